"""Scale-out on CPU workers: LocalCUDACluster-like worker specs, balanced tails that keep every bit, and a worker
killed with SIGKILL mid-sweep (its batch runs again elsewhere; the store equals the serial one)."""

import json
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import zarr
from hertzian.studies.worker_kill import kill_one_worker
from hertzian.sweeping.balance import TAIL_TOLERANCE, balance_plan, batch_priorities, makespan, tail_excess
from hertzian.sweeping.distributed import cuda_visible_devices, local_cluster
from hertzian.sweeping.planner import plan_sweep
from hertzian.sweeping.spec import expand, sweep_from_dict
from hertzian.sweeping.sweep_store import batch_records, completed_batches, differing_arrays

from tests.helpers import HERTZIAN, assert_refused, invoke, sweep_cli

SWEEP = """
[scene.chain]
grains = 16

[scene.excitation]
impact = 1e-2

[scene.integrator]
method = "verlet"
dt = 1e-5
duration = {duration}

[scene.record]
every = 0.01
traces = [3]

[[axis]]
name = "v_imp"
key = "excitation.impact"
logspace = [-3, -1, {speeds}]

[[axis]]
name = "gravity"
key = "chain.gravity"
values = [0.0, 1.0]
"""


def write_sweep(tmp_path, *, speeds: int, duration: float):
    path = tmp_path / "sweep.toml"
    path.write_text(SWEEP.format(speeds=speeds, duration=duration))
    return path


def sweep(path, out, *flags):
    result = sweep_cli(path, "--out", out, "--device", "cpu", "--quiet", *flags)
    assert result.exit_code == 0, result.stderr or str(result.exception)
    return result


def test_makespan_hands_out_batches_biggest_first():
    assert makespan([1.0] * 9, 4) == 3.0  # 9 equal batches on 4 workers: three rounds
    assert makespan([3, 5, 3, 4, 3], 2) == 10  # 5 | 4, then 3 → 7, 3 → 8, 3 → 10
    assert makespan([], 3) == 0.0


def test_balanced_plan_tiles_the_grid_and_finishes_together():
    import tomllib

    definition = sweep_from_dict(tomllib.loads(SWEEP.format(speeds=48, duration=0.01)))
    points = expand(definition)
    plan = plan_sweep(definition, points, "cpu", batch_size=10)  # 9 batches of 10 points and one of 6
    assert len(plan.batches) == 10 and tail_excess(plan, 4) > 0.2
    balanced = balance_plan(plan, 4)
    assert tail_excess(balanced, 4) <= TAIL_TOLERANCE
    assert balanced.batch_size >= plan.batch_size // 4 and balanced.block != plan.block
    covered = np.zeros(definition.shape, dtype=np.int64)
    for b in balanced.batches:
        covered[b.slices] += 1
    assert (covered == 1).all()
    assert balance_plan(plan, 1) is plan
    # 90 points: no block of 3 to 10 points splits evenly over 4 workers; the best found is kept
    odd = sweep_from_dict(tomllib.loads(SWEEP.format(speeds=45, duration=0.01)))
    odd_plan = plan_sweep(odd, expand(odd), "cpu", batch_size=10)
    assert TAIL_TOLERANCE < tail_excess(balance_plan(odd_plan, 4), 4) < tail_excess(odd_plan, 4)
    priorities = batch_priorities(balanced, range(len(balanced.batches)))
    order = sorted(priorities, key=priorities.get, reverse=True)
    sizes = [balanced.batches[i].size for i in order]
    assert sizes == sorted(sizes, reverse=True) and sorted(priorities.values()) == list(range(1, len(order) + 1))


def test_each_worker_sees_only_its_own_gpu():
    gpus = ["0", "1", "2", "3"]
    assert [cuda_visible_devices(i, gpus) for i in range(4)] == ["0", "1", "2", "3"]
    assert cuda_visible_devices(5, ["4", "6"]) == "6"  # more workers than GPUs: they take turns


def test_three_workers_with_a_balanced_block_write_the_serial_store_bit_for_bit(tmp_path):
    """The balanced block differs from the serial run's, so each point runs in a batch of other points; the
    gravity axis makes batches differ in their static features (the launch group's variant covers them all)."""
    path = write_sweep(tmp_path, speeds=5, duration=0.05)
    sweep(path, tmp_path / "serial.zarr", "--batch-size", "3")
    result = sweep(path, tmp_path / "three.zarr", "--batch-size", "4", "--workers", "3", "--json")
    assert "on 3 local Dask workers" in result.stderr
    blocks = [zarr.open_group(str(tmp_path / s), mode="r").attrs["sweep_block"] for s in ("serial.zarr", "three.zarr")]
    assert blocks[0] != blocks[1]
    assert differing_arrays(tmp_path / "three.zarr", tmp_path / "serial.zarr") == []
    assert len({r["worker"] for r in batch_records(tmp_path / "three.zarr")}) >= 2


