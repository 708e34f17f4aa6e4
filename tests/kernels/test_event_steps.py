"""Event-aware Gear steps (kernels/events.py): contacts that open or close keep the method's order.

Checked against independent things: the order of accuracy as the log-error/log-dt slope against a
gear6 reference at dt/4 (Richardson-checked by ensemble/studies/accuracy.py), the same study with the
treatment switched off (the order it repairs), and bitwise equality of every kernel on the CPU.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from hertzian.core.model import build_model, features_of
from hertzian.kernels.features import Features
from hertzian.kernels.step import step_kernel
from hertzian.kernels.tile import TileShape, plan_tile, tile_kernel
from hertzian.studies.accuracy import work_precision

from tests.helpers import (
    assert_every_window_moved,
    assert_kernels_agree,
    call_count,
    chains,
    function_body,
    fused,
    generated_source,
    invoke,
    make_scene,
    per_step,
    slope,
    sweep,
)

DTS = [2e-3, 1e-3, 5e-4]


def test_l0_zero_keeps_gear4_order():
    """l0 = 0: every contact closes ahead of the solitary wave and opens behind it. Plain Gear steps
    fall to order ≈ 2; event-aware steps give gear4 its order 4 back (slope ≥ 3.5)."""
    scene = make_scene(
        chain={"grains": 20, "l0": 0.0},
        excitation={"impact": 1e-2},
        integrator={"duration": 1.0},
        record={"every": 0.25, "fields": ["u"]},
    )
    records, reference, _ = work_precision(scene, ["gear4"], DTS, ["float64"], device="cpu", events=["auto", "off"])
    errors = {e: [r.error for r in records if r.events == e] for e in ("auto", "off")}
    assert not any(r.reference_limited for r in records), records
    assert slope(DTS, errors["auto"]) >= 3.5, errors
    assert slope(DTS, errors["off"]) < 2.5, errors
    assert errors["auto"][-1] < errors["off"][-1] / 10, errors


def test_an_event_at_the_first_step_keeps_gear4_order():
    """A column under weak gravity with a free surface, struck at the top: the struck contact's static overlap is
    so small that the very first steps are event steps. They take the velocity as x1/dt − dt³/24·u⁗, which holds
    only where the Nordsieck vector is in gear4's steady-state form: so the start is in that form
    (ensemble/core/startup.py). From the plain Taylor start the first step's velocity would be off by dt³/24·u⁗ and
    the error would fall at order 3, above plain steps' (docs/stability.md §6b)."""
    scene = make_scene(
        chain={"grains": 60, "l0": 0.0, "gravity": 1e-3},
        boundary={"surface": "free", "bottom": "wall"},
        excitation={"impact": 0.1},
        integrator={"duration": 0.05},
        record={"every": 0.025, "fields": ["u"]},
    )
    dts = [5e-4, 2.5e-4, 1.25e-4]
    records, _, _ = work_precision(scene, ["gear4"], dts, ["float64"], device="cpu", events=["auto", "off"])
    errors = {e: [r.error for r in records if r.events == e] for e in ("auto", "off")}
    assert not any(r.reference_limited for r in records), records
    assert slope(dts, errors["auto"]) >= 3.7, errors
    assert all(a < b for a, b in zip(errors["auto"], errors["off"])), errors


