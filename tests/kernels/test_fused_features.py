"""Traces and drive on the fused solvers (CPU chain kernel, tile, window) against the per-step kernel.

The per-step kernel writes trace samples inside the step and integrates the driven surface grain
itself (kernels/step.py); the fused solvers sample the ring between stride-aligned pieces and the
chain kernel copies the driven path expression for expression. On the CPU every record, every trace
sample and the driver's work must agree bit for bit (on CUDA too with HERTZIAN_FUSE_FP=0; by default to
rounding there, tests.helpers.assert_kernels_agree). Each case asserts that motion reached the
last traced grain / the bottom of the chain before comparing (a test of zeros against zeros
cannot fail).
"""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest
from hertzian.core.model import build_model
from hertzian.core.runner import Runner
from hertzian.core.solvers import CHAIN, choose_config, config_of
from hertzian.core.solvers.calibrate import step_reason
from hertzian.kernels.tile import plan_tile

from tests.helpers import (
    MOVED,
    accessed_arrays,
    assert_every_window_moved,
    assert_kernels_agree,
    call_count,
    chains,
    function_body,
    generated_source,
    window_ranges,
)

TRACED = {"grains": 30, "l0": 1e-4}
TRACE_RECORD = {"every": 0.1, "traces": [0, 13, 28], "trace_every": 4e-3, "fields": ["u", "v"]}
"""Stride 8 steps (dt 5e-4): pieces between records and monitor checks are cut at trace steps."""


def traced_scenes(**extra):
    return chains(2, chain=dict(TRACED), integrator={"dt": 5e-4, "duration": 2.0}, record=dict(TRACE_RECORD), **extra)


def run(model, kernel, monitor_every=11):
    return Runner(model, kernel=kernel, use_graph=False, monitor_every=monitor_every).run()


def assert_same_run(got, want, *, last_traced_moved=True, device="cpu"):
    assert got.traces and want.traces
    if last_traced_moved:
        u = np.abs(want.traces["u"])
        assert np.all(u[:, :, -1].max(axis=1) > MOVED * u.max(axis=(1, 2))), "motion never reached the last trace"
    for name in ("u", "v"):
        assert_kernels_agree(got.traces[name], want.traces[name], device)
        assert_kernels_agree(got.fields[name], want.fields[name], device)
    assert_kernels_agree(got.energy, want.energy, device)
    if want.work is not None:
        assert np.max(np.abs(want.work)) > 0
        assert_kernels_agree(got.work, want.work, device)
    np.testing.assert_array_equal(got.status, want.status)


def test_sweep_traces_equal_per_step():
    model = build_model(traced_scenes(), "cpu")
    want = run(model, "step")
    got = run(model, "chain")
    assert got.kernel == "chain"
    assert_same_run(got, want)


@pytest.mark.parametrize("windowed", [False, True])
def test_tile_traces_equal_per_step(windowed, device):
    model = build_model(traced_scenes(), device)
    f = replace(model.features, traces=False)
    keywords = (
        dict(grains_per_lane=4, lanes_per_chain=4, steps_per_launch=5, windowed=True)
        if windowed
        else dict(grains_per_lane=4)
    )
    config = config_of(plan_tile(f, model.grain_count, model.chain_count, **keywords))
    want = run(model, "step")
    got = run(model, config)
    assert_same_run(got, want, device=device)


def test_auto_picks_sweep_for_traces():
    model = build_model(traced_scenes(), "cpu")
    assert choose_config(model, "auto", run_steps=10**8) == CHAIN
    assert step_reason(model, 10**8) is None
    assert step_reason(model, 10) is None  # a short run too: the chain kernel is faster, its compile included


def driven_scenes(*, traces: bool, **sections):
    """Two driven chains (amplitudes differ) that open and close contacts at the surface."""
    from hertzian.core.scene import scene_from_dict

    data = {
        "chain": {"grains": 24, "l0": 1e-4},
        "boundary": {"surface": "driven"},
        "excitation": {"drive_amplitude": 2e-4, "drive_period": 0.5},
        "integrator": {"dt": 5e-4, "duration": 2.0},
        "record": dict(TRACE_RECORD, traces=[0, 1, 12, 22]) if traces else {"every": 0.1, "fields": ["u", "v"]},
    }
    for key, value in sections.items():
        data.setdefault(key, {}).update(value)
    base = scene_from_dict(data)
    return [base, base.with_overrides({"excitation.drive_amplitude": 3e-4})]


