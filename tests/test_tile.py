"""Fused window kernels (kernels/tile.py, kernels/ghost.py) against the per-step kernel (kernels/step.py).

The fused kernels keep chains on-chip for many steps; they must reproduce the per-step kernel's
state: bit for bit on the CPU (Warp runs the blocks as cooperative fibers there), within 1e-13
relative on CUDA. Each case exercises a different layout: padded lanes, several chains per block,
windows with ghost zones, free ends, a fixed bottom, impurities and gravity, other integrators and
exponents, a frozen chain.
"""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from ensemble.model import build_model
from ensemble.runner import Runner
from ensemble.scene import scene_from_dict
from ensemble.solvers import TileSolver, config_of
from kernels.features import STATUS_NON_FINITE
from kernels.ghost import plan_windows
from kernels.tile import fusable, plan_tile


def chains(n_chains: int, **sections) -> list:
    """``n_chains`` scenes that differ in their impact speed."""
    data = {k: dict(v) if isinstance(v, dict) else v for k, v in sections.items()}
    data.setdefault("integrator", {}).setdefault("duration", 1.0)
    data.setdefault("excitation", {}).setdefault("impact", 1e-2)
    base = scene_from_dict(data)
    return [base.with_overrides({"excitation.impact": base.excitation.impact * (1 + 0.3 * c)})
            for c in range(n_chains)]


def per_step(model, steps: int, status=None) -> np.ndarray:
    runner = Runner(model, kernel="step", use_graph=False)
    if status is not None:
        runner.current.status.assign(status)
    runner.advance(steps)
    return runner.current.x.numpy()


def fused(model, plan, steps: int, status=None) -> np.ndarray:
    solver = TileSolver(model, config_of(plan))
    start, scratch = model.state_pair()
    if status is not None:
        start.status.assign(status)
    end = solver.advance(start, scratch, steps)
    assert end.clock.numpy()[0] == steps
    return end.x.numpy()


def assert_same(got: np.ndarray, want: np.ndarray, device) -> None:
    assert np.all(np.isfinite(got))
    assert np.max(np.abs(want)) > 0  # a moving chain, not a state at rest
    if wp.get_device(device).is_cpu:
        np.testing.assert_array_equal(got, want)
    else:
        assert np.max(np.abs(got - want)) <= 1e-13 * np.max(np.abs(want))


CASES = {
    # name: (scene sections, chain count, plan keywords, steps)
    "walls, padded lanes": (
        dict(chain={"grains": 37, "l0": 1e-4}, integrator={"dt": 5e-4}), 2,
        dict(grains_per_lane=4), 40),
    "free ends, 2 chains per block": (
        dict(chain={"grains": 12}, boundary={"surface": "free", "bottom": "free"},
             integrator={"dt": 5e-4}), 5,
        dict(grains_per_lane=4, chains_per_block=2), 30),
    "windows, fixed bottom, impurities, gravity": (
        dict(chain={"grains": 50, "gravity": 1.0, "l0": 1e-4}, boundary={"bottom": "fixed"},
             impurities=[{"grains": [10, 11, 30], "mass": 0.5, "a": 3000.0}], integrator={"dt": 5e-4}), 2,
        dict(grains_per_lane=4, lanes_per_chain=8, steps_per_launch=6, windowed=True), 22),
    "verlet, exponent 2, surface load": (
        dict(chain={"grains": 20, "exponent": 2.0, "l0": 1e-4}, boundary={"surface": "load"},
             integrator={"method": "verlet", "dt": 2e-4}), 2,
        dict(grains_per_lane=8), 25),
    "gear6, full lanes": (
        dict(chain={"grains": 16, "l0": 1e-4}, integrator={"method": "gear6", "dt": 5e-4}), 3,
        dict(grains_per_lane=8), 20),
}


@pytest.mark.parametrize("case", list(CASES))
def test_fused_equals_per_step(device, case):
    sections, n_chains, plan_keywords, steps = CASES[case]
    model = build_model(chains(n_chains, **sections), device)
    assert fusable(model.features)
    plan = plan_tile(model.features, model.grain_count, model.chain_count, **plan_keywords)
    assert_same(fused(model, plan, steps), per_step(model, steps), device)


def test_frozen_chain_keeps_its_state(device):
    model = build_model(chains(3, chain={"grains": 24, "l0": 1e-4}, integrator={"dt": 5e-4}), device)
    status = np.array([0, STATUS_NON_FINITE, 0], dtype=np.int32)
    plan = plan_tile(model.features, 24, 3, grains_per_lane=8, chains_per_block=3)
    got = fused(model, plan, 10, status)
    assert_same(got, per_step(model, 10, status), device)
    np.testing.assert_array_equal(got[:, 1], model.initial_state().x.numpy()[:, 1])


def test_runner_with_fused_kernel_records_the_same(device):
    # the whole run (records, energy, fields) through Runner's dispatch, windows on a GPU, tile on a CPU
    scenes = chains(2, chain={"grains": 40, "l0": 1e-4}, integrator={"dt": 5e-4, "duration": 0.05},
                    record={"every": 0.01})
    model = build_model(scenes, device)
    reference = Runner(model, kernel="step").run()
    runner = Runner(model, kernel=config_of(plan_tile(model.features, 40, 2, grains_per_lane=4, lanes_per_chain=8,
                                                      steps_per_launch=8, windowed=True)))
    assert runner.solver.kind == "window"
    result = runner.run()
    for name in ("u", "v"):
        assert_same(result.fields[name], reference.fields[name], device)
    np.testing.assert_allclose(result.energy, reference.energy, rtol=1e-12, atol=0)


def test_window_geometry():
    w = plan_windows(10240, 320, 32)
    assert (w.interior, w.ghost, w.blocks_per_chain) == (256, 32, 40)
    assert w.overhead(10240) == pytest.approx(320 / 256)
    with pytest.raises(ValueError):
        plan_windows(100, 64, 32)  # no interior left


def test_plan_rejects_uncovered_chains():
    model_features = build_model(chains(1, chain={"grains": 10}), "cpu").features
    with pytest.raises(ValueError):
        plan_tile(model_features, 100, 1, grains_per_lane=4, lanes_per_chain=8)
    with pytest.raises(ValueError):
        plan_tile(model_features, 5000, 1, grains_per_lane=4)  # 1250 threads in a block