def test_local_workers_follow_local_cuda_cluster_semantics():
    import dask

    # the GPU ids are made up: on a GPU host, distributed's NVML monitor would fail on them, so it is off here
    with dask.config.set({"distributed.diagnostics.nvml": False}), local_cluster(2, gpus=["5", "7"]) as cluster:
        from distributed import Client
        from distributed.system import MEMORY_LIMIT

        with Client(cluster) as client:
            info = client.scheduler_info(n_workers=-1)["workers"]
            assert sorted(w["name"] for w in info.values()) == [0, 1]
            assert {w["memory_limit"] for w in info.values()} == {MEMORY_LIMIT // 2}
            assert {w["nthreads"] for w in info.values()} == {1}
            assert {
                client.run(lambda: os.environ["CUDA_VISIBLE_DEVICES"], workers=[a])[a]: w["name"]
                for a, w in info.items()
            } == {"5": 0, "7": 1}  # worker i sees GPU i only
            assert all(client.run(lambda: "hertzian.core.runner" in sys.modules).values())  # preloaded


def test_a_worker_killed_mid_sweep_leaves_the_serial_store(tmp_path):
    """hertzian.studies.worker_kill, the measurement docs/scale-out.md reports on GPUs, on two CPU workers."""
    path = write_sweep(tmp_path, speeds=6, duration=0.3)  # 12 batches of one point
    found = kill_one_worker(path, ["--batch-size", "1"], tmp_path, "cpu")
    assert found["returncode"] == 0
    assert 0 < found["done_at_kill"] < 12  # killed mid-sweep
    assert not found["victim_alive_after"]
    assert found["batches_completed"] == 12
    assert found["differing_arrays"] == []


def _fail_batch(index: int, how: str):
    """On a worker: make batch ``index`` fail the way a real one can (a CUDA error raised, or the process gone before
    or right after the batch is written)."""

    def patch():
        import hertzian.sweeping.distributed as distributed

        run_job = distributed.__dict__.setdefault("unpatched_run_job", distributed.run_job)

        def failing(job, *args, **kwargs):
            if job.batch.index == index:
                if how == "written, then exit":
                    run_job(job, *args, **kwargs)
                    os._exit(1)
                if how == "exit":
                    os._exit(1)
                raise RuntimeError("Warp CUDA error 2: out of memory\n(while launching the step kernel)")
            return run_job(job, *args, **kwargs)

        distributed.run_job = failing

    return patch


def _one_line_failure(result, batches: str) -> str:
    text = (result.stdout + result.stderr).strip()
    assert result.exit_code == 1, (result.exit_code, text, result.exception)
    assert "Traceback" not in text and len(text.splitlines()) == 1, text
    assert re.match(f"error: batch [{batches}] failed on worker [01]: ", text), text
    assert text.endswith("--resume"), text
    return text


def test_a_failing_batch_is_one_line_and_the_store_resumes(tmp_path):
    import dask
    from distributed import Client  # before dask.config.set: leaving it must not drop distributed's defaults

    path = write_sweep(tmp_path, speeds=3, duration=0.05)  # 6 batches of one point
    sweep(path, tmp_path / "serial.zarr", "--batch-size", "1")
    store = tmp_path / "failed.zarr"
    flags = ("--device", "cpu", "--quiet", "--batch-size", "1", "--scheduler")
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), local_cluster(2, gpus=[]) as cluster:
        with Client(cluster) as client:  # closed before the sweep: its own client runs in this process
            client.run(_fail_batch(2, "raise"))
        text = _one_line_failure(sweep_cli(path, "--out", store, *flags, cluster.scheduler_address), "2")
        assert "RuntimeError: Warp CUDA error 2: out of memory (while launching the step kernel)" in text
        with Client(cluster) as client:
            client.run(_fail_batch(4, "exit"))
        killed = _one_line_failure(
            sweep_cli(path, "--out", tmp_path / "k.zarr", *flags, cluster.scheduler_address), "0-5"
        )
        # the batch named is one the dead worker held (batch 4, or another queued or running there): not complete
        assert "KilledWorker: its worker died on each of 1 attempts" in killed
        named = int(re.match(r"error: batch (\d+)", killed).group(1))
        assert {4, named}.isdisjoint(completed_batches(tmp_path / "k.zarr"))
    assert completed_batches(store) == {0, 1, 3, 4, 5}
    sweep(path, store, "--batch-size", "1", "--resume")
    assert differing_arrays(store, tmp_path / "serial.zarr") == []


