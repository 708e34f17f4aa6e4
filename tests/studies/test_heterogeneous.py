"""The heterogeneous-chain study's command line: its CPU size, the shipped sizes (``--shipped``) and ``--device``
reach the sweeps it runs, without running the shipped sizes here."""

from __future__ import annotations

import tomllib

import pytest
from hertzian.core.errors import OptionError
from hertzian.studies import heterogeneous
from hertzian.studies.heterogeneous import SHIPPED_EVENTS, arguments, study


def _seeds(data: dict) -> int:
    (axis,) = [a for a in data["axis"] if a["name"] == "seed"]
    return int(axis["linspace"][2]) if "linspace" in axis else len(axis["values"])


def test_shipped_runs_the_sweeps_as_shipped_with_plain_steps(tmp_path):
    out, sweeps, device, _ = arguments([str(tmp_path / "out.json"), "--shipped", "--device", "cpu"])
    assert device == "cpu"
    taper, disorder = sweeps["taper"], sweeps["disorder"]
    assert taper["scene"]["chain"]["grains"] == 100 and taper["scene"]["record"]["traces"] == [99]
    assert len(taper["axis"][0]["values"]) == 9 and taper["scene"]["integrator"]["duration"] == 12.0
    assert disorder["scene"]["chain"]["grains"] == 200 and disorder["scene"]["integrator"]["duration"] == 20.0
    assert _seeds(disorder) == 1000 and len(disorder["axis"][0]["values"]) == 6
    for data in sweeps.values():
        assert data["scene"]["integrator"]["events"] == SHIPPED_EVENTS == "off"
    assert (taper["scene"]["integrator"]["dt"], disorder["scene"]["integrator"]["dt"]) == (2e-6, 5e-5)
    _, halved, _, part = arguments(
        [str(out), "--shipped", "--only", "taper", "--dt", "1e-6", "--device", "cpu", "--part", "dt2"]
    )
    assert part == "dt2"
    assert list(halved) == ["taper"] and halved["taper"]["scene"]["integrator"]["dt"] == 1e-6
    assert halved["taper"]["scene"]["record"]["trace_every"] == 2e-5  # still 20 steps: the same samples
    _, sweeps, _, _ = arguments([str(out), "--shipped", "--events", "auto", "--device", "cpu"])
    assert sweeps["disorder"]["scene"]["integrator"]["events"] == "auto"
    _, few, _, _ = arguments([str(out), "--shipped", "--only", "disorder", "--seeds", "8", "--device", "cpu"])
    assert _seeds(few["disorder"]) == 8 and few["disorder"]["scene"]["chain"]["grains"] == 200
    _, fine, _, _ = arguments([str(out), "--shipped", "--trace-every", "5e-5", "--device", "cpu"])
    assert fine["disorder"]["scene"]["record"]["trace_every"] == fine["taper"]["scene"]["record"]["trace_every"] == 5e-5


@pytest.mark.parametrize("option", [["--seeds", "0"], ["--grains", "1"], ["--trace-every", "0.0"], ["--dt", "-1.0"]])
def test_sizes_that_cannot_run_are_refused_in_one_line(tmp_path, option, capsys):
    with pytest.raises(SystemExit) as exit_info:
        arguments([str(tmp_path / "out.json"), *option, "--device", "cpu"])
    assert exit_info.value.code == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"error: {option[0]} = {option[1]}: must be ")


def test_the_cpu_size_is_the_default_and_keeps_the_shipped_events(tmp_path):
    _, sweeps, device, _ = arguments([str(tmp_path / "out.json"), "--device", "cpu"])
    assert device == "cpu"
    taper, disorder = sweeps["taper"], sweeps["disorder"]
    assert taper["scene"]["chain"]["grains"] == disorder["scene"]["chain"]["grains"] == 40
    assert taper["scene"]["record"]["traces"] == [39] and disorder["scene"]["record"]["traces"] == [39]
    assert (taper["scene"]["integrator"]["duration"], disorder["scene"]["integrator"]["duration"]) == (6.0, 4.0)
    assert _seeds(disorder) == 20
    assert "events" not in taper["scene"]["integrator"] and "events" not in disorder["scene"]["integrator"]


def test_the_device_reaches_the_sweep_and_the_file_round_trips(tmp_path, monkeypatch):
    import hertzian.sweeping.pipeline as pipeline
    import xarray as xr

    seen = {}
    monkeypatch.setattr(pipeline, "sweep", lambda path, out, **options: seen.update(path=path, **options))
    monkeypatch.setattr(xr, "open_zarr", lambda path: path)
    _, sweeps, _, _ = arguments([str(tmp_path / "out.json"), "--shipped", "--device", "cpu"])
    heterogeneous._run(sweeps["disorder"], "disorder", tmp_path, "cuda:3")
    assert seen["device"] == "cuda:3"
    assert tomllib.loads(seen["path"].read_text()) == sweeps["disorder"]


def test_an_absent_device_is_one_clear_line(tmp_path):
    with pytest.raises(OptionError, match="device"):
        arguments([str(tmp_path / "out.json"), "--device", "cuda:9"])


def test_a_small_cpu_study_reports_each_sweeps_wall_time_and_settings():
    _, sweeps, device, _ = arguments(["out.json", "--device", "cpu", "--grains", "12", "--seeds", "2"])
    record = study(device=device, sweeps=sweeps)
    assert record["device"] == "cpu" and record["grains"] == 12
    for name in ("taper", "disorder"):
        assert record[name]["seconds"] > 0 and record[name]["events"] == "auto" and record[name]["dt"] == 5e-5
    assert record["disorder"]["realisations"] == 2 and len(record["disorder"]["decay_length_mean"]) == 6


def test_the_record_keeps_its_command_and_a_users_file_is_refused(tmp_path, monkeypatch, capsys):
    import json
    import sys

    from hertzian.studies.heterogeneous import main

    out = tmp_path / "out.json"
    argv = [str(out), "--device", "cpu", "--grains", "12", "--seeds", "2", "--only", "taper"]
    monkeypatch.setattr(sys, "argv", ["heterogeneous", *argv])
    main()
    record = json.loads(out.read_text())
    assert record["command"] == "python -m hertzian.studies.heterogeneous " + " ".join(argv)
    main()  # its own record is replaced
    mine = tmp_path / "mine.json"
    mine.write_text('{"my": 1}')
    monkeypatch.setattr(sys, "argv", ["heterogeneous", str(mine), "--device", "cpu"])
    with pytest.raises(SystemExit) as refused:
        main()
    assert refused.value.code == 2 and "hertzian did not write it" in capsys.readouterr().err
    assert mine.read_text() == '{"my": 1}'


def test_a_sweep_the_options_break_is_refused_before_it_runs(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        arguments(
            [str(tmp_path / "out.json"), "--shipped", "--only", "taper", "--trace-every", "3.3e-6", "--device", "cpu"]
        )
    assert exit_info.value.code == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("error: the taper sweep: record.trace_every = 3.3e-06: must be a whole number of steps")
    assert not (tmp_path / "out.json").exists()