DRIVEN_CASES = {
    "traces, events auto, bottom wall": dict(traces=True),
    # traces of a driven chain with plain steps (no event section in the fused kernels' step loop)
    "traces, events off, bottom wall": dict(traces=True, integrator={"events": "off"}),
    "no traces, events off, fixed bottom, gear5": dict(
        traces=False, boundary={"bottom": "fixed"}, integrator={"events": "off", "method": "gear5"}
    ),
    "float32 (compensated), events auto": dict(traces=False, integrator={"precision": "float32"}),
}


@pytest.mark.parametrize("case", list(DRIVEN_CASES))
def test_sweep_drive_equals_per_step(case):
    model = build_model(driven_scenes(**DRIVEN_CASES[case]), "cpu")
    want = run(model, "step")
    got = run(model, "chain")
    assert got.kernel == "chain"
    if want.traces:
        assert_same_run(got, want)
    else:
        for name in ("u", "v"):
            np.testing.assert_array_equal(got.fields[name], want.fields[name])
        np.testing.assert_array_equal(got.energy, want.energy)
        np.testing.assert_array_equal(got.work, want.work)
    # the drive reached the bottom (the last free grain moved), and the driver did work
    u = np.abs(want.u)
    last = -2 if DRIVEN_CASES[case].get("boundary") else -1
    assert np.all(u[:, :, last].max(axis=1) > MOVED * u.max(axis=(1, 2)))
    assert np.all(np.max(np.abs(want.work), axis=1) > 0)


TILE_DRIVE = [
    (case, windowed) for case in DRIVEN_CASES for windowed in (False, True) if windowed or case.startswith("traces")
] + [("traces, events auto, bottom wall", "G=2")]
"""Whole-chain and windowed shapes for the traced case, the windowed shape for the other (compile time), and
windows of 2 grains per lane (the calibration's one-warp shape at G = 2)."""
SHAPE_KEYWORDS = {
    False: dict(grains_per_lane=4),
    True: dict(grains_per_lane=4, lanes_per_chain=4, steps_per_launch=5, windowed=True),
    "G=2": dict(grains_per_lane=2, lanes_per_chain=6, steps_per_launch=4, windowed=True),
}


@pytest.mark.parametrize("case,windowed", TILE_DRIVE)
def test_tile_drive_equals_per_step(case, windowed, device):
    # the driver's phases come from a device table and its work is summed after each launch's steps (kernels/tile.py)
    sections = DRIVEN_CASES[case]
    model = build_model(driven_scenes(**sections), device)
    f = replace(model.features, traces=False)
    keywords = SHAPE_KEYWORDS[windowed]
    plan = plan_tile(f, model.grain_count, model.chain_count, **keywords)
    want = run(model, "step")
    got = run(model, config_of(plan))
    held = "boundary" in sections
    # every window (and its ghost exchange) saw the drive's motion before comparing
    assert_every_window_moved(
        np.stack([np.abs(want.u).max(axis=1), np.abs(want.v).max(axis=1)]),
        window_ranges(plan, model.grain_count),
        held_bottom=held,
    )
    for name in ("u", "v"):
        assert_kernels_agree(got.fields[name], want.fields[name], device)
        if want.traces:
            assert_kernels_agree(got.traces[name], want.traces[name], device)
    assert_kernels_agree(got.energy, want.energy, device)
    assert np.all(np.max(np.abs(want.work), axis=1) > 0)
    assert_kernels_agree(got.work, want.work, device)


