"""Host-side cuts of a sweep's batches: each gives the same bits as the path it replaces.

* the static state solved once per distinct static configuration equals every chain's own
  ``static_state`` (the per-scene reference);
* a serial sweep that prepares batch b + 1's host arrays in a background thread while batch b runs
  writes the same store as one that does not (and both equal the per-scene runs, tests/sweeping/test_sweep.py);
* reused host staging buffers give the same records as fresh ones;
* records written into the store while their batch still runs (sweep_store.RowWriter) give the same store as
  a batch written at its end.
"""

import numpy as np
import pytest
from hertzian.core.chains import ChainSet
from hertzian.core.model import build_model, prepare_model
from hertzian.core.recorder import STAGING
from hertzian.core.runner import Runner
from hertzian.core.scene import scene_from_dict
from hertzian.core.static import distinct_static_rows, static_arrays, static_state
from hertzian.sweeping.distributed import jobs_for, run_serial
from hertzian.sweeping.planner import plan_sweep
from hertzian.sweeping.spec import expand, sweep_from_dict
from hertzian.sweeping.sweep_store import create_sweep_store, differing_arrays

BASE = {
    "chain": {"grains": 12, "l0": 1e-4},
    "impurities": [{"grains": [5], "mass": 2.0}],
    "excitation": {"impact": 1e-2},
    "integrator": {"method": "gear4", "dt": 2e-4, "duration": 0.02},
    "record": {"every": 0.01, "fields": ["u", "v"], "traces": [0, 11], "trace_every": 0.002},
}


def test_shared_static_rows_equal_each_chains_own_static_state():
    template = scene_from_dict(BASE)
    # 3 impact speeds (not read by the static state) × 2 impurity masses × 2 precompressions: 4 configurations
    impact = np.repeat([1e-3, 1e-2, 5e-2], 4)
    mass = np.tile([0.5, 2.0], 6)
    l0 = np.tile([0.0, 0.0, 1e-4, 1e-4], 3)
    chains = ChainSet.of(template, {"excitation.impact": impact, "impurities.0.mass": mass, "chain.l0": l0}, 12)
    first, inverse = distinct_static_rows(chains)
    assert len(first) == 4 and inverse.shape == (12,)  # the shared path is the one taken
    st = static_arrays(chains)
    for c in range(len(chains)):
        ref = static_state(chains[c])
        for name in ("mass", "self_constant", "contact_constant", "carried_force", "static_overlap"):
            assert getattr(st, name)[c].tobytes() == getattr(ref, name).tobytes(), (c, name)
        assert st.exponent[c] == ref.exponent and st.surface_force[c] == ref.surface_force


SWEEP = {
    "scene": {**BASE, "chain": {"grains": 12, "gravity": 0.5}},
    "axis": [
        {"name": "v_imp", "key": "excitation.impact", "values": [1e-3, 1e-2, 3e-2]},
        {"name": "l0", "key": "chain.l0", "values": [1e-5, 1e-4]},
        {"name": "m_imp", "key": "impurities.0.mass", "values": [0.5, 2.0]},
    ],
}


def _store(tmp_path, name, overlap, timing=None, sweep=SWEEP, **options):
    sweep = sweep_from_dict(sweep)
    points = expand(sweep)
    plan = plan_sweep(sweep, points, "cpu", batch_size=2)
    out = tmp_path / name
    create_sweep_store(out, sweep, points.templates[0], plan, device="cpu")
    run_serial(jobs_for(out, plan, points, plan.batches), "cpu", overlap=overlap, timing=timing, **options)
    return out, len(plan.batches)


def test_overlapped_preparation_writes_the_same_store(tmp_path):
    serial, batches = _store(tmp_path, "serial.zarr", overlap=False)
    timing = {}
    overlapped, _ = _store(tmp_path, "overlapped.zarr", overlap=True, timing=timing)
    assert batches >= 3  # a preparation ran while an earlier batch ran
    assert timing["prepare"] > 0
    assert differing_arrays(overlapped, serial) == []


