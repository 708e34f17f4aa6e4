"""TileSolver: the fused kernels of kernels/tile.py, whole chains (``tile``) or windows (``window``) per block."""

from __future__ import annotations

from hertzian.kernels.ghost import plan_windows
from hertzian.kernels.tile import TilePlan, launch_tile, tile_kernel

from ..model import Model, State
from .base import Solver
from .config import SolverConfig


def tile_plan(config: SolverConfig, grain_count: int, chain_count: int) -> TilePlan:
    """The runtime geometry of a tile/window config for a model of ``chain_count`` × ``grain_count``."""
    shape, k = config.shape, config.steps_per_launch
    if shape.windowed:
        w = plan_windows(grain_count, shape.window, k)
        return TilePlan(shape, k, w.interior, w.ghost, w.blocks_per_chain, w.blocks_per_chain * chain_count)
    if shape.window < grain_count:
        raise ValueError(f"{shape.lanes_per_chain} lanes x {shape.grains_per_lane} grains do not cover "
                         f"{grain_count} grains")
    return TilePlan(shape, k, grain_count, 0, 1, -(-chain_count // shape.chains_per_block))


def config_of(plan: TilePlan) -> SolverConfig:
    """The SolverConfig of a hertzian.kernels.tile.TilePlan (e.g. from ``plan_tile``)."""
    return SolverConfig("window" if plan.shape.windowed else "tile", shape=plan.shape,
                        steps_per_launch=plan.steps_per_launch)


class TileSolver(Solver):
    """K steps per launch with chains (or windows of them) held on-chip; trace samples are written inside the
    launch."""

    def __init__(self, model: Model, config: SolverConfig):
        super().__init__(model, config)
        self.kind = config.kind
        self.plan = tile_plan(config, model.grain_count, model.chain_count)
        self.kernel = tile_kernel(self.kernel_features, config.shape)
        self.trace_stride_in_kernel = model.scenes[0].trace_stride if model.features.traces else 1
        self.block_dim = config.shape.block_dim
        self.damped = model.features.damping != "none"

    def launch(self, state_in: State, state_out: State, steps: int) -> None:
        m = self.model
        launch_tile(self.plan, self.kernel, x_in=state_in.x, clock_in=state_in.clock, inverse_mass=m.inverse_mass,
                    contact_constant=m.contact_constant, static_overlap=m.static_overlap, exponent=m.exponent,
                    status=state_in.status, dt=m.dt, steps=steps, x_out=state_out.x, clock_out=state_out.clock,
                    device=m.device, drive=m.drive, work_in=state_in.work, power_in=state_in.power,
                    work_out=state_out.work, power_out=state_out.power, trace_slot=m.trace_slot,
                    trace_stride=self.trace_stride_in_kernel, trace_x=state_in.traces,
                    damping=m.damping if self.damped else None, dissipated=state_in.dissipated if self.damped else None)

    def describe(self) -> str:
        return f"{self.kind} ({self.plan.describe()})"
