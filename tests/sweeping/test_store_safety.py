"""Data safety of stores: every chunk carries a CRC-32C (a damaged one raises or is named by ``hertzian verify``,
never read silently; ``--resume`` reruns its batch bitwise), storage faults end in one line and resume bitwise,
the store's estimate is checked against the free space, a second writer is refused, and batches are cut so that
a kill loses a bounded amount of work without changing a bit of the results."""

import errno
import math
import shutil

import numpy as np
import pytest
import zarr
import zarr.storage._local as zarr_local
from hertzian.core.runner import run_scene
from hertzian.core.solvers.chain import cpu_threads
from hertzian.sweeping import planner, storage, sweep_store
from hertzian.sweeping.integrity import verify_store
from hertzian.sweeping.spec import load_sweep, sweep_from_dict, sweep_scenes
from hertzian.sweeping.storage import StorageError, store_lock
from hertzian.sweeping.store_format import DAMAGE_ERRORS
from hertzian.sweeping.sweep_store import completed_batches, differing_arrays, write_result

from tests.helpers import RESUME_BATCHES, RESUME_FLAGS, invoke, sweep_cli


def one_error_line(result, *expected):
    lines = [ln for ln in result.stderr.splitlines() if ln.strip() and not ln.startswith(("note: ", "warning: "))]
    assert "Traceback" not in result.stderr and result.exception is None or isinstance(result.exception, SystemExit)
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    for text in expected:
        assert text in lines[0], lines[0]
    return lines[0]


@pytest.fixture
def store(tmp_path, reference):
    out = tmp_path / "out.zarr"
    shutil.copytree(reference, out)
    return out


def chunk_files(path):
    return sorted(p for p in path.rglob("*") if p.is_file() and p.name not in ("zarr.json", ".zattrs"))


def flip(file, offset, mask=0xFF):
    data = bytearray(file.read_bytes())
    data[offset % len(data)] ^= mask
    file.write_bytes(bytes(data))


def all_arrays(path):
    root = zarr.open_group(str(path), mode="r")
    out = {name: np.asarray(arr[...]) for name, arr in root.arrays()}
    out.update({f"batches/{name}": np.asarray(arr[...]) for name, arr in root["batches"].arrays()})
    return out


def same(a, b):
    return a.shape == b.shape and (a.tobytes() == b.tobytes() if a.dtype.kind not in "OTU" else np.array_equal(a, b))


def test_fifty_random_byte_flips_are_never_read_silently(store):
    """50 flips, each in a random chunk file at a random byte: reading every array raises the checksum error, and
    verify names the damage; 0 reads return wrong values."""
    original = all_arrays(store)
    files = chunk_files(store)
    rng = np.random.default_rng(35)
    silent, raised = [], 0
    for _ in range(50):
        file = files[rng.integers(len(files))]
        offset, mask = int(rng.integers(1 << 30)), int(rng.integers(1, 256))
        pristine = file.read_bytes()
        flip(file, offset, mask)
        try:
            read = all_arrays(store)
            wrong = [n for n in original if not same(read[n], original[n])]
            if wrong:
                silent.append((file.relative_to(store), wrong))
        except DAMAGE_ERRORS:
            raised += 1
        if not verify_store(store).damage:
            silent.append((file.relative_to(store), "verify"))
        file.write_bytes(pristine)
    assert silent == [] and raised == 50


def test_verify_names_the_damaged_point_and_resume_restores_it(store, sweep_file, reference):
    # batch 4 is point (1, 1): v_imp = 1e-2, l0 = 1e-5
    shard = store / "u" / "c" / "1" / "1"
    flip(next(p for p in sorted(shard.rglob("*")) if p.is_file()), 20)
    result = invoke("verify", str(store))
    assert result.exit_code == 1
    damaged = [ln for ln in result.stdout.splitlines() if ln.startswith("damaged: ")]
    assert damaged and all(ln.startswith("damaged: u: v_imp=0.01, l0=1e-05; batch 4:") for ln in damaged), damaged
    resumed = sweep_cli(sweep_file, "--out", store, "--resume", *RESUME_FLAGS)
    assert resumed.exit_code == 0, resumed.stderr
    assert "rerunning batches [4]" in resumed.stderr and "ran 1 of 9 batches" in resumed.stdout
    assert differing_arrays(store, reference) == []
    assert invoke("verify", str(store)).exit_code == 0


def test_resume_rebuilds_a_damaged_coordinate_and_rereads_a_damaged_flag(store, sweep_file, reference):
    flip(chunk_files(store / "l0")[0], 3)
    flip(chunk_files(store / "batches" / "done")[2], 1)
    assert {d.variable for d in verify_store(store).damage} == {"l0/c/0", "batches/done"}
    resumed = sweep_cli(sweep_file, "--out", store, "--resume", *RESUME_FLAGS)
    assert resumed.exit_code == 0, resumed.stderr
    assert differing_arrays(store, reference) == [] and completed_batches(store) == set(range(RESUME_BATCHES))
    assert verify_store(store).damage == []


def test_summarize_refuses_a_damaged_store_with_one_line(store):
    flip(chunk_files(store / "energy_error")[0], 5)
    result = invoke("summarize", str(store))
    assert result.exit_code == 1
    one_error_line(result, "damaged", "hertzian verify")


def test_a_store_without_checksums_opens_with_a_note(tmp_path, sweep_file, monkeypatch):
    monkeypatch.setattr(sweep_store, "chunk_codecs", lambda level=1: (zarr.codecs.ZstdCodec(level=level),))
    scene = sweep_scenes(load_sweep(sweep_file))[0]
    out = write_result(tmp_path / "old.zarr", run_scene(scene, device="cpu"))
    monkeypatch.undo()
    result = invoke("summarize", str(out))
    assert result.exit_code == 0 and "no chunk checksums" in result.stderr
    verified = invoke("verify", str(out))
    assert verified.exit_code == 0 and "no chunk checksums" in verified.stderr


