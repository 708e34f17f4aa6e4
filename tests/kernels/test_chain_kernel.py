"""The CPU chain kernel (kernels/cpu.py) against the per-step kernel, and the runner's kernel choice.

The sweep integrates a chain in place with its neighbours in registers; it performs the per-step
kernel's operations in the same order, so on the CPU the states must agree bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp
from hertzian.core.model import build_model
from hertzian.core.runner import Runner
from hertzian.core.solvers import CHAIN, STEP, ChainSolver, SolverConfig, choose_config

from tests.helpers import CASES, chains, invoke, per_step, sweep


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
    scenes = chains(
        3, chain={"grains": 30, "l0": 1e-4}, integrator={"dt": 5e-4, "duration": 0.05}, record={"every": 0.01}
    )
    model = build_model(scenes, "cpu")
    reference = Runner(model, kernel="step").run()
    runner = Runner(model, kernel="chain")
    assert isinstance(runner.solver, ChainSolver)
    result = runner.run()
    np.testing.assert_array_equal(result.u, reference.u)
    np.testing.assert_array_equal(result.v, reference.v)
    np.testing.assert_array_equal(result.energy, reference.energy)
    np.testing.assert_array_equal(result.status, reference.status)


def test_kernel_choice(monkeypatch):
    from hertzian.core.solvers import calibrate

    model = build_model(chains(2, chain={"grains": 10}), "cpu")
    assert choose_config(model, "step") == STEP
    monkeypatch.setattr(calibrate, "in_kernel_cache", lambda module, device: False)  # a cold kernel cache
    assert choose_config(model, "auto", run_steps=10) == STEP  # too short to repay the chain kernel's compile
    monkeypatch.setattr(calibrate, "in_kernel_cache", lambda module, device: True)  # both compiled already
    assert choose_config(model, "auto", run_steps=10) == CHAIN
    assert choose_config(model, "auto", run_steps=10**8) == CHAIN
    traced = build_model(chains(2, chain={"grains": 10}, record={"traces": [0]}), "cpu")
    assert choose_config(traced, "auto", run_steps=10**8) == CHAIN  # traces are sampled between launches
    with pytest.raises(ValueError):
        choose_config(model, "fastest")


@pytest.mark.parametrize(
    "case",
    ["walls, padded lanes", "windows, fixed bottom, impurities, gravity", "float32, walls, padded lanes, events"],
)
def test_chain_split_over_threads_changes_no_bit(case, monkeypatch):
    """The CPU chain kernel launches contiguous chain ranges from several Python threads at once
    (ensemble/core/solvers/chain.py); each chain is still one kernel thread's, so any split gives the same bits."""
    from hertzian.core.solvers import chain as chain_module
    from hertzian.core.solvers.chain import chain_ranges

    monkeypatch.setattr(chain_module, "MIN_GRAIN_STEPS_TO_SPLIT", 0)  # these launches are small: split anyway
    sections, _, _, steps = CASES[case]
    model = build_model(chains(5, **sections), "cpu")
    results = []
    for threads in (1, 2, 3, 5):
        solver = ChainSolver(model, SolverConfig("chain", steps_per_launch=7), threads=threads)
        assert len(solver.ranges) == min(threads, 5) and solver.ranges == chain_ranges(5, threads)
        start, scratch = model.state_pair()
        end = solver.advance(start, scratch, steps)
        assert end.clock.numpy()[0] == steps
        results.append(end.x.numpy())
    assert np.max(np.abs(results[0])) > 0
    for got in results[1:]:
        np.testing.assert_array_equal(got, results[0])
    np.testing.assert_array_equal(results[0], per_step(model, steps))


def test_cpu_thread_count_comes_from_the_environment(monkeypatch):
    from hertzian.core.solvers.chain import cpu_threads

    monkeypatch.setenv("HERTZIAN_CPU_THREADS", "3")
    assert cpu_threads() == 3
    monkeypatch.setenv("HERTZIAN_CPU_THREADS", "zero")
    result = invoke("run", "--device", "cpu")
    assert result.exit_code == 2
    assert result.stderr.strip().splitlines() == ["error: HERTZIAN_CPU_THREADS = 'zero': must be a whole number ≥ 1"]