def test_a_worker_dying_after_writing_its_batch_loses_nothing(tmp_path):
    """The worker of the last batch dies once that batch is written, before Dask has its small result: the sweep
    counts the batch as done (its completion flag is set) and ends well, its store equal to a serial one."""
    import dask
    from distributed import Client  # before dask.config.set: leaving it must not drop distributed's defaults

    path = write_sweep(tmp_path, speeds=3, duration=0.05)  # 6 batches of one point
    sweep(path, tmp_path / "serial.zarr", "--batch-size", "1")
    store = tmp_path / "late.zarr"
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), local_cluster(2, gpus=[]) as cluster:
        with Client(cluster) as client:
            client.run(_fail_batch(5, "written, then exit"))
        flags = ("--device", "cpu", "--quiet", "--batch-size", "1", "--scheduler", cluster.scheduler_address)
        result = sweep_cli(path, "--out", store, *flags)
    assert result.exit_code == 0, result.output
    assert completed_batches(store) == set(range(6))
    assert differing_arrays(store, tmp_path / "serial.zarr") == []


SCALE = Path(__file__).parents[2] / "sweeps" / "scale.toml"
TINY = ("chain.grains=8", "integrator.duration=0.01", "record.every=0.005", "record.trace_every=0.001")
TINY_SETS = [*TINY, "record.traces=[0,7]"]  # sweeps/scale.toml's header: 2.6e7 grain-steps, about a second on a CPU


def _scale_flags(*flags):
    sets = [a for s in TINY_SETS for a in ("--set", s)]
    return ["bench", "--device", "cpu", "--scale-out", "2", "--sweep", SCALE, *sets, *flags]


def test_scale_out_record_is_whole_after_every_run(tmp_path):
    """Each finished run's line comes after the record file holds it; the stores are compared and gone."""
    from hertzian.studies.scaling import scale_out

    path, seen = tmp_path / "record.json", []

    def log(line):
        if line.startswith(("strong ", "weak ")) and " s, " in line:
            record = json.loads(path.read_text())
            seen.append((line.split(":")[0], len(record["strong"]), len(record["weak"]), record["complete"]))

    record = scale_out(
        SCALE, [2], sets=TINY_SETS, device="cpu", workdir=tmp_path / "w", weak=True, record_path=path, log=log
    )
    assert seen == [
        ("strong serial", 1, 0, False),
        ("strong --workers 2", 2, 0, False),
        ("weak serial", 2, 1, False),
        ("weak --workers 2", 2, 2, False),
    ]
    assert json.loads(path.read_text()) == record and record["complete"] and record["skipped"] == []
    assert record["strong"][1]["differing_arrays"] == [] and record["bitwise_equal"]
    assert record["weak"][0]["duration"] == 0.005 and record["weak"][1]["duration"] == 0.01
    assert list((tmp_path / "w").iterdir()) == []


def test_a_killed_scale_out_keeps_its_finished_runs(tmp_path):
    """SIGKILL to the measurement (and its sweep) once the serial run is reported: the record holds that run."""
    path = tmp_path / "record.json"
    command = [*HERTZIAN, *map(str, _scale_flags("--scale-json", path))]
    bench = subprocess.Popen(command, cwd=tmp_path, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        for line in bench.stderr:
            if line.startswith("strong serial:"):
                break
    finally:
        os.killpg(bench.pid, signal.SIGKILL)
        bench.wait()
    record = json.loads(path.read_text())
    assert [r["label"] for r in record["strong"]] == ["serial"] and not record["complete"]
    assert record["strong"][0]["speedup"] == 1.0 and record["grain_steps"] == 16000 * 8 * 200


def test_scale_budget_skips_the_runs_that_would_not_fit(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the stores' temporary directory
    assert_refused(
        invoke(*_scale_flags("--scale-budget", "0", "--scale-json", "r.json")), tmp_path / "r.json", "--scale-budget"
    )
    result = invoke(*_scale_flags("--scale-budget", "0.5", "--scale-weak", "--json"))
    assert result.exit_code == 0, result.stderr or str(result.exception)
    record = json.loads(result.stdout)
    assert [r["label"] for r in record["strong"]] == ["serial"] and record["weak"] == []
    assert [s["run"] for s in record["skipped"]] == ["strong --workers 2", "weak serial", "weak --workers 2"]
    assert all(s["estimated_seconds"] > s["seconds_left"] for s in record["skipped"])
    assert "skipped strong --workers 2: estimated" in result.stderr


def _register_exit_marker(folder: str) -> None:
    """In a worker: an exit handler that leaves a file named for this process (it runs only in a full teardown)."""
    import atexit

    atexit.register(Path(folder, str(os.getpid())).write_text, "teardown")


def test_closing_a_local_cluster_ends_its_workers_without_their_teardown(tmp_path):
    """The workers end at the preload's teardown (os._exit): no exit handler of theirs runs, and none is left alive."""
    import psutil
    from distributed import Client

    with local_cluster(2, gpus=[]) as cluster, Client(cluster) as client:
        pids = list(client.run(os.getpid).values())
        client.run(_register_exit_marker, str(tmp_path))
    assert len(pids) == 2
    gone = [not psutil.pid_exists(pid) or psutil.Process(pid).status() == psutil.STATUS_ZOMBIE for pid in pids]
    assert all(gone), pids
    assert list(tmp_path.iterdir()) == []  # a worker that closed the usual way would have run its exit handler
