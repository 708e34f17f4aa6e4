"""Solvers: advance an ensemble's state, ``solver.advance(state_in, state_out, n_steps) -> State``.

``make_solver(model, config)`` builds the solver a :class:`SolverConfig` names; ``choose_config``
(``calibrate``) picks the config for a model (``--kernel``), timing and caching on GPUs.

========  =============================  ==================================================
kind      class (module)                 kernel
========  =============================  ==================================================
step      StepSolver (step.py)           kernels/step.py, one step per launch, every feature
tile      TileSolver (tile.py)           kernels/tile.py, whole chains per block, K steps
window    TileSolver (tile.py)           kernels/tile.py + ghost.py, windows with ghost zones
sweep     SweepSolver (sweep.py)         kernels/cpu.py, one CPU thread per chain
========  =============================  ==================================================
"""

from __future__ import annotations

from ..model import Model
from .base import Solver
from .calibrate import KERNELS, choose_config
from .config import GRAPH_STEPS, SOLVER_KINDS, STEP, SWEEP, SolverConfig
from .step import StepSolver
from .sweep import SweepSolver
from .tile import TileSolver, config_of, tile_plan

SOLVERS = {"step": StepSolver, "tile": TileSolver, "window": TileSolver, "sweep": SweepSolver}


def make_solver(model: Model, config: SolverConfig = STEP) -> Solver:
    """The solver of ``config.kind`` for ``model`` (compiles nothing until ``load`` or the first launch)."""
    return SOLVERS[config.kind](model, config)


__all__ = [
    "GRAPH_STEPS",
    "KERNELS",
    "SOLVERS",
    "SOLVER_KINDS",
    "STEP",
    "SWEEP",
    "Solver",
    "SolverConfig",
    "StepSolver",
    "SweepSolver",
    "TileSolver",
    "choose_config",
    "config_of",
    "make_solver",
    "tile_plan",
]
