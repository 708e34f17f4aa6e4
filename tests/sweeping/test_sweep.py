"""Sweeps run: the planner (blocks, launch groups, batches) and the store (xarray dims, chunks aligned with
batches, every point equal to the same chain run alone with its launch group's kernel)."""

import json
import math

import numpy as np
import pytest
import xarray as xr
import zarr
from hertzian.core.model import build_model
from hertzian.core.runner import Runner, run_scene
from hertzian.core.scene import SceneError
from hertzian.sweeping.planner import batches_for, block_for, plan_sweep
from hertzian.sweeping.spec import load_sweep, sweep_from_dict, sweep_scenes
from hertzian.sweeping.sweep_store import (
    POINT_COORDINATES,
    batch_records,
    chunk_layout,
    create_sweep_store,
    differing_arrays,
    write_result,
)

from tests.helpers import GRID_SWEEP, invoke, run_store, sweep_cli, write_sweep

# ---- planner -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "shape,splitting,target,block",
    [
        ((100, 100), [False, False], 250, (2, 100)),
        ((100, 100), [False, False], 10**6, (100, 100)),
        ((3, 7), [False, False], 5, (1, 4)),  # 7 cut into near-equal parts 4 + 3
        ((4, 3), [True, False], 100, (1, 3)),
        ((4, 3, 5), [False, True, False], 12, (2, 1, 5)),
        ((), [], 10, ()),
    ],
)
def test_block_shapes(shape, splitting, target, block):
    assert block_for(shape, splitting, target) == block
    assert math.prod(block) <= max(target, 1)
    batches = batches_for(shape, block, np.zeros(shape, dtype=int))
    points = sorted(p for b in batches for p in b.points)
    assert points == list(range(math.prod(shape)))  # every point exactly once


METHOD_SWEEP = GRID_SWEEP.replace(
    "values = [0.0, 1e-4]",
    'values = [0.0, 1e-4]\n\n[[axis]]\nname = "method"\nkey = "integrator.method"\nvalues = ["gear4", "verlet"]',
)


def test_method_axis_splits_launch_groups(tmp_path):
    sweep = load_sweep(write_sweep(tmp_path, METHOD_SWEEP))
    scenes = sweep_scenes(sweep)
    plan = plan_sweep(sweep, scenes, "cpu")
    assert len(plan.groups) == 2 and plan.block == (3, 2, 1)
    assert {p.features.method for p in plan.groups} == {"gear4", "verlet"}
    for b in plan.batches:
        assert {scenes[p].integrator.method for p in b.points} == {plan.groups[b.group].features.method}


def test_every_point_equals_the_same_chain_alone_with_its_groups_kernel(tmp_path, device):
    out = tmp_path / "o.zarr"
    result = sweep_cli(write_sweep(tmp_path, METHOD_SWEEP), "--out", out, "--device", device, "--batch-size", "4")
    assert result.exit_code == 0, result.stderr
    sweep = load_sweep(tmp_path / "sweep.toml")
    scenes = sweep_scenes(sweep)
    plan = plan_sweep(sweep, scenes, device)
    ds = xr.open_zarr(out)
    for flat, index in enumerate(np.ndindex(*sweep.shape)):
        features = plan.groups[plan.point_group[index]].features
        alone = Runner(build_model([scenes[flat]], device, features=features)).run()
        point = ds.isel(dict(zip(sweep.dims, index)))
        np.testing.assert_array_equal(point.u.values, alone.u[0])
        np.testing.assert_array_equal(point.v.values, alone.v[0])
        np.testing.assert_array_equal(point.energy.values, alone.energy[0])
        np.testing.assert_array_equal(point.trace_v.values, alone.traces["v"][0])
        assert int(point.status) == 0 and float(point.energy_error) == alone.energy_error[0]
    assert ds.method.values.tolist() == ["gear4", "verlet"]
    assert ds.u.sel({"v_imp": 1e-2, "l0": 1e-4, "method": "verlet"}).shape == (3, 12)


def test_batch_size_changes_the_chunks_not_the_results(tmp_path):
    one = run_store(tmp_path, GRID_SWEEP, "--batch-size", "1", name="one.zarr")
    all_ = run_store(tmp_path, GRID_SWEEP, name="all.zarr")
    assert differing_arrays(one, all_) == []
    assert zarr.open_array(str(one), path="status").chunks == (1, 1)
    assert zarr.open_array(str(all_), path="status").chunks == (3, 2)


def test_differing_arrays_sees_one_changed_value(tmp_path):
    a = run_store(tmp_path, GRID_SWEEP, name="a.zarr")
    b = run_store(tmp_path, GRID_SWEEP, name="b.zarr")
    assert differing_arrays(a, b) == []
    arr = zarr.open_array(str(b), path="v", mode="r+")
    arr[2, 1, 1, 3] = np.nextafter(arr[2, 1, 1, 3], np.inf)
    assert differing_arrays(a, b) == ["v"]


# ---- store ----------------------------------------------------------------------------------


