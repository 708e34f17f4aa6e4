"""TileSolver: the fused kernels of kernels/tile.py, whole chains (``tile``) or windows (``window``) per block."""

from __future__ import annotations

import warp as wp
from hertzian.core.model import Model, State
from hertzian.core.solvers.base import Solver
from hertzian.core.solvers.config import FUSED_GRAPH_LAUNCHES, SolverConfig
from hertzian.kernels.ghost import plan_windows
from hertzian.kernels.tile import TilePlan, drive_table, launch_drive_table, launch_tile, tile_kernel, with_driver_slot

DRIVE_TABLE_BYTES = 32 * 2**20
"""Device memory a driven model's phase table may take (TileSolver): it covers a graph's launches where that fits,
else fewer (one launch at least)."""


def tile_plan(config: SolverConfig, grain_count: int, chain_count: int) -> TilePlan:
    """The runtime geometry of a tile/window config for a model of ``chain_count`` × ``grain_count``."""
    shape, k = config.shape, config.steps_per_launch
    if shape.windowed:
        w = plan_windows(grain_count, shape.window, k)
        return TilePlan(shape, k, w.interior, w.ghost, w.blocks_per_chain, w.blocks_per_chain * chain_count)
    if shape.window < grain_count:
        raise ValueError(
            f"{shape.lanes_per_chain} lanes x {shape.grains_per_lane} grains do not cover {grain_count} grains"
        )
    return TilePlan(shape, k, grain_count, 0, 1, -(-chain_count // shape.chains_per_block))


def solver_plan(config: SolverConfig, features, grain_count: int, chain_count: int) -> TilePlan:
    """The plan TileSolver compiles and launches for ``config``: ``tile_plan``'s geometry with the driver's slot
    set for it (whatever the config says, e.g. a cached calibration's)."""
    return with_driver_slot(tile_plan(config, grain_count, chain_count), features)


def config_of(plan: TilePlan) -> SolverConfig:
    """The SolverConfig of a hertzian.kernels.tile.TilePlan (e.g. from ``plan_tile``)."""
    return SolverConfig(
        "window" if plan.shape.windowed else "tile", shape=plan.shape, steps_per_launch=plan.steps_per_launch
    )


class TileSolver(Solver):
    """K steps per launch with chains (or windows of them) held on-chip; trace samples are written inside the
    launch."""

    def __init__(self, model: Model, config: SolverConfig):
        super().__init__(model, config)
        self.kind = config.kind
        self.plan = solver_plan(config, model.features, model.grain_count, model.chain_count)
        self.kernel = tile_kernel(self.kernel_features, self.plan.shape)
        self.trace_stride_in_kernel = model.scenes[0].trace_stride if model.features.traces else 1
        self.block_dim = config.shape.block_dim
        self.damped = model.features.damping != "none"
        self.phases = self.phase_first = self.driver_log = None
        self.table_steps = 0
        """Driven: the steps one fill of the phase table covers (a multiple of K)."""
        if model.features.surface == "driven":
            k = config.steps_per_launch
            piece = config.graph_steps or FUSED_GRAPH_LAUNCHES * k
            fits = DRIVE_TABLE_BYTES // (16 * model.chain_count) - 2
            self.table_steps = max(k, min(-(-piece // k) * k, fits // k * k))
            # rows for step0 … step0 + table_steps and the step after (loaded one step ahead: kernels/tile.py)
            self.phases = wp.empty((model.chain_count, self.table_steps + 2), dtype=wp.vec2d, device=model.device)
            self.phase_first = wp.zeros(1, dtype=wp.int32, device=model.device)
            # one row per chain, then one scratch row per block (kernels/tile.py: the log's store has no branch)
            self.driver_log = wp.empty(
                (model.chain_count + self.plan.block_count, k), dtype=wp.vec2d, device=model.device
            )

    def launches(self, state_in: State, state_out: State, n_steps: int) -> State:
        """Ping-pong launches; a driven model's phase table is filled first, and again every ``table_steps``."""
        if self.phases is None:
            return super().launches(state_in, state_out, n_steps)
        m = self.model
        a, b = state_in, state_out
        while n_steps > 0:
            steps = min(n_steps, self.table_steps)
            # only the rows these steps read (an advance between response samples may be a few steps)
            launch_drive_table(
                clock=a.clock,
                drive=m.drive,
                dt=m.dt,
                phases=self.phases,
                phase_first=self.phase_first,
                device=m.device,
                rows=steps + 2,
            )
            end = super().launches(a, b, steps)
            a, b = (end, b if end is a else a)
            n_steps -= steps
        return a

    def load(self) -> None:
        super().load()
        if self.phases is not None:
            wp.load_module(drive_table.module, device=self.model.device)

    def launch(self, state_in: State, state_out: State, steps: int) -> None:
        m = self.model
        launch_tile(
            self.plan,
            self.kernel,
            x_in=state_in.x,
            clock_in=state_in.clock,
            inverse_mass=m.inverse_mass,
            contact_constant=m.contact_constant,
            static_overlap=m.static_overlap,
            law_parameters=m.law_parameters,
            status=state_in.status,
            dt=m.dt,
            steps=steps,
            x_out=state_out.x,
            clock_out=state_out.clock,
            device=m.device,
            drive=m.drive,
            work_in=state_in.work,
            power_in=state_in.power,
            work_out=state_out.work,
            power_out=state_out.power,
            trace_slot=m.trace_slot,
            trace_stride=self.trace_stride_in_kernel,
            trace_x=state_in.traces,
            damping=m.damping if self.damped else None,
            dissipated=state_in.dissipated if self.damped else None,
            phases=self.phases,
            phase_first=self.phase_first,
            driver_log=self.driver_log,
        )

    def describe(self) -> str:
        return f"{self.kind} ({self.plan.describe()})"
