"""The one store writer: a run (or an ensemble written from code) is a sweep with no axes (or with the
caller's axes), written by ``hertzian.sweeping.sweep_store`` through ``write_result``."""

import json
import math

import numpy as np
import pytest
import xarray as xr
import zarr
from hertzian.core.chains import ChainSet
from hertzian.core.model import build_model
from hertzian.core.runner import Runner, run_ensemble, run_scene
from hertzian.core.scene import scene_from_dict
from hertzian.sweeping.planner import block_for
from hertzian.sweeping.store import summary_records
from hertzian.sweeping.sweep_store import batch_records, chunk_layout, completed_batches, write_result

SCENE = {
    "chain": {"grains": 8, "l0": 1e-4},
    "excitation": {"impact": 1e-2},
    "integrator": {"dt": 1e-4, "duration": 0.01},
    "record": {"every": 0.005, "traces": [0, 7]},
}


def test_a_run_store_is_a_sweep_store_with_no_axes(tmp_path):
    scene = scene_from_dict(SCENE)
    result = run_scene(scene, "cpu")
    out = write_result(tmp_path / "run.zarr", result)
    ds = xr.open_zarr(out)
    assert ds.u.dims == ("record", "grain") and ds.trace_v.dims == ("sample", "traced")
    np.testing.assert_array_equal(ds.u.values, result.fields["u"][0])
    np.testing.assert_array_equal(ds.energy.values, result.energy[0])
    assert int(ds.status) == 0 and float(ds.energy_error) == result.energy_error[0]
    prov = ds.attrs["provenance"]
    assert prov["complete"] and prov["batches"] == prov["batches_done"] == 1 and prov["kernel"] == result.kernel
    assert json.loads(ds.attrs["scene"]) == scene.to_dict() and ds.attrs["scenes_differ_along"] == []
    assert json.loads(ds.attrs["scene_overrides"]) == {}
    assert completed_batches(out) == {0} and batch_records(out)[0]["points"] == 1
    [record] = summary_records(out)
    assert record["status_name"] == "OK" and record["grains"] == 8 and record["steps"] == 100
    with pytest.raises(FileExistsError):
        write_result(out, result)


def test_an_ensemble_store_keeps_every_points_scene(tmp_path):
    base = scene_from_dict(SCENE)
    speeds = [1e-3, 1e-2, 3e-2]
    scenes = [base.with_overrides({"excitation.impact": v, "chain.gravity": 0.5 * k}) for k, v in enumerate(speeds)]
    result = run_ensemble(scenes, "cpu")
    out = write_result(tmp_path / "e.zarr", result, axes={"v_imp": np.array(speeds)})
    group = zarr.open_group(str(out), mode="r")
    overrides = json.loads(group.attrs["scene_overrides"])
    assert overrides == {"chain.gravity": [0.0, 0.5, 1.0], "excitation.impact": speeds}
    # the axis is recognised as the scene key it varies; rebuilding each point's scene gives it back
    assert group["v_imp"].attrs["scene_key"] == "excitation.impact"
    first = scene_from_dict(json.loads(group.attrs["scene"]))
    for p, scene in enumerate(scenes):
        assert first.with_overrides({k: v[p] for k, v in overrides.items()}) == scene
    np.testing.assert_array_equal(group["u"][...], result.fields["u"])
    with pytest.raises(ValueError, match="do not match 3 chains"):
        write_result(tmp_path / "bad.zarr", result, axes={"v_imp": np.array(speeds[:2])})
    assert not (tmp_path / "bad.zarr").exists()


def test_a_chain_set_result_is_written_from_its_arrays(tmp_path):
    base = scene_from_dict(SCENE)
    chains = ChainSet.of(base, {"excitation.impact": [1e-3, 2e-3], "chain.l0": [1e-4, 1e-4]}, 2)
    result = Runner(build_model(chains, "cpu")).run()
    out = write_result(tmp_path / "c.zarr", result, axes={"speed": np.array([1e-3, 2e-3])})
    group = zarr.open_group(str(out), mode="r")
    assert json.loads(group.attrs["scene_overrides"]) == {"excitation.impact": [1e-3, 2e-3]}
    assert group["speed"].attrs["scene_key"] == "excitation.impact"
    alone = run_scene(chains[1], "cpu")
    np.testing.assert_array_equal(group["u"][1], alone.fields["u"][0])


def test_axis_named_like_a_store_variable_is_refused(tmp_path):
    result = run_scene(scene_from_dict(SCENE), "cpu")
    with pytest.raises(ValueError, match="store variable names"):
        write_result(tmp_path / "x.zarr", result, axes={"u": np.array([0.0])})
    assert not (tmp_path / "x.zarr").exists()


def test_a_block_cut_into_a_prime_extent_is_rounded_so_inner_chunks_hold_many_points():
    """10 000 points in 7 batches: 1429 points a batch is prime, so no inner chunk but one point divides it."""
    block = block_for((10000,), [False], 1500)
    assert math.ceil(10000 / block[0]) == 7 and block[0] <= 1500
    chunks, shards = chunk_layout(block, (1000,), 8)  # one 1000-grain record a point: 8 kB
    assert shards == block + (1000,)
    assert chunks[0] >= 32 and block[0] % chunks[0] == 0
    assert block_for((10000,), [False], 1430) == (1430,)  # no room to round up: the extent as it was