def test_records_written_while_the_batch_runs_give_the_same_store(tmp_path, monkeypatch):
    import zarr
    from hertzian.sweeping import sweep_store

    # 5 records, 5 trace samples between two: the traces' shards hold 5 samples, u's and v's one record
    sweep = dict(SWEEP, scene={**SWEEP["scene"], "integrator": {**BASE["integrator"], "duration": 0.04}})
    at_end = []
    final_write = sweep_store.write_batch

    def spy(path, batch, result, **kw):
        rows = kw.get("rows")
        at_end.append(dict(rows.written) if rows is not None else None)
        return final_write(path, batch, result, **kw)

    monkeypatch.setattr(sweep_store, "write_batch", spy)
    monkeypatch.setattr(sweep_store, "ROW_SHARD_BYTES", 1)  # a shard per record (interval) however small
    at_once, batches = _store(tmp_path, "at_once.zarr", overlap=False, sweep=sweep, rows_while_running=False)
    assert at_end == [None] * batches
    at_end.clear()
    timing = {}
    running, _ = _store(tmp_path, "running.zarr", overlap=False, sweep=sweep, rows_while_running=True, timing=timing)
    group = zarr.open_group(str(running), mode="r")
    outer = {name: group[name].shards or group[name].chunks for name in ("u", "trace_v")}
    assert outer["u"][3] == 1 and outer["trace_v"][3] == 5 and group["u"].shape[3] == 5
    # every record and the trace samples 0…19 went through the RowWriter; the final write had sample 20 left
    assert at_end == [{"u": 5, "v": 5, "trace_u": 20, "trace_v": 20}] * batches
    assert timing["store"] > 0
    assert differing_arrays(running, at_once) == []


def test_store_created_by_the_store_thread_while_the_first_batch_runs(tmp_path):
    reference, batches = _store(tmp_path, "reference.zarr", overlap=False, rows_while_running=False)
    sweep = sweep_from_dict(SWEEP)
    points = expand(sweep)
    plan = plan_sweep(sweep, points, "cpu", batch_size=2)
    out = tmp_path / "created_later.zarr"
    created = []

    def create():
        created.append(out.exists())
        create_sweep_store(out, sweep, points.templates[0], plan, device="cpu")

    timing = {}
    run_serial(jobs_for(out, plan, points, plan.batches), "cpu", overlap=True, create_store=create, timing=timing)
    assert created == [False] and timing["create_store"] > 0 and batches >= 3
    assert differing_arrays(out, reference) == []

    def fails():
        raise OSError("no space left on device")

    with pytest.raises(OSError, match="no space left"):  # its own error, not that of the writes queued after it
        run_serial(
            jobs_for(tmp_path / "never.zarr", plan, points, plan.batches), "cpu", overlap=True, create_store=fails
        )


def test_a_serial_sweep_warms_the_stepping_kernel_its_batches_use(monkeypatch):
    """``warm_kernels(runs=…)`` on a CPU: the record kernels of each chain length, ``track_extremes`` and the chain
    kernel ``auto`` takes, short runs and long alike; without ``runs`` (Dask workers) the same for short chains."""
    from hertzian.core.solvers import compile as compiling
    from hertzian.kernels.cpu import chain_kernel
    from hertzian.kernels.records import record_kernels, traced_start_kernel, track_extremes
    from hertzian.sweeping import distributed

    sweep = sweep_from_dict(SWEEP)
    points = expand(sweep)
    plan = plan_sweep(sweep, points, "cpu", batch_size=4)
    runs = distributed.runs_of(plan, points, plan.batches)
    f = plan.groups[0].features
    assert {(r[0], r[1], r[3]) for r in runs} == {(f, 12, 100)} and sorted({r[2] for r in runs}) == [4]
    loaded = []
    monkeypatch.setattr(compiling, "_load", lambda device, module, block_dim: loaded.append(module))
    common = {track_extremes.module, chain_kernel(f).module} | (
        {traced_start_kernel(f.precision).module} if f.traces else set()
    )
    short = {k.module for k in record_kernels(f)[:2]} | common
    for warm in (runs, [(f, 12, 4, 10**9)], None):
        loaded.clear()
        distributed.warm_kernels([f], "cpu", runs=warm)
        assert set(loaded) == short
    loaded.clear()
    distributed.warm_kernels([f], "cpu", runs=[(f, 4096, 2, 10**9)])  # long chains: the two-stage reductions
    long_records = record_kernels(f)
    assert (
        set(loaded)
        == {
            long_records.grains.module,
            long_records.parts_of_grains.module,
            long_records.record_long.module,
        }
        | common
    )