@pytest.mark.parametrize("launches_per_table", [1, 3])
def test_drive_table_refilled_within_an_advance_equals_per_step(launches_per_table, device, monkeypatch):
    """The driver's phases come from a device table that TileSolver fills before its launches (kernels/tile.py
    drive_table); with the table covering one launch, or three, it is refilled within every advance between
    records, and the fused run still equals the per-step kernel."""
    import hertzian.core.solvers.tile as tile_solver

    sections = DRIVEN_CASES["traces, events auto, bottom wall"]
    model = build_model(driven_scenes(**sections), device)
    plan = plan_tile(
        replace(model.features, traces=False), model.grain_count, model.chain_count, **SHAPE_KEYWORDS[True]
    )
    k = plan.steps_per_launch
    monkeypatch.setattr(tile_solver, "DRIVE_TABLE_BYTES", 16 * model.chain_count * (launches_per_table * k + 2))
    assert tile_solver.TileSolver(model, config_of(plan)).table_steps == launches_per_table * k
    assert np.diff(model.scenes[0].record_steps).min() > 2 * launches_per_table * k  # refilled between records
    want = run(model, "step")
    got = run(model, config_of(plan))
    for name in ("u", "v"):
        assert_kernels_agree(got.fields[name], want.fields[name], device)
        assert_kernels_agree(got.traces[name], want.traces[name], device)
    assert np.all(np.max(np.abs(want.work), axis=1) > 0)
    assert_kernels_agree(got.work, want.work, device)
    assert_kernels_agree(got.energy, want.energy, device)


def test_driven_window_needs_grains_0_and_1_in_one_lane():
    model = build_model(driven_scenes(traces=False), "cpu")
    with pytest.raises(ValueError, match="grains 0 and 1"):
        plan_tile(
            model.features,
            model.grain_count,
            model.chain_count,
            grains_per_lane=4,
            lanes_per_chain=4,
            steps_per_launch=3,
            windowed=True,
        )
    # also where grain 0 is the last of a lane in the second window that holds it (its interior is short of its ghost)
    with pytest.raises(ValueError, match="grains 0 and 1"):
        plan_tile(
            model.features,
            model.grain_count,
            model.chain_count,
            grains_per_lane=4,
            lanes_per_chain=3,
            steps_per_launch=5,
            windowed=True,
        )


@pytest.mark.parametrize(
    "keywords",
    [
        dict(grains_per_lane=4),
        dict(grains_per_lane=8, lanes_per_chain=4),
        SHAPE_KEYWORDS[True],
        SHAPE_KEYWORDS["G=2"],
        dict(grains_per_lane=4, lanes_per_chain=4, steps_per_launch=4, windowed=True),
        dict(grains_per_lane=8, lanes_per_chain=3, steps_per_launch=6, windowed=True),
    ],
)
def test_driver_slot_is_grain_0s_place_in_every_block_that_holds_it(keywords):
    # the fused kernel reads the driven grain at a fixed register (shape.driver_slot) when every block holding grain 0
    # has it at the same place in a lane: here found by listing every block's grains, lane by lane
    model = build_model(driven_scenes(traces=False), "cpu")
    plan = plan_tile(model.features, model.grain_count, model.chain_count, **keywords)
    G, lanes = plan.shape.grains_per_lane, plan.shape.lanes_per_chain
    places = set()
    for block in range(plan.blocks_per_chain):
        first = block * plan.interior - plan.ghost if plan.shape.windowed else 0
        for lane in range(lanes):
            for k in range(G):
                if first + lane * G + k == 0:
                    places.add(k)
    assert len(places) == 1 and plan.shape.driver_slot == places.pop()
    undriven = plan_tile(replace(model.features, surface="free"), model.grain_count, model.chain_count, **keywords)
    assert undriven.shape.driver_slot == -1


def test_records_reach_the_host_arrays():
    # records are staged (two alternating buffers) and unpacked at the end: the last two records must
    # be the final state, and the trace rows of the last record the ring's last samples
    model = build_model(traced_scenes(), "cpu")
    runner = Runner(model, kernel="chain", use_graph=False)
    result = runner.run()
    x = runner.current.x.numpy()
    np.testing.assert_array_equal(result.u[:, -1], x[0])
    np.testing.assert_array_equal(result.v[:, -1], x[1] / np.float64(model.dt))
    np.testing.assert_array_equal(result.traces["u"][:, -1], x[0][:, TRACE_RECORD["traces"]])
    assert np.all(result.energy[:, -2:] > 0)
    # the record before the last is another state (the run moved in between)
    assert np.max(np.abs(result.u[:, -2] - result.u[:, -1])) > 0


def test_traces_of_advances_that_end_between_trace_steps():
    # advances of 13 and 40 steps (not multiples of the stride 8): the kernel writes its samples by the clock
    from hertzian.core.solvers import ChainSolver

    model = build_model(traced_scenes(), "cpu")
    reference = Runner(model, kernel="step", use_graph=False, monitor_every=0)
    reference.advance(13)
    reference.advance(40)
    solver = ChainSolver(model)
    first, second = model.state_pair()
    a = solver.advance(first, second, 13)
    a = solver.advance(a, second if a is first else first, 40)
    np.testing.assert_array_equal(a.x.numpy(), reference.current.x.numpy())
    np.testing.assert_array_equal(a.traces.numpy(), reference.current.traces.numpy())
    assert np.max(np.abs(a.traces.numpy())) > 0


