"""``hertzian reproduce``: stores, PNGs and a JSON log per figure group; --quick runs on the CPU."""

from __future__ import annotations

import json

import pytest
import xarray as xr
from typer.testing import CliRunner

from hertzian.ensemble.cli import app
from hertzian.ensemble.reproduce import GROUPS, default_sweeps_dir, group_of

cli = CliRunner()


def test_every_group_has_its_sweep_file_and_figures_known_to_plot():
    from hertzian.ensemble.plot import FIGURES

    for name, group in GROUPS.items():
        assert (default_sweeps_dir() / group.sweep).is_file(), name
        assert set(group.figures) <= set(FIGURES), name
    assert group_of("fig10") == "fig9_10" and group_of("fig5_single") == "fig5_single"


def test_quick_group_writes_store_png_and_log(tmp_path):
    out = tmp_path / "out"
    result = cli.invoke(app, ["reproduce", "--quick", "--figure", "fig6", "--out-dir", str(out), "--device", "cpu"])
    assert result.exit_code == 0, result.output
    log = json.loads((out / "log.json").read_text())
    assert log["quick"] and log["device"] == "cpu" and log["figure_failures"] == 0
    (run,) = log["runs"]
    assert run["name"] == "fig6" and run["figures"] == {"fig6": "fig6.png"}
    assert run["wall_seconds"] > 0 and run["grain_steps_per_second"] > 0
    assert run["grain_steps"] == run["points"] * run["grains"] * run["steps"]
    assert 0 < run["energy_error_max"] < 1e-6        # SPEC's bound for a gear4 run at this step
    assert run["status_counts"] == {"0": run["points"]}
    assert (out / "fig6.png").read_bytes()[:4] == b"\x89PNG"
    with xr.open_zarr(out / "fig6.zarr") as ds:
        assert ds.sizes["grain"] == GROUPS["fig6"].quick["chain.grains"]
        assert float(ds.energy_error.max()) == pytest.approx(run["energy_error_max"], rel=0, abs=0)


def test_events_option_sets_every_group(tmp_path):
    # --events off: plain Gear steps in every group (the GPU's fast choice), recorded in the log and the store
    out = tmp_path / "off"
    result = cli.invoke(app, ["reproduce", "--quick", "--figure", "fig6", "--events", "off", "--out-dir", str(out),
                              "--device", "cpu"])
    assert result.exit_code == 0, result.output
    log = json.loads((out / "log.json").read_text())
    assert log["events"] == "off" and "--events off" in log["command"]
    (run,) = log["runs"]
    assert run["events"] == "off"
    with xr.open_zarr(out / "fig6.zarr") as ds:
        assert json.loads(ds.attrs["sweep"])["scene"]["integrator"]["events"] == "off"


@pytest.mark.parametrize("args,message", [
    (["--figure", "fig42"], "--figure = 'fig42': allowed:"),
    (["--events", "sometimes"], "--events = 'sometimes': auto or off"),
    (["--sweeps", "nowhere"], "--sweeps = 'nowhere': no paper_fig1.toml there"),
    (["--out-dir", "missing/deeper"], "--out-dir = 'missing/deeper': parent directory does not exist"),
])
def test_reproduce_bad_input_is_one_line_exit_2(tmp_path, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    result = cli.invoke(app, ["reproduce", "--quick", *args])
    assert result.exit_code == 2 and message in result.output and "Traceback" not in result.output
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_quick_reproduces_every_group_on_the_cpu(tmp_path):
    """The whole paper at --quick size (about 1.5 min on 2 CPU cores): every figure drawn, every run logged."""
    out = tmp_path / "all"
    result = cli.invoke(app, ["reproduce", "--quick", "--out-dir", str(out), "--device", "cpu"])
    assert result.exit_code == 0, result.output
    log = json.loads((out / "log.json").read_text())
    assert [r["name"] for r in log["runs"]] == list(GROUPS)
    for run in log["runs"]:
        assert all(not str(v).startswith("failed") for v in run["figures"].values()), run
        assert run["energy_error_max"] < 1e-5, run   # driven columns: |E − E0 − W| / max|W| at dt = 1.25e-4
    assert sorted(p.name for p in out.glob("*.png")) == sorted(
        {f"{n}.png" for n, g in GROUPS.items() if len(g.figures) == 1} | {"fig9.png", "fig10.png"})