def test_overlapped_preparation_of_batches_spanning_templates(tmp_path):
    # the impurity's contact rule changes no kernel: one launch group whose batches join two templates
    # (run as one scene per point, nothing prepared)
    sweep = dict(
        SWEEP, axis=SWEEP["axis"][:2] + [{"name": "rule", "key": "impurities.0.contact", "values": ["harmonic", "own"]}]
    )
    stores = []
    for overlap in (False, True):
        definition = sweep_from_dict(sweep)
        points = expand(definition)
        plan = plan_sweep(definition, points, "cpu", batch_size=4)
        jobs = jobs_for(tmp_path / f"{overlap}.zarr", plan, points, plan.batches)
        assert any(isinstance(j.chains, list) for j in jobs)
        create_sweep_store(tmp_path / f"{overlap}.zarr", definition, points.templates[0], plan, device="cpu")
        run_serial(jobs, "cpu", overlap=overlap)
        stores.append(tmp_path / f"{overlap}.zarr")
    assert differing_arrays(*stores) == []


def test_prepared_model_is_refused_for_other_chains():
    template = scene_from_dict(BASE)
    a = ChainSet.of(template, {"excitation.impact": [1e-3, 1e-2]}, 2)
    b = ChainSet.of(template, {"excitation.impact": [1e-3, 2e-2]}, 2)
    with pytest.raises(ValueError):
        build_model(b, "cpu", prepared=prepare_model(a))


def test_reused_staging_buffers_give_the_same_records():
    template = scene_from_dict(BASE)
    chains = ChainSet.of(template, {"excitation.impact": [1e-3, 1e-2, 3e-2]}, 3)
    first = Runner(build_model(chains, "cpu"), kernel="step")
    kept = [id(buf) for buf in first.recorder.staging]
    one = first.run()
    second = Runner(build_model(chains, "cpu"), kernel="step")
    assert [id(buf) for buf in second.recorder.staging] == kept[::-1]  # the pool handed them back
    two = second.run()
    for name in ("u", "v"):
        np.testing.assert_array_equal(one.fields[name], two.fields[name])
        np.testing.assert_array_equal(one.traces[name], two.traces[name])
    np.testing.assert_array_equal(one.energy, two.energy)
    # a different layout does not take them
    other = Runner(build_model(ChainSet.of(template, {"excitation.impact": [1e-3, 1e-2]}, 2), "cpu"), kernel="step")
    assert not {id(buf) for buf in other.recorder.staging} & set(kept)
    other.run()
    assert STAGING._key == other.recorder.staging_key


def test_the_collector_is_frozen_during_a_run_and_unfrozen_after():
    """A run's loop freezes the objects made before it for the garbage collector (its full passes skip them) and
    unfreezes them after, also when the run raises."""
    import gc

    from hertzian.core.runner import frozen_collector

    assert gc.get_freeze_count() == 0
    with pytest.raises(RuntimeError):
        with frozen_collector():
            assert gc.get_freeze_count() > 0
            raise RuntimeError("a failed run")
    assert gc.get_freeze_count() == 0
