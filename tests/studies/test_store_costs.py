"""The store-cost study (``python -m hertzian.studies.store_costs``): its byte flips are classified by what a read
returns, and its record keeps the other parts of the file it writes into."""

import json
import sys

import numpy as np
from hertzian.studies import store_costs


def test_flips_are_caught_by_the_checksum_and_counted_without_it():
    data = np.repeat(np.arange(64.0), 16)  # compressible, like a store's zeros ahead of a pulse
    out = store_costs.flip_outcomes(data, flips=30, seed=3, chunks=4)
    assert out["with_checksum"] == {"raised": 30, "silent": 0, "harmless": 0}
    assert sum(out["without_checksum"].values()) == 30 and out["without_checksum"]["silent"] > 0


def test_the_record_is_one_part_beside_the_others(tmp_path, monkeypatch):
    out = tmp_path / "cpu.json"
    out.write_text(json.dumps({"command": "hertzian bench", "parts": {"kernels": {"runs": []}}}))
    monkeypatch.setattr(store_costs, "simulated_field", lambda: np.linspace(0.0, 1.0, 4096))
    argv = ["store_costs", "--out", str(out), "--megabytes", "1", "--repeats", "1", "--flips", "4", "--scenes", "3"]
    monkeypatch.setattr(sys, "argv", argv)
    store_costs.main()
    parts = json.loads(out.read_text())["parts"]
    assert set(parts) == {"kernels", "store"}
    store = parts["store"]
    assert store["command"].startswith("python -m hertzian.studies.store_costs --out ")
    assert store["expansion"]["points"] == 100000 and store["expansion"]["scene_points"] == 3
    assert len(store["checksum"]["seconds"]["with_checksum"]["write"]) == 1
    assert store["flips"]["with_checksum"]["raised"] == 4