def test_sweep_writes_trace_samples_inside_the_launch_as_the_per_step_kernel():
    """The chain kernel writes the trace ring itself (one launch per advance, several ranges of chains):
    the ring after an advance is the per-step kernel's bit for bit, a frozen chain's samples included."""

    scenes = chains(
        3,
        chain={"grains": 30, "l0": 1e-4},
        integrator={"dt": 5e-4, "duration": 0.2},
        record={"every": 0.1, "traces": [0, 13, 29], "trace_every": 4e-3},
    )
    model = build_model(scenes, "cpu")
    status = np.array([0, 1, 0], dtype=np.int32)  # chain 1 is frozen (non-finite status)
    steps = 200
    reference = Runner(model, kernel="step", use_graph=False)
    reference.current.status.assign(status)
    reference.advance(steps)
    solver = ChainSolver(model, threads=2)
    assert solver.kernel_features.traces and len(solver.ranges) == 2
    start, scratch = model.state_pair()
    start.status.assign(status)
    end = solver.advance(start, scratch, steps)
    ring = end.traces.numpy()
    np.testing.assert_array_equal(ring, reference.current.traces.numpy())
    np.testing.assert_array_equal(end.x.numpy(), reference.current.x.numpy())
    assert np.max(np.abs(ring[:, 0])) > 0 and np.max(np.abs(ring[:, 1])) > 0


WINDOW_CASES = {
    # name: (scene sections, steps until the pulse has reached the far end)
    **{
        short: (CASES[name][0], CASES[name][3])
        for short, name in (
            ("walls", "walls, padded lanes"),
            ("gear6", "gear6, full lanes"),
            ("fixed bottom, impurities, gravity", "windows, fixed bottom, impurities, gravity"),
            ("verlet, exponent 2, surface load", "verlet, exponent 2, surface load"),
            ("float32, events", "float32, walls, padded lanes, events"),
        )
    },
    "free ends": (
        dict(chain={"grains": 24}, boundary={"surface": "free", "bottom": "free"}, integrator={"dt": 5e-4}),
        3501,
    ),
    "yoshida4": (dict(chain={"grains": 48, "l0": 1e-4}, integrator={"method": "yoshida4", "dt": 5e-4}), 6001),
}


def windowed_solver(model, monkeypatch, windows: int, window_steps: int = 1) -> ChainSolver:
    """A chain solver that cuts each chain into ``windows`` (as many cores, at least twice as many threads as
    chains), exchanging every ``window_steps`` steps, even on launches too small to be split by default."""
    from hertzian.core.solvers import chain as chain_module

    monkeypatch.setattr(chain_module, "MIN_GRAIN_STEPS_TO_SPLIT", 0)
    monkeypatch.setattr(chain_module, "WINDOW_STEPS", window_steps)
    monkeypatch.setattr(chain_module, "usable_cores", lambda: windows)
    solver = ChainSolver(model, threads=max(windows, 2 * model.chain_count))
    assert len(solver.windows) == windows, solver.windows
    return solver


@pytest.mark.parametrize("case", list(WINDOW_CASES))
def test_chain_cut_into_windows_changes_no_bit(case, monkeypatch):
    """One chain on two threads: windows that trade the grains next to their cut every step (the least reach) or
    every 2 steps give the per-step kernel's bits, over runs that carry the pulse across the cut to the bottom."""
    sections, steps = WINDOW_CASES[case]
    model = build_model(chains(1, **sections), "cpu")
    want = per_step(model, steps)
    u = np.abs(want[0, 0])
    assert u[-2] > 1e-3 * u.max()  # the pulse reached the far end
    for window_steps in (1, 2):
        solver = windowed_solver(model, monkeypatch, 2, window_steps)
        start, scratch = model.state_pair()
        end = solver.advance(start, scratch, steps)
        assert end.clock.numpy()[0] == steps
        np.testing.assert_array_equal(end.x.numpy(), want)