def failing_writes(monkeypatch, code, after):
    """Make the store's file writes raise ``code`` once ``after`` chunk files under u/ have been written."""
    put, count = zarr_local._put, [0]

    def broken(path, value, exclusive=False):
        if "/u/" in str(path):
            count[0] += 1
            if count[0] > after:
                raise OSError(code, "injected", str(path))
        return put(path, value, exclusive)

    monkeypatch.setattr(zarr_local, "_put", broken)


@pytest.mark.parametrize("code", [errno.ENOSPC, errno.EACCES, errno.EROFS])
def test_a_storage_fault_mid_sweep_is_one_line_and_resume_is_bitwise(
    tmp_path, sweep_file, reference, monkeypatch, code
):
    out = tmp_path / "out.zarr"
    failing_writes(monkeypatch, code, after=3)
    result = sweep_cli(sweep_file, "--out", out, *RESUME_FLAGS)
    assert result.exit_code == 1
    line = one_error_line(result, "writing batch", f"errno {code}", str(out))
    if code == errno.ENOSPC:
        assert "the store needs about" in line and "free there" in line
    assert 0 < len(completed_batches(out)) < RESUME_BATCHES
    assert not list(out.rglob("*.partial"))
    monkeypatch.undo()
    resumed = sweep_cli(sweep_file, "--out", out, "--resume", *RESUME_FLAGS)
    assert resumed.exit_code == 0, resumed.stderr
    assert differing_arrays(out, reference) == []


def test_a_vanished_store_is_one_line(tmp_path, sweep_file):
    definition = load_sweep(sweep_file)
    plan = planner.plan_sweep(definition, None, "cpu")
    out = sweep_store.create_sweep_store(
        tmp_path / "s.zarr", definition, sweep_scenes(definition)[0], plan, device="cpu"
    )
    shutil.rmtree(out)
    with pytest.raises(StorageError, match="finishing the store failed at .*No such file.*removed while the sweep"):
        sweep_store.finalize(out)
    assert not out.exists()


def test_a_store_larger_than_the_free_space_is_refused_before_the_start(tmp_path, sweep_file, monkeypatch):
    out = tmp_path / "out.zarr"
    monkeypatch.setattr(storage.shutil, "disk_usage", lambda path: shutil._ntuple_diskusage(10**9, 10**9, 1000))
    result = sweep_cli(sweep_file, "--out", out, *RESUME_FLAGS)
    assert result.exit_code == 2
    one_error_line(result, "--out = ", "the store needs about", "1000 B free")
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_a_second_writer_is_refused(tmp_path, sweep_file):
    out = tmp_path / "out.zarr"
    with store_lock(out):
        result = sweep_cli(sweep_file, "--out", out, *RESUME_FLAGS)
        assert result.exit_code == 2
        one_error_line(result, "is being written by pid")
        assert not out.exists()
    assert not storage.lock_path(out).exists()
    assert sweep_cli(sweep_file, "--out", out, *RESUME_FLAGS).exit_code == 0


@pytest.mark.parametrize("size", ["3", "9"])
def test_batch_size_changes_no_bit(tmp_path, sweep_file, reference, size):
    out = tmp_path / "out.zarr"
    result = sweep_cli(sweep_file, "--out", out, "--batch-size", size, "--device", "cpu", "--quiet")
    assert result.exit_code == 0, result.stderr
    assert differing_arrays(out, reference) == []


@pytest.mark.parametrize("kind", ["cpu", "cuda"])
def test_a_long_sweep_is_cut_into_batches_a_kill_can_afford(kind):
    """4096 chains of 1000 grains and 10⁶ steps: 4e12 grain-steps, 4e5 s on a CPU. Every batch holds at most
    LOST_WORK_SECONDS of work at the safe rate, or 5 % of the sweep."""
    definition = sweep_from_dict(
        {
            "scene": {"chain": {"grains": 1000}, "integrator": {"dt": 1e-4, "duration": 100.0}},
            "axis": [{"name": "v_imp", "key": "excitation.impact", "linspace": [1e-3, 1e-1, 4096]}],
        }
    )
    plan = planner.plan_sweep(definition, None, "cpu")
    groups = plan.groups
    cap = planner.work_cap(groups, kind, 1000)
    limit = max(planner.LOST_WORK_SECONDS * planner.SAFE_RATE[kind], planner.LOST_WORK_FRACTION * plan.grain_steps)
    per_chain = groups[0].grain_steps_per_chain
    floor = planner.GPU_FILL_GRAIN_THREADS // 1000 if kind == "cuda" else cpu_threads()
    assert cap * per_chain <= max(limit, floor * per_chain) < (cap + 1) * per_chain
    if kind == "cpu":
        assert len(plan.batches) >= 20 and max(plan.batch_grain_steps(b) for b in plan.batches) <= limit


def test_a_long_cpu_sweep_keeps_every_core_busy():
    """Six long chains (the Sec. VI column): each batch holds at least one chain per thread of the chain kernel,
    though one chain alone is more work than a kill may cost."""
    definition = sweep_from_dict(
        {
            "scene": {"chain": {"grains": 10000}, "integrator": {"dt": 1.25e-4, "duration": 1000.0}},
            "axis": [{"name": "v_imp", "key": "excitation.impact", "linspace": [1e-3, 1e-1, 6]}],
        }
    )
    plan = planner.plan_sweep(definition, None, "cpu")
    assert min(math.prod(plan.block), 6) >= min(cpu_threads(), 6)
