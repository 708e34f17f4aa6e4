"""Fused window kernels (kernels/tile.py, kernels/ghost.py) against the per-step kernel (kernels/step.py).

The fused kernels keep chains on-chip for many steps; they must reproduce the per-step kernel's
state bit for bit, on the CPU (Warp runs the blocks as cooperative fibers there) and on CUDA. Each
case runs until the pulse has reached the last window and the bottom (asserted before comparing),
and each exercises a different layout: padded lanes, several chains per block,
windows with ghost zones, free ends, a fixed bottom, impurities and gravity, other integrators and
exponents, a frozen chain.
"""

from __future__ import annotations

import numpy as np
import pytest
from hertzian.core.model import build_model
from hertzian.core.runner import Runner
from hertzian.core.solvers import config_of
from hertzian.kernels.features import STATUS_NON_FINITE
from hertzian.kernels.ghost import plan_windows
from hertzian.kernels.tile import fusable, plan_tile

from tests.helpers import CASES, assert_every_window_moved, assert_kernels_agree, chains, fused, per_step, window_ranges


def assert_same(got: np.ndarray, want: np.ndarray, device) -> None:
    """Bit for bit on the CPU (the planner relies on it across batch sizes); on CUDA see assert_kernels_agree."""
    assert np.all(np.isfinite(got))
    assert np.max(np.abs(want)) > 0  # a moving chain, not a state at rest
    assert_kernels_agree(got, want, device)


@pytest.mark.parametrize("case", list(CASES))
def test_fused_equals_per_step(device, case):
    sections, n_chains, plan_keywords, steps = CASES[case]
    model = build_model(chains(n_chains, **sections), device)
    assert fusable(model.features)
    plan = plan_tile(model.features, model.grain_count, model.chain_count, **plan_keywords)
    want = per_step(model, steps)
    assert_every_window_moved(
        want, window_ranges(plan, model.grain_count), held_bottom=model.scenes[0].boundary.bottom == "fixed"
    )
    assert_same(fused(model, plan, steps), want, device)


def test_frozen_chain_keeps_its_state(device):
    model = build_model(chains(3, chain={"grains": 24, "l0": 1e-4}, integrator={"dt": 5e-4}), device)
    status = np.array([0, STATUS_NON_FINITE, 0], dtype=np.int32)
    plan = plan_tile(model.features, 24, 3, grains_per_lane=8, chains_per_block=3)
    got = fused(model, plan, 10, status)
    assert_same(got, per_step(model, 10, status), device)
    np.testing.assert_array_equal(got[:, 1], model.initial_state().x.numpy()[:, 1])


def test_runner_with_fused_kernel_records_the_same(device):
    # the whole run (records, energy, fields) through Runner's dispatch, windows on a GPU, tile on a CPU
    # records at uneven steps (every = 0.3 is 599.99… steps of dt; duration 1.5 not a multiple) and a
    # run long enough for the pulse to reach the last window and the bottom
    scenes = chains(
        2, chain={"grains": 40, "l0": 1e-3}, integrator={"dt": 5e-4, "duration": 1.5}, record={"every": 0.29997}
    )
    model = build_model(scenes, device)
    reference = Runner(model, kernel="step").run()
    plan = plan_tile(model.features, 40, 2, grains_per_lane=4, lanes_per_chain=8, steps_per_launch=8, windowed=True)
    last_record = np.stack([reference.fields["u"][:, -1], reference.fields["v"][:, -1]])
    assert_every_window_moved(last_record, window_ranges(plan, 40), held_bottom=False)
    runner = Runner(model, kernel=config_of(plan))
    assert runner.solver.kind == "window"
    result = runner.run()
    for name in ("u", "v"):
        assert_same(result.fields[name], reference.fields[name], device)
    assert_kernels_agree(result.energy, reference.energy, device)
    np.testing.assert_array_equal(result.t, reference.t)


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


def test_a_ring_fuses_in_full_lanes_only():
    """A ring's first and last lanes are neighbours: every lane full, whole chains (no windows); on a GPU a ring no
    timed lane size fills takes the per-step kernel, decided without a GPU on a stand-in model."""
    from types import SimpleNamespace

    from hertzian.core.solvers import calibrate

    ring = {"boundary": {"surface": "periodic", "bottom": "periodic"}, "integrator": {"events": "off"}}
    features = build_model(chains(1, chain={"grains": 24}, **ring), "cpu").features
    assert plan_tile(features, 24, 1, grains_per_lane=4).shape.lanes_per_chain == 6
    for keywords in (
        dict(grains_per_lane=8, chains_per_block=1, grains=20),
        dict(grains_per_lane=4, grains=24, lanes_per_chain=4, windowed=True),
    ):
        grains = keywords.pop("grains")
        with pytest.raises(ValueError, match="ring"):
            plan_tile(features, grains, 1, **keywords)
    gpu = SimpleNamespace(name="cuda:0", is_cpu=False, is_cuda=True, sm_count=132)
    for grains, fuses in ((24, True), (30, False)):
        model = SimpleNamespace(features=features, device=gpu, grain_count=grains, chain_count=4096)
        assert (calibrate.step_reason(model) is None) == fuses, grains
        assert (calibrate.choose_config(model, "fused").kind != "step") == fuses, grains


def test_a_composed_method_fuses_in_whole_chains_only():
    """yoshida4 and yoshida6 fuse with no window (a window's ghost zone would have to cover every substep); on a GPU a
    composed chain too long for one block takes the per-step kernel, decided without a GPU on a stand-in model."""
    from types import SimpleNamespace

    from hertzian.core.solvers import calibrate

    features = build_model(chains(1, chain={"grains": 24}, integrator={"method": "yoshida6"}), "cpu").features
    assert fusable(features)
    with pytest.raises(ValueError, match="whole chains"):
        plan_tile(features, 24, 1, grains_per_lane=4, lanes_per_chain=4, windowed=True)
    gpu = SimpleNamespace(name="cuda:0", is_cpu=False, is_cuda=True, sm_count=132)
    for grains, fuses in ((1024, True), (100_000, False)):
        model = SimpleNamespace(features=features, device=gpu, grain_count=grains, chain_count=4096)
        assert (calibrate.step_reason(model) is None) == fuses, grains
        assert (calibrate.choose_config(model, "fused").kind != "step") == fuses, grains
