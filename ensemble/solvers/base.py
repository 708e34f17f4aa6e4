"""The solver protocol: ``advance(state_in, state_out, n_steps) -> State``.

A solver holds the model it integrates, its frozen :class:`SolverConfig`, its compiled kernel and
its captured graphs; it never owns a State. ``advance`` takes ``n_steps`` steps from ``state_in``,
ping-ponging between the two halves (a launch never reads and writes one buffer), and returns the
half that now holds step t + n (either one, depending on the launch count). It allocates nothing
and never synchronises with the host.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import warp as wp

from hertzian.kernels.features import Features
from hertzian.kernels.traces import trace_sample_kernel

from ..model import Model, State
from .config import SolverConfig
from .graphs import GraphCache


class Solver:
    """Base of every solver kind: ping-pong launches, optional CUDA graphs, ``load``, ``describe``."""

    kind = "base"
    traces_in_kernel = False
    """Whether the kind's kernel writes trace samples itself (per-step; the CPU sweep)."""

    def __init__(self, model: Model, config: SolverConfig):
        self.model = model
        self.config = config
        self.kernel = None
        self.block_dim: int | None = None
        self.use_graph = model.device.is_cuda if config.use_graph is None else config.use_graph
        self.graphs = GraphCache(model.device)
        self.samples_traces = model.features.traces and config.kind != "step" and not self.traces_in_kernel
        """Fused kinds whose kernel has no trace sampler (tile, window) take traces outside it: pieces end on
        trace steps, then ``sample_traces``."""
        self.trace_stride = model.scenes[0].trace_stride if self.samples_traces else 0
        self.traced_grain = (wp.array(np.asarray(model.scenes[0].record.traces, dtype=np.int32), dtype=wp.int32,
                                      device=model.device) if self.samples_traces else None)
        self.sample_kernel = trace_sample_kernel(model.features.precision) if self.samples_traces else None

    @property
    def kernel_features(self) -> Features:
        """The features the stepping kernel is compiled for (a fused kind leaves traces to ``sample_traces``)."""
        f = self.model.features
        return replace(f, traces=False) if self.samples_traces else f

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

    def advance(self, state_in: State, state_out: State, n_steps: int, *, first_step: int | None = None) -> State:
        """Take ``n_steps`` steps from ``state_in`` (``state_out`` is scratch); returns the half now current.

        ``first_step``: the step ``state_in`` holds. Fused kinds with traces need it to cut the advance
        at trace steps; when it is None they read the clock back (a host synchronisation).
        """
        if n_steps <= 0:
            return state_in
        if not self.samples_traces:
            return self._advance(state_in, state_out, n_steps)
        step = int(state_in.clock.numpy()[0]) if first_step is None else int(first_step)
        stride, end = self.trace_stride, step + n_steps
        a, b = state_in, state_out
        while step < end:
            piece_end = min(end, (step // stride + 1) * stride)
            current = self._advance(a, b, piece_end - step)
            a, b = (current, b if current is a else a)
            if piece_end % stride == 0:
                self.sample_traces(a)
            step = piece_end
        return a

    def sample_traces(self, state: State) -> None:
        """Copy the traced grains of ``state`` (at a trace step) into the trace ring (device only)."""
        wp.launch(self.sample_kernel, dim=(self.model.chain_count, self.traced_grain.shape[0]),
                  inputs=[state.x, state.clock, self.traced_grain, self.trace_stride], outputs=[state.traces],
                  device=self.model.device)

    def _advance(self, state_in: State, state_out: State, n_steps: int) -> State:
        """``advance`` without trace sampling: launches, or captured graphs of them on CUDA."""
        if not self.use_graph:
            return self.launches(state_in, state_out, n_steps)
        piece = self.config.graph_steps or n_steps
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
        if self.sample_kernel is not None:
            wp.load_module(self.sample_kernel.module, device=self.model.device)

    def describe(self) -> str:
        return self.config.describe()
