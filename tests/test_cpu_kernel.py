"""The CPU sweep kernel (kernels/cpu.py) against the per-step kernel, and the runner's kernel choice.

The sweep integrates a chain in place with its neighbours in registers; it performs the per-step
kernel's operations in the same order, so on the CPU the states must agree bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from ensemble.calibrate import SweepStepper, make_stepper
from ensemble.model import build_model
from ensemble.runner import Runner
from fused_cases import CASES, chains, per_step


def sweep(model, steps: int, status=None, steps_per_launch: int = 1 << 30) -> np.ndarray:
    stepper = SweepStepper(model, steps_per_launch)
    buffers = (model.initial_state(), model.state())
    flags = wp.zeros(model.chain_count, dtype=wp.int32, device=model.device)
    if status is not None:
        flags.assign(status)
    parity = stepper.advance(buffers, 0, flags, steps)
    assert buffers[parity].clock.numpy()[0] == steps
    return buffers[parity].x.numpy()


@pytest.mark.parametrize("case", list(CASES))
def test_sweep_equals_per_step(case):
    sections, n_chains, _, steps = CASES[case]
    model = build_model(chains(n_chains, **sections), "cpu")
    want = per_step(model, steps)
    got = sweep(model, steps, steps_per_launch=7)  # several launches, an odd one last
    assert np.max(np.abs(want)) > 0
    np.testing.assert_array_equal(got, want)


def test_sweep_freezes_non_finite_chains():
    model = build_model(chains(2, chain={"grains": 10, "l0": 1e-4}, integrator={"dt": 5e-4}), "cpu")
    status = np.array([1, 0], dtype=np.int32)
    got = sweep(model, 5, status)
    np.testing.assert_array_equal(got, per_step(model, 5, status))
    np.testing.assert_array_equal(got[:, 0], model.initial_state().x.numpy()[:, 0])


def test_runner_sweep_run_equals_per_step_run():
    scenes = chains(3, chain={"grains": 30, "l0": 1e-4}, integrator={"dt": 5e-4, "duration": 0.05},
                    record={"every": 0.01})
    model = build_model(scenes, "cpu")
    reference = Runner(model, kernel="step").run()
    runner = Runner(model, kernel="sweep")
    assert isinstance(runner.fused, SweepStepper)
    result = runner.run()
    np.testing.assert_array_equal(result.u, reference.u)
    np.testing.assert_array_equal(result.v, reference.v)
    np.testing.assert_array_equal(result.energy, reference.energy)
    np.testing.assert_array_equal(result.status, reference.status)


def test_kernel_choice():
    model = build_model(chains(2, chain={"grains": 10}), "cpu")
    assert make_stepper(model, "step") is None
    assert make_stepper(model, "auto", run_steps=10) is None            # too short to repay a compile
    assert isinstance(make_stepper(model, "auto", run_steps=10**8), SweepStepper)
    traced = build_model(chains(2, chain={"grains": 10}, record={"traces": [0]}), "cpu")
    assert make_stepper(traced, "auto", run_steps=10**8) is None        # traces stay on the per-step kernel
    with pytest.raises(ValueError):
        make_stepper(traced, "sweep")
    with pytest.raises(ValueError):
        make_stepper(model, "fastest")
