"""StepSolver: one Gear/Verlet step per launch over a (chain, grain) grid; every feature (kernels/step.py).

A composed method (yoshida4) takes its step as ``features.substeps`` launches, one per velocity-Verlet
substep, ping-ponging a → b → a → b: a step from ``state_in`` ends in ``state_out`` as for the other methods
(three is odd), with ``state_in`` used as scratch on the way. ``advance(n)`` is 3·n launches.
"""

from __future__ import annotations

import warp as wp
from hertzian.core.model import Model, State
from hertzian.core.solvers.base import Solver
from hertzian.core.solvers.config import STEP, SolverConfig
from hertzian.kernels.step import step_kernel


class StepSolver(Solver):
    """One launch per step (per substep for a composed method). On the CPU the launches are recorded once per
    buffer pair (and substep) and replayed; on CUDA, ``config.graph_steps`` steps are captured in one graph."""

    kind = "step"

    def __init__(self, model: Model, config: SolverConfig = STEP):
        super().__init__(model, config)
        self.kernel = step_kernel(model.features)
        self.commands: dict[tuple[int, int, int], object] = {}
        self.substeps = model.features.substeps

    def _args(self, state_in: State, state_out: State, substep: int = 0):
        m = self.model
        inputs = [
            state_in.x,
            state_in.clock,
            m.inverse_mass,
            m.contact_constant,
            m.static_overlap,
            m.law_parameters,
            m.drive,
            state_in.status,
            m.trace_slot,
            m.scenes[0].trace_stride,
            state_in.work,
            state_in.power,
            m.dt,
            substep,
        ]
        outputs = [
            state_out.x,
            state_out.clock,
            state_out.traces,
            state_out.work,
            state_out.power,
            m.damping,
            state_in.dissipated,
        ]
        return inputs, outputs

    def _pairs(self, state_in: State, state_out: State):
        """(source, destination, substep) of each launch of one step from ``state_in`` into ``state_out``."""
        pair = (state_in, state_out)
        return [(pair[k % 2], pair[1 - k % 2], k) for k in range(self.substeps)]

    def launch(self, state_in: State, state_out: State, steps: int = 1) -> None:
        for source, destination, substep in self._pairs(state_in, state_out):
            inputs, outputs = self._args(source, destination, substep)
            wp.launch(
                self.kernel,
                dim=(self.model.chain_count, self.model.grain_count),
                inputs=inputs,
                outputs=outputs,
                device=self.model.device,
            )

    def _command(self, state_in: State, state_out: State, substep: int = 0):
        key = (state_in.x.ptr, state_out.x.ptr, substep)
        if key not in self.commands:
            inputs, outputs = self._args(state_in, state_out, substep)
            self.commands[key] = wp.launch(
                self.kernel,
                dim=(self.model.chain_count, self.model.grain_count),
                inputs=inputs,
                outputs=outputs,
                device=self.model.device,
                record_cmd=True,
            )
        return self.commands[key]

    def launches(self, state_in: State, state_out: State, n_steps: int) -> State:
        if self.use_graph:
            return super().launches(state_in, state_out, n_steps)
        forward = [self._command(*launch) for launch in self._pairs(state_in, state_out)]
        backward = [self._command(*launch) for launch in self._pairs(state_out, state_in)]
        for k in range(n_steps):
            for command in forward if k % 2 == 0 else backward:
                command.launch()
        return state_out if n_steps % 2 else state_in
