"""A run ends at ``integrator.duration`` to the nearest step: records on the steps nearest r·every, the last at
the duration, in a run and in a sweep store."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from hertzian.core.runner import run_scene
from hertzian.sweeping.spec import load_sweep

from tests.helpers import invoke, make_scene, toml_text

IMPACT = {"chain": {"grains": 8, "l0": 1e-4}, "excitation": {"impact": 1e-2}}


@pytest.mark.parametrize("dt, every, duration", [(1e-3, 0.3, 1.0), (3e-3, 0.01, 1.0), (1e-3, 0.25, 0.6)])
def test_run_ends_at_the_duration(dt, every, duration):
    """Schedules that do not divide evenly: records on the steps nearest r·every, the last at the duration (to a step)."""
    scene = make_scene(
        chain={"grains": 6, "l0": 1e-4},
        excitation={"impact": 1e-2},
        integrator={"duration": duration, "dt": dt},
        record={"every": every, "traces": [5]},
    )
    result = run_scene(scene, "cpu")
    assert abs(result.t[-1] - duration) <= dt / 2
    assert result.steps == round(duration / dt)
    wanted = np.append(np.arange(0, duration - dt / 2, every), duration)
    np.testing.assert_allclose(result.t, wanted, rtol=0, atol=dt / 2)
    # the trace samples every step to the end, and agrees with the snapshots where they coincide
    assert result.trace_t.size == result.steps + 1
    steps = np.rint(result.t / dt).astype(int)
    np.testing.assert_array_equal(result.traces["u"][0, steps, 0], result.u[0, :, 5])


def test_whole_schedules_are_unchanged():
    """every/dt and duration/every whole: records exactly every/dt steps apart."""
    scene = make_scene(integrator={"duration": 0.2, "dt": 1e-4}, record={"every": 0.05})
    np.testing.assert_array_equal(scene.record_steps, np.arange(5) * 500)
    np.testing.assert_array_equal(scene.record_times, np.arange(5) * 500 * 1e-4)


def test_sweep_ends_at_the_duration(tmp_path):
    """The same schedule in a sweep store: t ends at the duration, and each point's last record equals
    the point run alone."""
    text = (
        toml_text({"scene": {**IMPACT, "integrator": {"duration": 0.1, "dt": 1e-3}, "record": {"every": 0.03}}})
        + '\n[[axis]]\nname = "v_imp"\nkey = "excitation.impact"\nvalues = [1e-2, 2e-2]\n'
    )
    path = tmp_path / "sweep.toml"
    path.write_text(text)
    out = tmp_path / "sweep.zarr"
    result = invoke("sweep", path, "--out", out, "--device", "cpu", "--quiet")
    assert result.exit_code == 0, result.output
    ds = xr.open_zarr(out)
    np.testing.assert_allclose(ds.t.values, [0.0, 0.03, 0.06, 0.09, 0.1], rtol=0, atol=1e-12)
    alone = run_scene(load_sweep(path).scene_at((1,)), "cpu")
    np.testing.assert_array_equal(ds.u.sel(v_imp=2e-2).values, alone.u[0])
