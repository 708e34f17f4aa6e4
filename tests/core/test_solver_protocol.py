"""The solver protocol (ensemble/core/solvers): ``advance(state_in, state_out, n) -> State`` for every kind.

Pieces of an advance must compose (n = a + b gives the same bits as a then b, whichever half each
piece ends in), the shared status must freeze a chain on both halves, and configs are validated.
"""

from __future__ import annotations

import numpy as np
import pytest
from hertzian.core.model import build_model
from hertzian.core.solvers import CHAIN, STEP, SolverConfig, config_of, make_solver
from hertzian.kernels.features import STATUS_NON_FINITE
from hertzian.kernels.tile import plan_tile

from tests.helpers import chains


def configs(model):
    f, n, c = model.features, model.grain_count, model.chain_count
    return {
        "step": STEP,
        "chain": SolverConfig("chain", steps_per_launch=5),
        "tile": config_of(plan_tile(f, n, c, grains_per_lane=4, steps_per_launch=4)),
        "window": config_of(
            plan_tile(f, n, c, grains_per_lane=4, lanes_per_chain=6, steps_per_launch=3, windowed=True)
        ),
    }


@pytest.mark.parametrize("kind", ["step", "chain", "tile", "window"])
def test_advance_in_pieces_equals_one_advance(kind):
    model = build_model(chains(2, chain={"grains": 30, "l0": 1e-4}, integrator={"dt": 5e-4}), "cpu")
    solver = make_solver(model, configs(model)[kind])
    solver.load()
    a, b = model.state_pair()
    assert a.status.ptr == b.status.ptr and a.traces.ptr == b.traces.ptr  # one status, one trace ring
    assert solver.advance(a, b, 0) is a
    whole = solver.advance(a, b, 23)
    assert whole.clock.numpy()[0] == 23
    want = whole.x.numpy().copy()
    assert np.max(np.abs(want - model.initial_state().x.numpy())) > 0  # it moved
    pair = model.state_pair()
    current = pair[0]
    for piece in (7, 1, 10, 5):  # odd and even pieces: the result lands in either half
        current = solver.advance(current, pair[1] if current is pair[0] else pair[0], piece)
    assert current.clock.numpy()[0] == 23
    np.testing.assert_array_equal(current.x.numpy(), want)


@pytest.mark.parametrize("kind", ["step", "chain", "tile"])
def test_status_is_shared_by_both_halves(kind):
    """A chain flagged non-finite stays frozen over many launches, whichever half is read."""
    model = build_model(chains(3, chain={"grains": 16, "l0": 1e-4}, integrator={"dt": 5e-4}), "cpu")
    solver = make_solver(model, configs(model)[kind])
    solver.load()
    a, b = model.state_pair()
    a.status.assign(np.array([0, STATUS_NON_FINITE, 0], dtype=np.int32))
    start = a.x.numpy().copy()
    end = solver.advance(a, b, 9)
    got = end.x.numpy()
    np.testing.assert_array_equal(got[:, 1], start[:, 1])
    assert np.max(np.abs(got[:, 0] - start[:, 0])) > 0


def test_config_is_validated():
    with pytest.raises(ValueError, match="solver kind"):
        SolverConfig("fastest")
    with pytest.raises(ValueError, match="launch shape"):
        SolverConfig("tile")
    with pytest.raises(ValueError, match="steps_per_launch"):
        SolverConfig("chain", steps_per_launch=0)
    assert SolverConfig.from_dict(CHAIN.to_dict()) == CHAIN
    model = build_model(chains(1, chain={"grains": 30}), "cpu")
    window = configs(model)["window"]
    assert SolverConfig.from_dict(window.to_dict()) == window


def test_a_long_fused_advance_replays_graphs_of_a_fixed_length():
    """On CUDA the tile/window solvers capture FUSED_GRAPH_LAUNCHES launches per graph and replay it: a long
    advance (10⁵ launches) is not one graph of every launch, which costs seconds to capture and instantiate."""
    from types import SimpleNamespace

    from hertzian.core.solvers.base import Solver
    from hertzian.core.solvers.config import FUSED_GRAPH_LAUNCHES

    lengths = []
    graphs = SimpleNamespace(run=lambda launches, a, b, n: lengths.append(n) or b)
    fused = SimpleNamespace(
        use_graph=True, config=SimpleNamespace(graph_steps=None), steps_per_launch=32, launches=None, graphs=graphs
    )
    a, b = object(), object()
    Solver._advance(fused, a, b, 32 * 100_000 + 5)
    piece = 32 * FUSED_GRAPH_LAUNCHES
    assert lengths == [piece] * ((32 * 100_000 + 5) // piece) + [(32 * 100_000 + 5) % piece]
    lengths.clear()
    per_step = SimpleNamespace(
        use_graph=True, config=SimpleNamespace(graph_steps=512), steps_per_launch=1, launches=None, graphs=graphs
    )
    Solver._advance(per_step, a, b, 2000)
    assert lengths == [512, 512, 512, 464]


def test_fused_choice_is_auto_without_the_short_run_rule(monkeypatch):
    from hertzian.core.solvers import calibrate, choose_config

    model = build_model(chains(2, chain={"grains": 30, "l0": 1e-4}, integrator={"dt": 5e-4}), "cpu")
    monkeypatch.setattr(calibrate, "in_kernel_cache", lambda module, device: False)  # a cold kernel cache
    assert choose_config(model, "auto", run_steps=100) == STEP  # too short to repay a compile
    assert choose_config(model, "fused", run_steps=100) == CHAIN
    assert choose_config(model, "auto", run_steps=10**9) == CHAIN
    damped = build_model(
        chains(
            2, chain={"grains": 30, "l0": 1e-4}, integrator={"dt": 5e-4}, damping={"model": "viscous", "gamma": 0.1}
        ),
        "cpu",
    )
    assert choose_config(damped, "fused", run_steps=100).kind in ("chain", "step")