def test_store_has_a_runs_variables_with_the_sweep_dims_first(tmp_path):
    out = run_store(tmp_path)
    sweep = load_sweep(tmp_path / "out.zarr.toml")
    run_path = write_result(tmp_path / "run.zarr", run_scene(sweep_scenes(sweep)[0], "cpu"))
    ds, run = xr.open_zarr(out), xr.open_zarr(run_path)
    assert set(run.variables) <= set(ds.variables)
    for name, var in run.variables.items():
        per_point = name not in run.coords or name in POINT_COORDINATES  # how a point ran: a coordinate, per point
        prefix = sweep.dims if per_point else ()
        assert ds[name].dims == prefix + var.dims, name
        for key in ("units", "long_name"):
            assert ds[name].attrs.get(key) == var.attrs.get(key), (name, key)
    assert ds.u.sel(v_imp=1e-2, l0=1e-4).dims == ("record", "grain")
    np.testing.assert_array_equal(ds.t.values, run.t.values)
    np.testing.assert_array_equal(ds.trace_t.values, run.trace_t.values)
    for key in ("schema_version", "scene", "sweep", "provenance", "status_codes"):
        assert key in ds.attrs
    prov = ds.attrs["provenance"]
    assert prov["complete"] and prov["batches_done"] == prov["batches"] == 1
    assert json.loads(ds.attrs["sweep"])["axis"][0]["name"] == "v_imp"


