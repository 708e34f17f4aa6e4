"""``HERTZIAN_TIMELINE=PATH hertzian run``: the seconds since process start of each phase, written as JSON; the
kernel loads say which were compiled and which came from Warp's kernel cache."""

from __future__ import annotations

import json
import os
import time

from tests.cli.test_run_command import SCENE
from tests.helpers import hertzian

PHASES = [
    "cli_ready",
    "scene_loaded",
    "warp_initialised",
    "device_ready",
    "model_built",
    "kernels_loaded",
    "integrated",
    "store_written",
    "exit",
]
"""The phases of ``hertzian run`` in the order they end (``library_imported`` and ``store_imported`` between)."""


def _timed_run(tmp_path, name: str, cache):
    """``hertzian run`` of SCENE with its timeline; (process wall [s] measured outside, the timeline)."""
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE)
    timeline = tmp_path / f"{name}.json"
    env = {**os.environ, "HERTZIAN_TIMELINE": str(timeline), "WARP_CACHE_PATH": str(cache)}
    env["HERTZIAN_CACHE"] = str(cache / "calibration.json")
    start = time.perf_counter()
    result = hertzian("run", scene, "--device", "cpu", "--quiet", "--overwrite", "--out", tmp_path / "o.zarr", env=env)
    wall = time.perf_counter() - start
    assert result.returncode == 0, result.stderr
    return wall, json.loads(timeline.read_text())


def test_timeline_phases_in_order_within_the_process_wall(tmp_path):
    cache = tmp_path / "warp-cache"
    for name in ("cold", "warm"):
        wall, record = _timed_run(tmp_path, name, cache)
        names = [p["phase"] for p in record["phases"]]
        assert [n for n in names if n in PHASES] == PHASES, names
        seconds = [p["seconds"] for p in record["phases"]]
        assert all(0 <= a <= b for a, b in zip(seconds, seconds[1:])), seconds
        # the phases' durations add up to the exit mark, which the process wall seen from outside bounds
        assert sum(b - a for a, b in zip([0.0, *seconds], seconds)) == record["wall_seconds"] <= wall
        loads = next(p for p in record["phases"] if p["phase"] == "kernels_loaded")["variants"]
        assert loads and all(load["seconds"] >= 0 for load in loads)
        # an empty kernel cache compiles every variant; the same run again compiles none
        assert [load["cached"] for load in loads] == [name == "warm"] * len(loads), loads


def test_timeline_in_a_missing_folder_is_refused_in_one_line(tmp_path):
    env = {**os.environ, "HERTZIAN_TIMELINE": str(tmp_path / "nowhere" / "t.json")}
    result = hertzian("run", "--device", "cpu", "--out", tmp_path / "o.zarr", env=env)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and result.stderr.startswith("error: HERTZIAN_TIMELINE = "), result.stderr
    assert not (tmp_path / "o.zarr").exists() and not (tmp_path / "nowhere").exists()
