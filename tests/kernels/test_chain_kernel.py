"""The CPU chain kernel (kernels/cpu.py) against the per-step kernel, and the runner's kernel choice.

The sweep integrates a chain in place with its neighbours in registers; it performs the per-step
kernel's operations in the same order, so on the CPU the states must agree bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest
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