def test_chunks_are_the_batch_blocks(tmp_path, monkeypatch):
    from hertzian.sweeping import sweep_store

    # shards of one record of u and v (of one record interval of the traces) however small: the default groups
    # records into shards of ROW_SHARD_BYTES, which this small sweep's records do not reach (checked below)
    monkeypatch.setattr(sweep_store, "ROW_SHARD_BYTES", 1)
    out = run_store(tmp_path, GRID_SWEEP, "--batch-size", "2")
    sweep = load_sweep(tmp_path / "out.zarr.toml")
    plan = plan_sweep(sweep, sweep_scenes(sweep), "cpu", batch_size=2)
    assert plan.block == (1, 2)
    group = zarr.open_group(str(out), mode="r")
    scene = sweep_scenes(sweep)[0]
    # snapshots: a shard per batch and record; traces: per batch and record interval (written as the batch runs)
    rows = {"u": 1, "v": 1, "trace_u": scene.record_steps[1] // scene.trace_stride}
    rows["trace_v"] = rows["trace_u"]
    for name in ("u", "v", "energy", "trace_u", "trace_v", "status", "energy_error", "wall_seconds"):
        arr = group[name]
        outer = arr.shards or arr.chunks  # one shard (or chunk) per batch along the sweep dims
        assert outer[:2] == plan.block, name
        if name in rows:
            assert outer[2] == rows[name] < arr.shape[2] and outer[3:] == arr.shape[3:], name
        else:
            assert all(o >= s for o, s in zip(outer[2:], arr.shape[2:])), name
        if arr.shards:
            assert all(s % c == 0 for s, c in zip(arr.shards, arr.chunks)), name
    records = batch_records(out)
    assert [r["batch"] for r in records] == [b.index for b in plan.batches]
    assert [r["points"] for r in records] == [2, 2, 2] and all(r["device"] == "cpu" for r in records)
    # completion records are three small arrays chunked one batch per chunk, not a group per batch
    batches = group["batches"]
    assert sorted(batches.array_keys()) == ["done", "record", "where"] and not list(batches.group_keys())
    for name in ("done", "record", "where"):
        assert batches[name].shape[0] == 3 and batches[name].chunks[0] == 1, name
    monkeypatch.undo()
    grouped = zarr.open_group(str(run_store(tmp_path, GRID_SWEEP, "--batch-size", "2", name="grouped.zarr")), mode="r")
    assert (grouped["u"].shards or grouped["u"].chunks)[2] == grouped["u"].shape[2]  # 2 × 12 × 8 B a record: one shard


def test_records_per_shard_reach_the_shard_bytes():
    from hertzian.sweeping.sweep_store import ROW_SHARD_BYTES, records_per_shard

    assert records_per_shard(5000, 500 * 8) == 1  # gpu_10k: 20 MB a record
    assert records_per_shard(2, 10000 * 8) == 53  # the driven columns: 160 kB a record
    assert records_per_shard(1, 1) == ROW_SHARD_BYTES and records_per_shard(0, 0) == ROW_SHARD_BYTES


@pytest.mark.parametrize(
    "block,trailing,chunks,shards",
    [
        ((50, 100), (3, 500), (1, 50, 3, 500), (50, 100, 3, 500)),  # ~1 MiB inner chunks of 50 points
        ((2, 3), (5, 20), (2, 3, 5, 20), None),  # a small batch is one plain chunk
        ((1, 1), (100001, 2), (1, 1, 65536, 2), (1, 1, 131072, 2)),  # a long trace is cut along samples
        ((4, 7), (), (4, 7), None),  # per-point values: one chunk per batch
    ],
)
def test_chunk_layout(block, trailing, chunks, shards):
    assert chunk_layout(block, trailing, 8) == (chunks, shards)


@pytest.mark.parametrize(
    "block,trailing,rows,chunks,shards",
    [
        ((50, 100), (11, 500), 1, (2, 100, 1, 500), (50, 100, 1, 500)),  # a shard per record, ~1 MiB inner chunks
        ((50, 100), (501, 2), 50, (10, 100, 50, 2), (50, 100, 50, 2)),  # trace samples: a shard per record interval
        ((2, 3), (4, 5), 4, (2, 3, 4, 5), None),  # a shard holding every row: the plain layout
        ((4,), (6, 200000), 3, (1, 1, 200000), (4, 3, 200000)),  # rows over 1 MiB: one point and row per inner chunk
        ((2,), (2001, 10000), 53, (1, 13, 10000), (2, 65, 10000)),  # shards of whole ~1 MiB chunks: 53 rounded up to 65
        ((2,), (60, 10000), 53, (1, 13, 10000), (2, 65, 10000)),  # past every row: the plain layout, one shard
    ],
)
def test_chunk_layout_with_rows_per_shard(block, trailing, rows, chunks, shards):
    assert chunk_layout(block, trailing, 8, rows) == (chunks, shards)


def test_summarize_a_sweep_and_an_unfinished_one(tmp_path):
    sweep = load_sweep(write_sweep(tmp_path))
    scenes = sweep_scenes(sweep)
    plan = plan_sweep(sweep, scenes, "cpu")
    empty = create_sweep_store(tmp_path / "empty.zarr", sweep, scenes, plan, device="cpu")
    result = invoke("summarize", str(empty), "--json")
    assert result.exit_code == 0, result.stderr
    records = json.loads(result.stdout)
    assert len(records) == 6 and {r["status_name"] for r in records} == {"NOT_RUN"}
    assert int(xr.open_zarr(empty).status.min()) == -1
    out = run_store(tmp_path)
    records = json.loads(invoke("summarize", str(out), "--json").stdout)
    assert [(r["v_imp"], r["l0"]) for r in records[:2]] == [(1e-3, 0.0), (1e-3, 1e-4)]
    for r in records:
        assert r["status_name"] == "OK" and r["energy_error"] < 1e-6
        assert r["grain_steps_per_second"] > 0 and r["wall_seconds"] > 0
        assert (r["method"], r["steps"], r["grains"], r["dt"]) == ("gear4", 200, 12, 1e-4)
    table = invoke("summarize", str(out))
    assert table.exit_code == 0 and "6 point(s); 12 grains, 200 steps of gear4" in table.stdout


def test_sweep_without_axes_is_a_single_run(tmp_path):
    text = GRID_SWEEP.split("[[axis]]")[0]
    out = run_store(tmp_path, text)
    ds = xr.open_zarr(out)
    assert ds.u.dims == ("record", "grain") and int(ds.status) == 0
    alone = run_scene(load_sweep(tmp_path / "out.zarr.toml").base, "cpu")
    np.testing.assert_array_equal(ds.u.values, alone.u[0])


def test_scene_error_from_planner_is_a_scene_error(tmp_path):
    sweep = load_sweep(write_sweep(tmp_path))
    with pytest.raises(SceneError):
        plan_sweep(sweep, sweep_scenes(sweep), "cpu", block=(5, 5, 5))


def test_non_leading_zip_axis_may_repeat_values():
    """Only the first axis of a [[zip]] group labels the store dimension; the others are coordinates."""

    data = {
        "scene": {"chain": {"grains": 10}, "excitation": {"impact": 1e-2}, "integrator": {"duration": 0.01}},
        "axis": [
            {"name": "case", "key": "chain.l0", "values": [0.0, 1e-5, 1e-4]},
            {"name": "v_imp", "key": "excitation.impact", "values": [1e-2, 1e-2, 1e-3]},
        ],
        "zip": [{"axes": ["case", "v_imp"]}],
    }
    sweep = sweep_from_dict(data)
    assert len(sweep.dimensions) == 1 and len(sweep.dimensions[0].axes) == 2
    data["zip"] = [{"axes": ["v_imp", "case"]}]
    with pytest.raises(SceneError, match="must not repeat"):
        sweep_from_dict(data)


def test_unsafe_dt_warns_and_strict_refuses(tmp_path):
    """`hertzian check`'s warning at the grid's corners; --strict exits 2 and writes nothing."""
    path = write_sweep(tmp_path)
    out = tmp_path / "unsafe.zarr"
    coarse = ("--set", "integrator.dt=5e-3", "--set", "record.trace_every=5e-3")
    refused = sweep_cli(path, "--out", out, "--device", "cpu", *coarse, "--strict")
    assert refused.exit_code == 2 and "looks inaccurate" in refused.stderr
    assert not out.exists()
    warned = sweep_cli(path, "--dry-run", "--device", "cpu", *coarse)
    assert warned.exit_code == 0 and "warning: point 0" in warned.stderr
