"""SweepSolver: the chain-per-thread CPU sweep (kernels/cpu.py), every step of an advance in one launch."""

from __future__ import annotations

from hertzian.kernels.cpu import launch_sweep, sweep_kernel

from ..model import Model, State
from .base import Solver
from .config import SWEEP, SolverConfig


class SweepSolver(Solver):
    """One CPU thread per chain; traces are sampled between launches (base ``Solver.advance``)."""

    kind = "sweep"

    def __init__(self, model: Model, config: SolverConfig = SWEEP):
        super().__init__(model, config)
        self.kernel = sweep_kernel(self.kernel_features)

    def launch(self, state_in: State, state_out: State, steps: int) -> None:
        m = self.model
        launch_sweep(self.kernel, x_in=state_in.x, clock_in=state_in.clock, inverse_mass=m.inverse_mass,
                     contact_constant=m.contact_constant, static_overlap=m.static_overlap, exponent=m.exponent,
                     status=state_in.status, dt=m.dt, steps=steps, x_out=state_out.x, clock_out=state_out.clock,
                     device=m.device, drive=m.drive, work_in=state_in.work, power_in=state_in.power,
                     work_out=state_out.work, power_out=state_out.power, damping=m.damping,
                     dissipated=state_in.dissipated)