def test_windows_of_driven_damped_traced_chains_change_no_bit(monkeypatch):
    """Two driven chains with a dashpot and traces, each cut in two: the records, the driver's work, the
    dissipated energy and the trace rings are the per-step kernel's bit for bit (each written by one window)."""
    from tests.kernels.test_fused_features import TRACE_RECORD, assert_same_run, driven_scenes

    scenes = driven_scenes(traces=True, damping={"model": "contact", "gamma": 0.8}, integrator={"events": "off"})
    assert TRACE_RECORD["traces"]
    model = build_model(scenes, "cpu")
    want = Runner(model, kernel="step", use_graph=False).run()
    windowed_solver(model, monkeypatch, 2, 2)  # the runner's solver is built the same way
    monkeypatch.setenv("HERTZIAN_CPU_THREADS", str(2 * model.chain_count))
    runner = Runner(model, kernel="chain")
    assert len(runner.solver.windows) == 2
    got = runner.run()
    assert_same_run(got, want)
    np.testing.assert_array_equal(got.dissipated, want.dissipated)
    assert np.max(np.abs(want.work)) > 0 and np.max(want.dissipated) > 0


def test_windows_need_chains_long_enough_to_cut():
    from hertzian.core.solvers.chain import MIN_WINDOW_GRAINS, chain_windows

    assert chain_windows(1000, 2, 16) == [(0, 516, 0, 500), (484, 1000, 500, 1000)]
    assert chain_windows(1000, 3, 16) == [(0, 350, 0, 334), (318, 683, 334, 667), (651, 1000, 667, 1000)]
    assert chain_windows(2 * MIN_WINDOW_GRAINS * 16, 2, 16) != []
    assert chain_windows(2 * MIN_WINDOW_GRAINS * 16 - 1, 2, 16) == []
    assert chain_windows(1000, 1, 16) == []


def test_a_window_left_alone_at_its_barrier_gives_up():
    """kernels/threads.py's barrier: a party whose partner never comes sets the abort flag after its spin limit and
    returns False, instead of hanging; two parties pass it."""
    import threading

    from hertzian.kernels.threads import barrier

    @wp.kernel(module="unique")
    def meet(
        state: wp.array(dtype=wp.uint32), parties: int, passed: wp.array(dtype=wp.int32), me: int, limit: wp.int64
    ):
        if barrier(state, parties, limit):
            passed[me] = 1

    state = wp.zeros(3, dtype=wp.uint32, device="cpu")
    passed = wp.zeros(2, dtype=wp.int32, device="cpu")
    wp.launch(meet, 1, [state, 2, passed, 0, wp.int64(100_000)], device="cpu")
    assert passed.numpy().tolist() == [0, 0] and state.numpy()[2] == 1
    state.zero_()
    patient = wp.int64(1 << 40)  # the partner's thread may start late on a busy machine
    other = threading.Thread(target=lambda: wp.launch(meet, 1, [state, 2, passed, 1, patient], device="cpu"))
    other.start()
    wp.launch(meet, 1, [state, 2, passed, 0, patient], device="cpu")
    other.join()
    assert passed.numpy().tolist() == [1, 1] and state.numpy().tolist() == [0, 1, 0]


def test_windows_that_give_up_leave_the_run_as_whole_chains_would(monkeypatch):
    """Windows whose partner is not running give up at once (here: no patience at all): each such launch runs again
    as whole chains from the same state, the dissipated energy restored, and windows are tried again later. The run
    is the per-step kernel's bit for bit."""
    from hertzian.core.solvers import chain as chain_module

    from tests.kernels.test_fused_features import assert_same_run, driven_scenes

    scenes = driven_scenes(traces=True, damping={"model": "contact", "gamma": 0.8}, integrator={"events": "off"})
    model = build_model(scenes, "cpu")
    want = Runner(model, kernel="step", use_graph=False).run()
    windowed_solver(model, monkeypatch, 2, 2)
    monkeypatch.setenv("HERTZIAN_CPU_THREADS", str(2 * model.chain_count))
    monkeypatch.setattr(chain_module, "BARRIER_SPIN_LIMIT", 0)
    attempts = []
    windowed = chain_module.ChainSolver._windowed
    monkeypatch.setattr(
        chain_module.ChainSolver, "_windowed", lambda self, *a: attempts.append(windowed(self, *a)) or attempts[-1]
    )
    runner = Runner(model, kernel="chain")
    assert len(runner.solver.windows) == 2 and runner.solver.patience == 0
    got = runner.run()
    assert_same_run(got, want)
    np.testing.assert_array_equal(got.dissipated, want.dissipated)
    assert attempts.count(False) >= 3 and len(attempts) < runner.solver.model.scenes[0].record_count
