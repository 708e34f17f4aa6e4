"""Resume: a sweep killed (SIGKILL, a real subprocess) at any moment and resumed gives a store
whose arrays equal, bitwise, those of an uninterrupted run; a store from another sweep or
package version is refused."""

import signal
import subprocess
import time

import numpy as np
import pytest
import xarray as xr
import zarr
from hertzian.core.runner import run_scene
from hertzian.sweeping.manifest import write_manifest
from hertzian.sweeping.spec import load_sweep, sweep_scenes
from hertzian.sweeping.store import consolidate
from hertzian.sweeping.sweep_store import batch_records, completed_batches, differing_arrays, write_result

from tests.helpers import HERTZIAN, RESUME_BATCHES, RESUME_FLAGS, RESUME_SWEEP, sweep_cli


def assert_equal_to_reference(out, reference):
    assert differing_arrays(out, reference) == []
    ds = xr.open_zarr(out)
    assert (ds.status.values == 0).all()
    prov = ds.attrs["provenance"]
    assert prov["complete"] and prov["batches_done"] == RESUME_BATCHES
    assert completed_batches(out) == set(range(RESUME_BATCHES))


def kill_when(proc, condition, timeout=120.0) -> bool:
    """SIGKILL ``proc`` as soon as ``condition()`` holds; True if it was still running then."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            running = proc.poll() is None
            proc.send_signal(signal.SIGKILL)
            proc.wait()
            return running
        if proc.poll() is not None:
            return False
        time.sleep(0.002)
    proc.kill()
    raise AssertionError("condition never held")


def records(out):
    return len(completed_batches(out)) if out.exists() else 0


MOMENTS = {
    "while the store is created": lambda tmp, out: (
        out.exists() or any(p.name.startswith(".out.zarr.") for p in tmp.iterdir())
    ),
    "after the first batch": lambda tmp, out: records(out) >= 1,
    "in the middle": lambda tmp, out: records(out) >= 4,
}


@pytest.mark.parametrize("moment", list(MOMENTS))
def test_sigkill_then_resume_equals_an_uninterrupted_run(tmp_path, sweep_file, reference, moment):
    out = tmp_path / "out.zarr"
    proc = subprocess.Popen(
        [*HERTZIAN, "sweep", str(sweep_file), "--out", str(out), *RESUME_FLAGS],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    was_running = kill_when(proc, lambda: MOMENTS[moment](tmp_path, out))
    assert was_running, f"the sweep ended before it could be killed: {proc.stderr.read().decode()}"
    assert proc.returncode == -signal.SIGKILL
    assert records(out) < RESUME_BATCHES
    result = sweep_cli(sweep_file, "--out", out, "--resume", *RESUME_FLAGS)
    assert result.exit_code == 0, result.stderr
    assert_equal_to_reference(out, reference)


def test_batch_written_but_not_recorded_is_rerun(tmp_path, sweep_file, reference):
    """The window a kill can hit inside a batch: some of its data written, no completion record."""
    out = tmp_path / "out.zarr"
    assert sweep_cli(sweep_file, "--out", out, *RESUME_FLAGS).exit_code == 0
    group = zarr.open_group(str(out), mode="r+")
    group["batches/done"][4] = 0  # batch 4 is point (1, 1): its completion flag not yet written
    group["u"][1, 1] = 0.0
    group["status"][1, 1] = 7
    group["trace_v"][1, 1, 3] = np.nan
    (out / "u" / "c" / "stale.partial").write_bytes(b"half a chunk")
    assert differing_arrays(out, reference) == ["status", "trace_v", "u"]
    result = sweep_cli(sweep_file, "--out", out, "--resume", *RESUME_FLAGS)
    assert result.exit_code == 0, result.stderr
    assert "ran 1 of 9 batches" in result.stdout
    assert_equal_to_reference(out, reference)
    assert not list(out.rglob("*.partial"))


def test_resume_of_a_finished_store_runs_nothing(tmp_path, sweep_file, reference):
    out = tmp_path / "out.zarr"
    assert sweep_cli(sweep_file, "--out", out, *RESUME_FLAGS).exit_code == 0
    result = sweep_cli(sweep_file, "--out", out, "--resume", *RESUME_FLAGS)
    assert result.exit_code == 0 and "nothing to do: all 9 batches were complete" in result.stdout
    assert_equal_to_reference(out, reference)


def test_resume_without_a_store_starts_one(tmp_path, sweep_file, reference):
    out = tmp_path / "out.zarr"
    result = sweep_cli(sweep_file, "--out", out, "--resume", *RESUME_FLAGS)
    assert result.exit_code == 0, result.stderr
    assert_equal_to_reference(out, reference)


def test_resume_keeps_the_stores_batches(tmp_path, sweep_file, reference):
    out = tmp_path / "out.zarr"
    assert sweep_cli(sweep_file, "--out", out, *RESUME_FLAGS).exit_code == 0
    result = sweep_cli(sweep_file, "--out", out, "--resume", "--batch-size", "4", "--device", "cpu", "--quiet")
    assert result.exit_code == 0 and "batch size 4 ignored" in result.stderr


def _refused(result, expected):
    assert result.exit_code == 2, (result.stdout, result.stderr)
    lines = [ln for ln in result.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: --resume = ") and expected in lines[0], result.stderr


def test_resume_refuses_a_store_of_another_sweep(tmp_path, sweep_file):
    out = tmp_path / "out.zarr"
    assert sweep_cli(sweep_file, "--out", out, *RESUME_FLAGS).exit_code == 0
    before = (out / "zarr.json").read_text()
    other = tmp_path / "other.toml"
    other.write_text(RESUME_SWEEP.replace("1e-4]", "2e-4]"))
    _refused(sweep_cli(other, "--out", out, "--resume", *RESUME_FLAGS), "was made from a different sweep")
    _refused(
        sweep_cli(sweep_file, "--out", out, "--resume", "--set", "chain.mass=2", *RESUME_FLAGS),
        "was made from a different sweep",
    )
    assert (out / "zarr.json").read_text() == before


def test_resume_refuses_a_store_of_another_package_version(tmp_path, sweep_file):
    out = tmp_path / "out.zarr"
    assert sweep_cli(sweep_file, "--out", out, *RESUME_FLAGS).exit_code == 0
    root = zarr.open_group(str(out), mode="r+")
    root.attrs["provenance"] = {**root.attrs["provenance"], "package_version": "0.0.1"}

    consolidate(out)
    write_manifest(out, finished=completed_batches(out))  # as that version wrote it, manifest and all
    _refused(sweep_cli(sweep_file, "--out", out, "--resume", *RESUME_FLAGS), "package version 0.0.1")


def test_resume_refuses_a_run_store(tmp_path, sweep_file):
    scene = sweep_scenes(load_sweep(sweep_file))[0]
    out = write_result(tmp_path / "run.zarr", run_scene(scene, "cpu"))
    # a run is a sweep with no axes: its store is refused as another sweep's
    _refused(sweep_cli(sweep_file, "--out", out, "--resume", *RESUME_FLAGS), "made from a different sweep")
    root = zarr.open_group(str(out), mode="r+")
    del root.attrs["sweep_fingerprint"]
    consolidate(out)
    write_manifest(out, finished=completed_batches(out))
    _refused(sweep_cli(sweep_file, "--out", out, "--resume", *RESUME_FLAGS), "not a hertzian sweep store")
    bogus = tmp_path / "bogus.zarr"
    bogus.mkdir()
    (bogus / "zarr.json").write_text("{not json")
    _refused(sweep_cli(sweep_file, "--out", bogus, "--resume", *RESUME_FLAGS), "not a readable Zarr store")


def test_completion_records_say_where_each_batch_ran(reference):
    records = batch_records(reference, status_counts=True)
    assert len(records) == RESUME_BATCHES
    for index, record in enumerate(records):
        assert record["batch"] == index and record["points"] == 1 and record["device"] == "cpu"
        assert record["status_counts"] == {"0": 1} and record["grain_steps"] == 20 * 10000
