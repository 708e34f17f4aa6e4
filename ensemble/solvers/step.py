"""StepSolver: one Gear/Verlet step per launch over a (chain, grain) grid; every feature (kernels/step.py)."""

from __future__ import annotations

import warp as wp

from hertzian.kernels.step import step_kernel

from ..model import Model, State
from .base import Solver
from .config import STEP, SolverConfig


class StepSolver(Solver):
    """One launch per step. On the CPU the launches are recorded once per buffer pair and replayed;
    on CUDA, ``config.graph_steps`` steps are captured in one graph."""

    kind = "step"

    def __init__(self, model: Model, config: SolverConfig = STEP):
        super().__init__(model, config)
        self.kernel = step_kernel(model.features)
        self.commands: dict[tuple[int, int], object] = {}

    def _args(self, state_in: State, state_out: State):
        m = self.model
        inputs = [state_in.x, state_in.clock, m.inverse_mass, m.contact_constant, m.static_overlap, m.exponent,
                  m.drive, state_in.status, m.trace_slot, m.scenes[0].trace_stride, state_in.work, state_in.power,
                  m.dt]
        outputs = [state_out.x, state_out.clock, state_out.traces, state_out.work, state_out.power,
                   m.damping, state_in.dissipated]
        return inputs, outputs

    def launch(self, state_in: State, state_out: State, steps: int = 1) -> None:
        inputs, outputs = self._args(state_in, state_out)
        wp.launch(self.kernel, dim=(self.model.chain_count, self.model.grain_count), inputs=inputs,
                  outputs=outputs, device=self.model.device)

    def _command(self, state_in: State, state_out: State):
        key = (state_in.x.ptr, state_out.x.ptr)
        if key not in self.commands:
            inputs, outputs = self._args(state_in, state_out)
            self.commands[key] = wp.launch(self.kernel, dim=(self.model.chain_count, self.model.grain_count),
                                           inputs=inputs, outputs=outputs, device=self.model.device,
                                           record_cmd=True)
        return self.commands[key]

    def launches(self, state_in: State, state_out: State, n_steps: int) -> State:
        if self.use_graph:
            return super().launches(state_in, state_out, n_steps)
        forward, backward = self._command(state_in, state_out), self._command(state_out, state_in)
        for k in range(n_steps):
            (forward if k % 2 == 0 else backward).launch()
        return state_out if n_steps % 2 else state_in
