"""Scale-out: two Dask worker processes (CPU, one thread each) fill one store, equal bitwise to the
serial run; each worker writes its own batches."""

import distributed  # a hard dependency (dask[distributed]): a missing one must fail, not skip
import pytest
from hertzian.sweeping.distributed import ClusterStart, worker_device
from hertzian.sweeping.sweep_store import batch_records, differing_arrays

from tests.helpers import invoke

SWEEP = """
[scene.chain]
grains = 16

[scene.excitation]
impact = 1e-2

[scene.integrator]
method = "verlet"
dt = 1e-4
duration = 0.05

[scene.record]
every = 0.01
traces = [3]

[[axis]]
name = "v_imp"
key = "excitation.impact"
logspace = [-3, -1, 4]

[[axis]]
name = "l0"
key = "chain.l0"
values = [1e-5, 1e-4]

[[axis]]
name = "gravity"
key = "chain.gravity"
values = [0.0, 1.0]
"""


def test_two_workers_write_one_store_equal_to_the_serial_run(tmp_path):
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(SWEEP)
    flags = ("--batch-size", "2", "--device", "cpu", "--quiet")
    serial = tmp_path / "serial.zarr"
    result = invoke("sweep", str(sweep), "--out", str(serial), *flags)
    assert result.exit_code == 0, result.stderr
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        parallel = tmp_path / "parallel.zarr"
        result = invoke("sweep", str(sweep), "--out", str(parallel), "--scheduler", cluster.scheduler_address, *flags)
        assert result.exit_code == 0, result.stderr
    assert differing_arrays(parallel, serial) == []
    records = batch_records(parallel)
    assert len(records) == 8 and sum(r["points"] for r in records) == 16
    assert {r["worker"] for r in records} == {"0", "1"}  # both workers wrote batches
    local = tmp_path / "local.zarr"  # --workers 2 starts its own LocalCluster
    result = invoke("sweep", str(sweep), "--out", str(local), "--workers", "2", *flags)
    assert result.exit_code == 0 and "on 2 local Dask workers" in result.stdout, result.stderr
    assert differing_arrays(local, serial) == []


def test_the_sweeps_client_is_not_the_processs_default_scheduler():
    """A sweep's client, to a scheduler or to its own workers, leaves dask's default alone: a store loaded by the
    caller meanwhile or later is not computed on workers the sweep closes (it would wait for them forever)."""
    with distributed.LocalCluster(n_workers=1, processes=False, dashboard_address=None) as cluster:
        for start in (ClusterStart(scheduler=cluster.scheduler_address), ClusterStart(workers=1, gpus=[])):
            try:
                assert start.client().scheduler_info()["workers"]
                with pytest.raises(ValueError, match="No clients found"):
                    distributed.default_client()
            finally:
                start.close()


def test_workers_pick_their_own_gpu():
    import warp as wp

    assert worker_device("cpu", 1) == "cpu"
    assert worker_device("cuda:1", 0) == "cuda:1"
    if wp.is_cuda_available():
        count = wp.get_cuda_device_count()
        assert worker_device(None, 1) == f"cuda:{1 % count}"
        assert worker_device("cuda", "tcp://host:1234") == "cuda:0"
    else:
        assert worker_device(None, 1) == "cpu"