@pytest.mark.parametrize("kernel", ["chain", "tile"])
def test_response_windows_on_the_fused_kernels_equal_per_step(kernel, device):
    """Response windows (V_k, window KE, driver-open fraction) of a driven chain whose surface contact opens:
    the fused kernels (sampled between launches) give the per-step kernel's sums."""
    if kernel == "chain" and device != "cpu":
        pytest.skip("the chain kernel is a CPU kernel")
    record = {
        "every": 0.5,
        "fields": ["v"],
        "response_start": 0.5,
        "response_periods": 1,
        "response_windows": 3,
        "harmonics": 2,
    }
    model = build_model(driven_scenes(traces=False, record=record), device)
    want = run(model, "step")
    if kernel == "chain":
        config = "chain"
    else:
        config = config_of(
            plan_tile(replace(model.features, traces=False), model.grain_count, model.chain_count, grains_per_lane=4)
        )
    got = run(model, config)
    assert got.kernel != "step"
    assert np.all(np.abs(want.response["response"][..., 1, -1]) > 0)  # the drive's harmonic reached the bottom grain
    assert np.all(want.response["driver_open"] > 0)  # the surface contact opened: event steps were taken
    for name in ("response", "window_ke", "driver_open"):
        assert_kernels_agree(got.response[name], want.response[name], device)


@pytest.mark.parametrize("windowed", [False, True])
def test_tile_writes_trace_samples_inside_the_launch_frozen_chains_included(windowed):
    """The tile/window kernels write the trace ring themselves (one launch per K steps, the traced grains
    written by the lanes that keep them): after an advance the ring is the per-step kernel's bit for bit, a
    frozen (non-finite) chain's samples included."""
    from hertzian.core.solvers import TileSolver

    model = build_model(traced_scenes(), "cpu")
    f = replace(model.features, traces=False)
    keywords = (
        dict(grains_per_lane=4, lanes_per_chain=4, steps_per_launch=5, windowed=True)
        if windowed
        else dict(grains_per_lane=4)
    )
    solver = TileSolver(model, config_of(plan_tile(f, model.grain_count, model.chain_count, **keywords)))
    assert solver.kernel_features.traces
    status = np.array([1, 0], dtype=np.int32)
    steps = 160
    reference = Runner(model, kernel="step", use_graph=False)
    reference.current.status.assign(status)
    reference.advance(steps)
    start, scratch = model.state_pair()
    start.status.assign(status)
    end = solver.advance(start, scratch, steps)
    ring = end.traces.numpy()
    np.testing.assert_array_equal(ring, reference.current.traces.numpy())
    # both chains hold samples (the frozen one: its frozen state), and the running one's change in time
    assert np.max(np.abs(ring[:, 0])) > 0 and np.max(np.abs(ring[:, 1])) > 0
    assert np.ptp(ring[0, 1, :20, 0]) > 0


def test_driven_kernel_never_indexes_registers_by_the_driven_grain():
    # grain 0's position in its lane (k0) is known only at run time; an array or matrix index of k0 makes CUDA keep
    # the lane's whole state in local memory, for every lane and step (the driven column stepped several times
    # slower than an undriven one until the drive used selects over the static positions)
    from hertzian.kernels.tile import tile_kernel

    model = build_model(driven_scenes(traces=False), "cpu")
    f = replace(model.features, traces=False)
    plan = plan_tile(
        f, model.grain_count, model.chain_count, grains_per_lane=4, lanes_per_chain=4, steps_per_launch=5, windowed=True
    )
    source = generated_source(tile_kernel(f, plan.shape), "cuda", block_dim=plan.shape.block_dim)
    # per generated function (variable names are local to each): k0 and k0 + 1 appear in comparisons and sums only
    functions = re.findall(r"^\S[^\n]*\n(?:[^\n]*\n)*?}\n", source, re.MULTILINE)
    uses = 0
    for body in functions:
        lines = [line.strip() for line in body.splitlines() if not line.lstrip().startswith("//")]
        names = {"var_k0"} | {
            m for line in lines for m in re.findall(r"^(var_\d+) = wp::add\(var_k0, var_\d+\);$", line)
        }
        for line in lines:
            if any(re.search(rf"\b{name}\b", line) for name in names):
                uses += 1
                assert not re.search(r"wp::(extract|index|assign\w*|view|address)\(", line), line
    assert uses > 0, "the driven kernel has no k0"


