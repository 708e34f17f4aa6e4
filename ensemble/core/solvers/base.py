"""The solver protocol: ``advance(state_in, state_out, n_steps) -> State``.

A solver holds the model it integrates, its frozen :class:`SolverConfig`, its compiled kernel and
its captured graphs; it never owns a State. ``advance`` takes ``n_steps`` steps from ``state_in``,
ping-ponging between the two halves (a launch never reads and writes one buffer), and returns the
half that now holds step t + n (either one, depending on the launch count). It allocates nothing
and never synchronises with the host.
"""

from __future__ import annotations

import warp as wp
from hertzian.core.model import Model, State
from hertzian.core.solvers.config import FUSED_GRAPH_LAUNCHES, SolverConfig
from hertzian.core.solvers.graphs import GraphCache
from hertzian.kernels.features import Features


class Solver:
    """Base of every solver kind: ping-pong launches, optional CUDA graphs, ``load``, ``describe``."""

    kind = "base"

    def __init__(self, model: Model, config: SolverConfig):
        self.model = model
        self.config = config
        self.kernel = None
        self.block_dim: int | None = None
        self.use_graph = model.device.is_cuda if config.use_graph is None else config.use_graph
        self.graphs = GraphCache(model.device)

    @property
    def kernel_features(self) -> Features:
        """The features the stepping kernel is compiled for (every kind writes its own trace samples)."""
        return self.model.features

    @property
    def steps_per_launch(self) -> int:
        return self.config.steps_per_launch

    def launch(self, state_in: State, state_out: State, steps: int) -> None:
        """One kernel launch taking ``steps`` ≤ steps_per_launch steps from ``state_in`` into ``state_out``."""
        raise NotImplementedError

    def launches(self, state_in: State, state_out: State, n_steps: int) -> State:
        """Ping-pong launches covering ``n_steps``; returns the half holding the result."""
        a, b = state_in, state_out
        while n_steps > 0:
            steps = min(n_steps, self.steps_per_launch)
            self.launch(a, b, steps)
            a, b = b, a
            n_steps -= steps
        return a

    def launch_count(self, n_steps: int) -> int:
        return -(-n_steps // self.steps_per_launch)

    def advance(self, state_in: State, state_out: State, n_steps: int) -> State:
        """Take ``n_steps`` steps from ``state_in`` (``state_out`` is scratch); returns the half now current.
        Trace samples are written by the kernels themselves, so an advance is never cut at trace steps."""
        if n_steps <= 0:
            return state_in
        return self._advance(state_in, state_out, n_steps)

    def _advance(self, state_in: State, state_out: State, n_steps: int) -> State:
        """Launches, or captured graphs of them on CUDA."""
        if not self.use_graph:
            return self.launches(state_in, state_out, n_steps)
        piece = self.config.graph_steps or FUSED_GRAPH_LAUNCHES * self.steps_per_launch
        a, b = state_in, state_out
        while n_steps > 0:
            steps = min(n_steps, piece)
            end = self.graphs.run(self.launches, a, b, steps)
            a, b = (end, b if end is a else a)
            n_steps -= steps
        return a

    def load(self) -> None:
        """Compile and load the kernel for its launch's block size (before any graph capture)."""
        if self.model.device.is_cpu and (self.block_dim or 1) > 1:
            wp.config.enable_cpu_blocks = True  # Warp 1.19 runs CPU blocks as fibers only when asked
        wp.load_module(self.kernel.module, device=self.model.device, block_dim=self.block_dim)

    def describe(self) -> str:
        return self.config.describe()
