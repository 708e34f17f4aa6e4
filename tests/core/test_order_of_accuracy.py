"""Order of accuracy from the slope of log(error) against log(dt), on a smooth problem (a strongly
precompressed chain: no contact ever opens, so the force is smooth). The reference is gear6 at a
step 4x smaller than the finest tested. The Gear methods start from exact Taylor derivatives
(ensemble/core/startup.py); with a zero start they all fall to order 2 (see test_zero_start_loses_order)."""

import numpy as np
import pytest
from hertzian.core.model import build_model
from hertzian.core.runner import Runner, run_scene

from tests.helpers import make_scene, slope

DTS = np.array([2e-3, 1e-3, 5e-4])
# Expected orders: velocity Verlet is second order; the q-value Gear methods (A&T coefficients)
# show order q in the positions here, as the independent NumPy reference does too
# (tests/reference.py with exact start: slopes 4.0, 5.0, 6.0, 2.0).
# yoshida4 (three Verlet substeps, Yoshida 1990) is fourth order (measured 4.00 here), yoshida6 (seven) sixth.
EXPECTED = {"verlet": 2.0, "gear4": 4.0, "gear5": 5.0, "gear6": 6.0, "yoshida4": 4.0, "yoshida6": 6.0}


def smooth_scene(method, dt):
    return make_scene(
        chain={"grains": 20, "l0": 1e-2},
        excitation={"impact": 1e-4},
        integrator={"method": method, "dt": dt, "duration": 1.0},
        record={"every": 0.25},
    )


@pytest.fixture(scope="module")
def reference_u():
    return run_scene(smooth_scene("gear6", DTS[-1] / 4), "cpu").u[0]


@pytest.mark.parametrize("method", list(EXPECTED))
def test_order_of_accuracy(method, reference_u):
    errors = [
        np.abs(run_scene(smooth_scene(method, dt), "cpu").u[0] - reference_u).max() / np.abs(reference_u).max()
        for dt in DTS
    ]
    assert abs(slope(DTS, errors) - EXPECTED[method]) < 0.25, (method, errors, slope(DTS, errors))


def test_zero_start_loses_order(reference_u):
    """Why the exact start matters: gear6 started with x3 = x4 = x5 = 0 converges at order 2."""
    errors = []
    for dt in DTS:
        model = build_model([smooth_scene("gear6", dt)], "cpu")
        runner = Runner(model)
        x = runner.buffers[0].x.numpy()
        x[3:] = 0.0
        runner.buffers[0].x.assign(x)
        errors.append(np.abs(runner.run().u[0] - reference_u).max() / np.abs(reference_u).max())
    assert abs(slope(DTS, errors) - 2.0) < 0.3, errors