def _entry_uses_local_memory(ptx: str) -> bool:
    """Whether the kernel entry of a PTX module declares local memory (register arrays indexed at run time,
    or spills the front end already decided); helper functions (the trig slow path) are not counted."""
    entry = ptx[ptx.index(".entry") :]
    end = entry.find("\n.func")
    return ".local" in (entry if end < 0 else entry[:end])


@pytest.mark.parametrize("driven", [True, False], ids=["driven column", "struck chain"])
def test_fused_kernel_keeps_its_state_in_registers(driven, tmp_path):
    # the CUDA C++ of a windowed kernel compiled to PTX for sm_90 by NVRTC (no GPU needed): a loop Warp does not
    # unroll (e.g. range(G - 1)) or an index known only at run time puts the lane's matrices in local memory —
    # that made the driven column step several times slower than an undriven one
    from hertzian.kernels.tile import tile_kernel
    from warp._src import build

    scenes = (
        driven_scenes(traces=False, boundary={"bottom": "fixed"}, integrator={"events": "off"})
        if driven
        else chains(2, chain={"grains": 40}, integrator={"events": "off"})
    )
    model = build_model(scenes, "cpu")
    f = replace(model.features, traces=False)
    plan = plan_tile(
        f, model.grain_count, model.chain_count, grains_per_lane=4, lanes_per_chain=8, steps_per_launch=8, windowed=True
    )
    cu = tmp_path / "fused.cu"
    cu.write_text(generated_source(tile_kernel(f, plan.shape), "cuda", block_dim=plan.shape.block_dim))
    try:
        build.build_cuda(str(cu), 90, str(tmp_path / "fused.ptx"), pch_dir=None, use_precompiled_headers=False)
    except Exception as err:  # a Warp without NVRTC
        pytest.skip(f"no CUDA compiler: {err}")
    assert not _entry_uses_local_memory((tmp_path / "fused.ptx").read_text(errors="replace"))


def test_auto_takes_a_tuned_fused_kernel_for_short_gpu_runs(tmp_path, monkeypatch):
    # a short run on a GPU takes a fused kernel without timing: the shape `hertzian tune` chose on the device (the
    # cache holds the choice), else the rule's shape; decided without a GPU on a stand-in model
    import json
    from types import SimpleNamespace

    from hertzian.core.solvers import calibrate

    monkeypatch.setenv("HERTZIAN_CACHE", str(tmp_path / "calibration.json"))
    real = build_model(chains(2, chain={"grains": 40}), "cpu")
    gpu = SimpleNamespace(name="cuda:0", is_cpu=False, is_cuda=True, sm_count=132)
    model = SimpleNamespace(
        features=real.features, device=gpu, grain_count=real.grain_count, chain_count=real.chain_count
    )
    assert calibrate.step_reason(model, run_steps=100) is None
    assert calibrate.choose_config(model, "auto", run_steps=100) == calibrate.default_config(model)
    cached = calibrate.whole_chain_configs(model)[-1]  # not the default shape
    (tmp_path / "calibration.json").write_text(json.dumps({calibrate._cache_key(model): cached.to_dict()}))
    assert calibrate.is_calibrated(model)
    assert calibrate.choose_config(model, "auto", run_steps=100) == cached
    # features no fused kernel has keep the per-step kernel, calibrated or not
    damped = SimpleNamespace(
        **{**vars(model), "features": replace(real.features, damping="contact", precision="float32")}
    )
    (tmp_path / "calibration.json").write_text(json.dumps({calibrate._cache_key(damped): {"kind": "tile"}}))
    assert "damping" in calibrate.step_reason(damped, run_steps=100)