@pytest.mark.parametrize("built", ["scenes", "chain set", "stacked chain sets", "shadow"])
def test_the_record_at_t0_is_the_exact_start(built):
    """gear4 integrates from its steady-state start (x1 = dt·v + dt⁴/24·u⁗), but the record at t = 0 keeps v(0)
    itself (v_imp on the struck grain, 0 elsewhere) and the energy the later records are compared with (the injected
    one), however the model was built: from scenes, from a sweep's chain set, from stacked sets (detection), or as
    the error estimate's shadow."""
    from hertzian.core.chains import ChainSet, ChainStack
    from hertzian.core.error_estimate import shadow_model
    from hertzian.core.model import prepare_model, stack_prepared
    from hertzian.core.runner import Runner

    template = make_scene(
        chain={"grains": 12, "l0": 1e-4}, excitation={"impact": 1e-2}, integrator={"duration": 0.1, "dt": 1e-3}
    )
    impacts = [1e-2, 3e-2]
    chains = ChainSet.of(template, {"excitation.impact": impacts}, 2)
    if built == "scenes":
        model = build_model([template.with_overrides({"excitation.impact": v}) for v in impacts], "cpu")
    elif built == "stacked chain sets":
        parts = [prepare_model(ChainSet.of(template, {"excitation.impact": [v]}, 1)) for v in impacts]
        stacked = stack_prepared(parts)
        model = build_model(stacked.chains, "cpu", prepared=stacked)
        assert isinstance(model.scenes, ChainStack)
    else:
        model = build_model(chains, "cpu")
        model = shadow_model(model) if built == "shadow" else model
    state = model.initial_state()
    steady = state.x.numpy()[1] / model.dt
    assert np.all(np.any(steady[:, 1:] != 0, axis=1))  # the steady form moves the grains below the struck one …
    with model.exact_start(state):
        exact = state.x.numpy()[1] / model.dt
    np.testing.assert_allclose(exact[:, 0], impacts, rtol=1e-15, atol=0)  # … the exact start does not …
    assert not np.any(exact[:, 1:])
    np.testing.assert_array_equal(state.x.numpy()[1] / model.dt, steady)  # … and the block ends in the steady form
    if built != "shadow":  # (a shadow records no velocities and no energy)
        result = Runner(model).run()
        v0 = result.fields["v"][:, 0]
        np.testing.assert_allclose(v0[:, 0], impacts, rtol=1e-15, atol=0)
        assert not np.any(v0[:, 1:])
        np.testing.assert_allclose(result.energy[:, 0], 0.5 * np.square(impacts), rtol=1e-14, atol=0)


def test_scenes_without_possible_events_compile_no_event_code():
    strong = make_scene(chain={"grains": 20, "l0": 1e-2}, excitation={"impact": 1e-4})
    assert features_of([strong]).event_window == 0  # (n−1)·a·δ0^n exceeds the injected energy
    loose = make_scene(chain={"grains": 20, "l0": 0.0}, excitation={"impact": 1e-2})
    assert features_of([loose]).event_window > 0
    assert features_of([loose.with_overrides({"integrator.events": "off"})]).event_window == 0
    assert features_of([loose.with_overrides({"integrator.method": "verlet"})]).event_window == 0
    # off is today's kernel: the same feature key, hence the same cached kernel object
    off = features_of([loose.with_overrides({"integrator.events": "off"})])
    assert off == Features(**{**off.__dict__, "event_window": 0.0})
    assert step_kernel(off) is step_kernel(Features(method="gear4", surface="wall", bottom="wall", static="none"))


EVENT_CASES = {
    # name: (scene sections, chain count, tile plan keywords); kept to two variants (compile time)
    "l0 = 0, gear4, free ends, 2 chains per block": (
        dict(chain={"grains": 30, "l0": 0.0}, boundary={"surface": "free", "bottom": "free"}, integrator={"dt": 5e-4}),
        3,
        dict(grains_per_lane=4, chains_per_block=2),
    ),
    "wall, light impurity, fixed bottom, gear5, windows": (
        dict(
            chain={"grains": 40, "l0": 0.0},
            boundary={"bottom": "fixed"},
            impurities=[{"grains": [5], "mass": 0.3}],
            integrator={"method": "gear5", "dt": 5e-4},
        ),
        2,
        dict(grains_per_lane=4, lanes_per_chain=8, steps_per_launch=6, windowed=True),
    ),
}


@pytest.mark.parametrize(
    "case", [pytest.param(case, marks=[pytest.mark.slow] if "windows" in case else []) for case in EVENT_CASES]
)
def test_every_kernel_takes_the_same_event_steps(case):
    sections, n_chains, plan_keywords = EVENT_CASES[case]
    steps = 300
    model = build_model(chains(n_chains, **sections), "cpu")
    assert model.features.event_window > 0
    want = per_step(model, steps)
    off = {**sections, "integrator": {**sections["integrator"], "events": "off"}}
    plain = per_step(build_model(chains(n_chains, **off), "cpu"), steps)
    assert np.max(np.abs(want - plain)) > 0  # event steps were taken
    np.testing.assert_array_equal(sweep(model, steps, steps_per_launch=7), want)
    plan = plan_tile(model.features, model.grain_count, model.chain_count, **plan_keywords)
    np.testing.assert_array_equal(fused(model, plan, steps), want)


