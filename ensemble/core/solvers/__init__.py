"""Solvers: advance an ensemble's state, ``solver.advance(state_in, state_out, n_steps) -> State``.

``make_solver(model, config)`` builds the solver a :class:`SolverConfig` names; ``choose_config``
(``calibrate``) picks the config for a model (``--kernel``) without timing; ``calibrate.tune`` times shapes (``hertzian tune``).

========  =============================  ==================================================
kind      class (module)                 kernel
========  =============================  ==================================================
step      StepSolver (step.py)           kernels/step.py, one step per launch, every feature
tile      TileSolver (tile.py)           kernels/tile.py, whole chains per block, K steps
window    TileSolver (tile.py)           kernels/tile.py + ghost.py, windows with ghost zones
chain     ChainSolver (chain.py)         kernels/cpu.py, one CPU thread per chain
========  =============================  ==================================================
"""

from __future__ import annotations

from hertzian.core.model import Model
from hertzian.core.solvers.base import Solver
from hertzian.core.solvers.calibrate import KERNELS, choose_config
from hertzian.core.solvers.chain import ChainSolver
from hertzian.core.solvers.config import CHAIN, GRAPH_STEPS, SOLVER_KINDS, STEP, SolverConfig
from hertzian.core.solvers.step import StepSolver
from hertzian.core.solvers.tile import TileSolver, config_of, tile_plan

SOLVERS = {"step": StepSolver, "tile": TileSolver, "window": TileSolver, "chain": ChainSolver}


def make_solver(model: Model, config: SolverConfig = STEP) -> Solver:
    """The solver of ``config.kind`` for ``model`` (compiles nothing until ``load`` or the first launch)."""
    return SOLVERS[config.kind](model, config)


__all__ = [
    "GRAPH_STEPS",
    "KERNELS",
    "SOLVERS",
    "SOLVER_KINDS",
    "STEP",
    "CHAIN",
    "Solver",
    "SolverConfig",
    "StepSolver",
    "ChainSolver",
    "TileSolver",
    "choose_config",
    "config_of",
    "make_solver",
    "tile_plan",
]