DAMPED_CASES = {
    # driven, the driver's contact opening and closing: 2 chains of different γ
    "viscous, driven, fixed bottom": dict(
        damping={"model": "viscous"}, boundary={"bottom": "fixed"}, integrator={"events": "off"}
    ),
    "viscous, driven, bottom wall, gear5": dict(
        damping={"model": "viscous"}, integrator={"events": "off", "method": "gear5"}
    ),
    "viscous, driven, fixed bottom, float32 (compensated)": dict(
        damping={"model": "viscous"}, boundary={"bottom": "fixed"}, integrator={"events": "off", "precision": "float32"}
    ),
    "dashpot, driven, fixed bottom": dict(
        damping={"model": "contact"}, boundary={"bottom": "fixed"}, integrator={"events": "off"}
    ),
    "dashpot, driven, bottom wall, gear5": dict(
        damping={"model": "contact"}, integrator={"events": "off", "method": "gear5"}
    ),
    "dashpot, driven, free bottom (l0 = 0), gear6": dict(
        damping={"model": "contact"},
        chain={"l0": 0.0},
        boundary={"bottom": "free"},
        integrator={"events": "off", "method": "gear6"},
    ),
}


@pytest.mark.parametrize("case", list(DAMPED_CASES))
@pytest.mark.parametrize("windowed", [False, True])
def test_damping_on_the_fused_kernels_equals_per_step(case, windowed, device):
    """Damping (viscous, and the contact dashpot with the driver's contact and the walls) in the tile and window
    kernels is the per-step kernel's: fields, energy, the driver's work and the dissipated energy D per grain,
    bit for bit on the CPU (to rounding on CUDA). The windowed plan cuts the 24-grain chains into windows of 8
    interior grains, so D and the dashpots cross window and lane edges."""
    sections = {k: dict(v) for k, v in DAMPED_CASES[case].items()}
    sections["damping"]["gamma"] = 0.8
    scenes = driven_scenes(traces=False, **sections)
    scenes[1] = scenes[1].with_overrides({"damping.gamma": 3.0})
    model = build_model(scenes, device)
    want = run(model, "step")
    keywords = (
        dict(grains_per_lane=4, lanes_per_chain=4, steps_per_launch=4, windowed=True)
        if windowed
        else dict(grains_per_lane=4)
    )
    config = config_of(plan_tile(model.features, model.grain_count, model.chain_count, **keywords))
    got = run(model, config)
    assert got.kernel.startswith("window" if windowed else "tile"), got.kernel
    moving = -2 if sections.get("boundary", {}).get("bottom") == "fixed" else -1  # the last grain that moves
    v = np.abs(want.fields["v"])
    assert np.all(v[:, :, moving].max(axis=1) > MOVED * v.max(axis=(1, 2))), "motion never reached the bottom"
    assert np.all(want.dissipated[:, -1] > 0) and np.all(np.diff(want.dissipated, axis=1) >= 0)
    assert want.dissipated[1, -1] > want.dissipated[0, -1]  # the larger γ dissipates more here
    for name in ("u", "v"):
        assert_kernels_agree(got.fields[name], want.fields[name], device)
    for name in ("energy", "work", "dissipated"):
        assert_kernels_agree(getattr(got, name), getattr(want, name), device)
    assert_kernels_agree(got.energy_error, want.energy_error, device)


def test_dashpot_between_walls_on_the_fused_kernels_equals_per_step():
    """The surface wall's dashpot (the contact above grain 0, which no integrated grain owns) in the tile and
    window kernels: an impact between walls, per-step kernel bit for bit; the impact reaches the bottom wall."""
    from hertzian.core.scene import scene_from_dict

    scene = scene_from_dict(
        {
            "chain": {"grains": 24, "l0": 1e-4},
            "excitation": {"impact": 1e-2},
            "boundary": {"surface": "wall", "bottom": "wall"},
            "integrator": {"duration": 2.0, "dt": 1e-3, "events": "off"},
            "damping": {"model": "contact", "gamma": 0.5},
            "record": {"every": 0.25, "fields": ["u", "v"]},
        }
    )
    model = build_model([scene, scene.with_overrides({"excitation.impact": 2e-2})], "cpu")
    want = run(model, "step")
    v = np.abs(want.fields["v"])
    assert np.all(v[..., -1].max(axis=1) > MOVED * v.max(axis=(1, 2))), "motion never reached the bottom"
    assert np.all(want.dissipated[:, -1] > 0)
    for keywords in (
        dict(grains_per_lane=4),
        dict(grains_per_lane=4, lanes_per_chain=4, steps_per_launch=4, windowed=True),
    ):
        got = run(model, config_of(plan_tile(model.features, model.grain_count, model.chain_count, **keywords)))
        for name in ("u", "v"):
            np.testing.assert_array_equal(got.fields[name], want.fields[name])
        for name in ("energy", "dissipated"):
            np.testing.assert_array_equal(getattr(got, name), getattr(want, name))