@pytest.mark.parametrize("case", [case for case in EVENT_CASES if "windows" not in case])
def test_fused_event_steps_on_every_device(case, device):
    """The tile kernel's event steps equal the per-step kernel's on this device (on CUDA: to rounding)."""
    sections, n_chains, plan_keywords = EVENT_CASES[case]
    steps = 300
    model = build_model(chains(n_chains, **sections), device)
    want = per_step(model, steps)
    plan = plan_tile(model.features, model.grain_count, model.chain_count, **plan_keywords)
    assert_kernels_agree(fused(model, plan, steps), want, device)


def test_tile_event_steps_hold_a_fixed_bottom():
    """l0 = 0, fixed bottom: the pulse reaches the held grain's only contact, which opens and closes, so
    the tile kernel flags the held grain; its event step must leave it where it is (as the per-step kernel
    does). Run until the last free grain has moved; every value equals the per-step kernel's."""
    sections = dict(chain={"grains": 12, "l0": 0.0}, boundary={"bottom": "fixed"}, integrator={"dt": 5e-4})
    model = build_model(chains(2, **sections), "cpu")
    assert model.features.event_window > 0
    steps = 1201
    want = per_step(model, steps)
    assert_every_window_moved(want, [(0, model.grain_count)], held_bottom=True)
    np.testing.assert_array_equal(want[:, :, -1], model.initial_state().x.numpy()[:, :, -1])
    plan = plan_tile(model.features, model.grain_count, model.chain_count, grains_per_lane=4)
    np.testing.assert_array_equal(fused(model, plan, steps), want)


def test_tile_kernel_writes_the_event_step_once():
    """The fused kernel tests every contact of a lane once (unrolled: G + 1 calls of the contact test) but
    writes the event step once, in the loop over rounds of the chain's shared event steps, whatever G: inlined
    per grain it made the CUDA code G times larger (kernels/tile.py). Generated C++ only, nothing compiled."""
    for features in (
        Features(method="gear4", surface="wall", bottom="wall", static="none", event_window=0.5),
        Features(method="gear5", surface="driven", bottom="fixed", static="uniform", event_window=0.5),
    ):
        for grains_per_lane in (4, 16):
            shape = TileShape(grains_per_lane, 4, inline_event_step=True)
            source = generated_source(tile_kernel(features, shape), block_dim=shape.block_dim)
            advance = function_body(source, "advance")
            assert call_count(advance, "near_event") == grains_per_lane + 1, (features, grains_per_lane)
            assert call_count(advance, "event_step") == 0, (features, grains_per_lane)
            assert call_count(advance, "shared_event_steps") == 1, (features, grains_per_lane)
            assert call_count(function_body(source, "shared_event_steps"), "event_step") == 1, (
                features,
                grains_per_lane,
            )
    # out of line: the one call site calls a function the compiler must not inline
    shape = TileShape(8, 4, inline_event_step=False)
    source = generated_source(tile_kernel(features, shape), block_dim=shape.block_dim)
    assert call_count(function_body(source, "shared_event_steps"), "event_step_call") == 1
    assert re.search(r"^static WP_NOINLINE [^\n]*__locals__event_step_call_\d+\(", source, re.MULTILINE)


def test_out_of_line_event_step_takes_the_same_steps():
    """TileShape.inline_event_step = False (a tuning knob for CUDA; inlined is the default) computes the
    same bits."""
    sections, n_chains, plan_keywords = EVENT_CASES["l0 = 0, gear4, free ends, 2 chains per block"]
    steps = 300
    model = build_model(chains(n_chains, **sections), "cpu")
    plan = plan_tile(model.features, model.grain_count, model.chain_count, inline_event_step=False, **plan_keywords)
    assert "event-step=call" in plan.describe()
    np.testing.assert_array_equal(fused(model, plan, steps), per_step(model, steps))


def test_bad_event_modes_are_one_line_errors():
    for args, key in (
        (["accuracy", "--events", "maybe", "--dt", "2e-4"], "--events"),
        (["check", "--set", "integrator.events=maybe"], "integrator.events"),
    ):
        result = invoke(*args)
        assert result.exit_code == 2, result.output
        assert key in result.output and "Traceback" not in result.output