def test_undamped_fused_kernels_hold_no_damping_code():
    """Leave out what a scene does not need: without damping the tile kernel's generated code reads neither γ
    nor the dissipated energy; with viscous damping it reads and writes both."""
    from hertzian.kernels.tile import tile_kernel

    scenes = driven_scenes(traces=False, integrator={"events": "off"})
    plain = build_model(scenes, "cpu").features
    damped = replace(plain, damping="viscous")
    shape = plan_tile(plain, 24, 2, grains_per_lane=4).shape
    plain_arrays = accessed_arrays(generated_source(tile_kernel(plain, shape), block_dim=shape.block_dim))
    damped_arrays = accessed_arrays(generated_source(tile_kernel(damped, shape), block_dim=shape.block_dim))
    assert not {"damping", "dissipated"} & plain_arrays
    assert {"damping", "dissipated"} <= damped_arrays


def test_fused_kernels_refuse_the_dashpot_in_compensated_float32():
    """The contact dashpot in compensated float32 is left to the per-step and CPU chain kernels: the tile kernel
    refuses it (one line), and a forced tile kernel on such a scene is refused before anything runs."""
    from hertzian.kernels.tile import tile_kernel

    model = build_model(
        driven_scenes(
            traces=False,
            damping={"model": "contact", "gamma": 0.5},
            integrator={"events": "off", "precision": "float32"},
        ),
        "cpu",
    )
    assert model.features.compensation
    with pytest.raises(ValueError, match="damping"):
        tile_kernel(
            model.features, plan_tile(model.features, model.grain_count, model.chain_count, grains_per_lane=4).shape
        )
    with pytest.raises(ValueError, match="damping"):
        choose_config(model, "tile")


def test_trace_sample_is_written_out_of_the_step_loop():
    """The fused kernel writes a trace sample through one out-of-line function, called only when a sample is due:
    written into the step loop, the sample's code slowed every step of the traced window kernel (docs/benchmarks.md). Generated C++ only, nothing compiled."""
    from hertzian.kernels.features import Features
    from hertzian.kernels.tile import TileShape, tile_kernel

    for surface in ("wall", "driven"):
        features = Features(method="gear4", surface=surface, bottom="wall", static="uniform", traces=True)
        shape = TileShape(4, 32, windowed=True, masked=True)
        source = generated_source(tile_kernel(features, shape), block_dim=shape.block_dim)
        assert re.search(r"^static WP_NOINLINE [^\n]*__locals__write_trace_sample_\d+\(", source, re.MULTILINE)
        assert call_count(function_body(source, "write_traces"), "write_trace_sample") == 1


def test_a_composed_ring_keeps_its_state_in_registers(tmp_path):
    """The whole-chain kernel of a yoshida6 β-FPUT ring of 1 024 sites (128 lanes of 8): its substeps run in a loop,
    the first and last lanes exchange edges, and still no register array is indexed at run time (sm_90 PTX by
    NVRTC, no GPU needed)."""
    from hertzian.kernels.tile import tile_kernel
    from warp._src import build

    ring = {"surface": "periodic", "bottom": "periodic"}
    scenes = chains(1, chain={"grains": 1024, "potential": "fput", "a": 1.0, "beta": 1.0}, boundary=ring)
    f = replace(build_model(scenes, "cpu").features, method="yoshida6")
    plan = plan_tile(f, 1024, 4096, grains_per_lane=8)
    assert plan.shape.lanes_per_chain == 128
    cu = tmp_path / "ring.cu"
    cu.write_text(generated_source(tile_kernel(f, plan.shape), "cuda", block_dim=plan.shape.block_dim))
    try:
        build.build_cuda(str(cu), 90, str(tmp_path / "ring.ptx"), pch_dir=None, use_precompiled_headers=False)
    except Exception as err:  # a Warp without NVRTC
        pytest.skip(f"no CUDA compiler: {err}")
    assert not _entry_uses_local_memory((tmp_path / "ring.ptx").read_text(errors="replace"))