@pytest.mark.slow
def test_wall_struck_chain_converges_like_the_smooth_case():
    """A wall-struck chain: 200 grains, l0 = 1e-4, v_imp = 1e-2, duration 8, gear4. The struck grain leaves
    the wall; with event-aware steps the error falls at every halving of dt and stays within 3× of
    the same chain's error with a load surface (no contact opens) at dt = 2e-4 and 1e-4. Without them
    (docs/records/accuracy/events.json, "wall") the error at 1e-4 is 3× the one at 2e-4 and 30× the load surface's."""
    dts = [4e-4, 2e-4, 1e-4, 5e-5]
    scene = make_scene(chain={"grains": 200, "l0": 1e-4}, excitation={"impact": 1e-2}, integrator={"duration": 8.0})
    wall, _, _ = work_precision(scene, ["gear4"], dts, ["float64"], device="cpu", events=["auto"])
    load, _, _ = work_precision(
        scene.with_overrides({"boundary.surface": "load"}), ["gear4"], dts, ["float64"], device="cpu", events=["off"]
    )
    errors = [r.error for r in wall]
    smooth = [r.error for r in load]
    assert all(a > b for a, b in zip(errors, errors[1:])), errors
    assert errors[1] <= 3 * smooth[1] and errors[2] <= 3 * smooth[2], (errors, smooth)


def test_cuda_runs_with_event_steps_say_what_they_cost():
    from hertzian.core.solvers.calibrate import event_cost_note

    loose = features_of([make_scene(chain={"grains": 20, "l0": 0.0}, excitation={"impact": 1e-2})])
    plain = features_of(
        [make_scene(chain={"grains": 20, "l0": 0.0}, excitation={"impact": 1e-2}, integrator={"events": "off"})]
    )
    assert 'integrator.events = "off"' in event_cost_note(loose, is_cpu=False)
    assert event_cost_note(loose, is_cpu=True) is None and event_cost_note(plain, is_cpu=False) is None


def test_event_kernels_calibrate_only_shapes_that_do_not_spill():
    """The calibration times G = 8 and 4 for a kernel with event-aware steps (at G = 16 or under a 168-register cap
    its event code spills on sm_90), and still G = 16 and the capped G = 8 for plain steps."""
    from hertzian.core.solvers.calibrate import whole_chain_configs

    sections = {
        "chain": {"grains": 200, "l0": 0.0},
        "excitation": {"impact": 1e-2},
        "integrator": {"method": "gear4", "dt": 1e-3, "duration": 1.0},
    }
    events = build_model(chains(4, **sections), "cpu")
    plain = build_model(chains(4, **{**sections, "integrator": {**sections["integrator"], "events": "off"}}), "cpu")
    assert events.features.event_window > 0 and plain.features.event_window == 0

    def shapes(model):
        return {(c.shape.grains_per_lane, c.shape.max_registers) for c in whole_chain_configs(model)}

    assert {G for G, _ in shapes(events)} == {4, 8}
    assert all(cap == 0 for _, cap in shapes(events))
    assert (16, 0) in shapes(plain) and (8, 168) in shapes(plain)


def test_event_shapes_beyond_shared_memory_are_refused():
    """With event-aware steps a block keeps its state at t_n and one result per grain in shared memory; a shape
    that needs more than a block may have is refused at planning (the calibration then skips it), one line."""
    from hertzian.kernels.tile import SHARED_BYTES, shared_bytes

    events = Features(method="gear4", surface="wall", bottom="wall", static="uniform", event_window=1e-2)
    plain = Features(method="gear4", surface="wall", bottom="wall", static="uniform")
    big = dict(grains_per_lane=16, lanes_per_chain=256)
    assert shared_bytes(events, TileShape(16, 256)) == 2 * 256 * 6 * 8 + 2 * 256 * 16 * 4 * 8 + 256 * 4
    with pytest.raises(ValueError, match="shared memory"):
        plan_tile(events, 4096, 1, **big)
    assert shared_bytes(plain, TileShape(16, 256)) <= SHARED_BYTES
    plan_tile(plain, 4096, 1, **big)
    plan_tile(events, 1000, 1, grains_per_lane=4)  # the frontier workload's shape fits
