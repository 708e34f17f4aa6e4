"""Laying out a fused launch: the plan of a launch (``TilePlan``, ``plan_tile``), the driver's slot, and the
shared-memory and register budgets it must fit."""

from dataclasses import dataclass, replace

from hertzian.kernels.features import Features
from hertzian.kernels.tile_layout import TileShape, edge_values


@dataclass(frozen=True)
class TilePlan:
    """A complete fused launch: compile-time shape plus the runtime window geometry."""

    shape: TileShape
    steps_per_launch: int
    """K: steps each launch takes (at most ``ghost`` when windowed)."""
    interior: int
    """Grains a block writes back per chain (the whole chain unless windowed)."""
    ghost: int
    blocks_per_chain: int
    block_count: int

    def describe(self) -> str:
        windows = f"windows={self.blocks_per_chain}x{self.interior}+2x{self.ghost}" if self.shape.windowed else ""
        return self.shape.describe(windows) + f" K={self.steps_per_launch}"


def plan_tile(
    features: Features,
    grain_count: int,
    chain_count: int,
    *,
    grains_per_lane: int = 8,
    lanes_per_chain: int | None = None,
    chains_per_block: int = 1,
    steps_per_launch: int = 64,
    windowed: bool = False,
    max_registers: int = 0,
    inline_event_step: bool = True,
    masked: bool | None = None,
) -> TilePlan:
    """Lay out a fused launch for ``chain_count`` chains of ``grain_count`` grains.

    Whole chains: ``lanes_per_chain = ceil(grain_count / grains_per_lane)`` unless given (it must cover
    the chain), ``chains_per_block`` chains per block. Windowed: ``lanes_per_chain`` lanes hold a window,
    its ghost zones are ``steps_per_launch`` grains (see hertzian.kernels.ghost). ``masked`` (whole chains):
    compile the padding masks whatever the fit (True), or only where lanes × G exceeds the chain or an end is free
    (None). Raises ValueError for shapes that cannot work (a block over 1024 threads, a window without interior).
    """
    from hertzian.kernels.ghost import plan_windows

    n = grain_count
    G = grains_per_lane
    ring = features.surface == "periodic"
    if windowed and features.substeps > 1:
        raise ValueError(
            f"method {features.method}: a composed step fuses in whole chains only (a window's ghost zone would have "
            "to cover every substep)"
        )
    free_end = features.surface not in ("wall", "periodic") or features.bottom == "free"
    if ring and (windowed or n % G or (lanes_per_chain or n // G) * G != n):
        raise ValueError(
            f"a ring fuses as whole chains in full lanes: {G} grains per lane do not fill {n} grains "
            f"{'in windows' if windowed else 'exactly'}"
        )
    if windowed:
        if lanes_per_chain is None:
            raise ValueError("a windowed plan needs lanes_per_chain")
        windows = plan_windows(n, lanes_per_chain * G, steps_per_launch)
        shape = TileShape(
            G,
            lanes_per_chain,
            1,
            windowed=True,
            masked=True,
            max_registers=max_registers,
            inline_event_step=inline_event_step,
        )
        plan = TilePlan(
            shape,
            steps_per_launch,
            windows.interior,
            windows.ghost,
            windows.blocks_per_chain,
            windows.blocks_per_chain * chain_count,
        )
    else:
        lanes = lanes_per_chain or -(-n // G)
        if lanes * G < n:
            raise ValueError(f"{lanes} lanes x {G} grains do not cover {n} grains")
        masked = masked or lanes * G != n or free_end
        shape = TileShape(
            G,
            lanes,
            chains_per_block,
            windowed=False,
            masked=masked,
            max_registers=max_registers,
            inline_event_step=inline_event_step,
        )
        plan = TilePlan(shape, steps_per_launch, n, 0, 1, -(-chain_count // chains_per_block))
    plan = with_driver_slot(plan, features)
    if plan.shape.block_dim > 1024:
        raise ValueError(f"block of {plan.shape.block_dim} threads: at most 1024")
    needed = shared_bytes(features, plan.shape)
    if needed > SHARED_BYTES:
        raise ValueError(
            f"block of {plan.shape.block_dim} lanes x {G} grains needs {needed} bytes of shared memory "
            f"(event steps keep the block's state there): at most {SHARED_BYTES}"
        )
    cap = launchable_register_cap(plan.shape.block_dim)
    if cap and (max_registers == 0 or max_registers > cap):
        plan = replace(plan, shape=replace(plan.shape, max_registers=cap))
    return plan


def lane_bucket(lanes: int, chains_per_block: int = 1) -> int:
    """``lanes`` rounded up to a multiple of 32 / ``chains_per_block``: a block then fills whole warps, so the
    padding lanes cost no warp, and every chain length whose lanes round alike shares one compiled shape."""
    step = max(1, 32 // chains_per_block)
    return -(-lanes // step) * step


def with_driver_slot(plan: TilePlan, features: Features) -> TilePlan:
    """``plan`` with ``shape.driver_slot`` set for its geometry: for a driven surface grain 0's position in its
    lane when every block that holds grain 0 has it at the same one (whole chains: lane 0's first grain; window p
    starts at grain p·interior − ghost), else -1 (found at run time); -1 for any other surface. Raises ValueError
    for a driven window plan where a block holds grain 0 as its lane's last grain (the driver's code needs grains 0
    and 1 in one lane)."""
    G = plan.shape.grains_per_lane
    slot = -1
    if features.surface == "driven":
        if not plan.shape.windowed:
            slot = 0
        else:
            span = plan.shape.lanes_per_chain * G
            slots = {
                (plan.ghost - p * plan.interior) % G
                for p in range(plan.blocks_per_chain)
                if p * plan.interior - plan.ghost <= 0 < p * plan.interior - plan.ghost + span
            }
            if G - 1 in slots:
                raise ValueError(
                    f"a driven windowed plan needs grains 0 and 1 in one lane (ghost {plan.ghost}, "
                    f"interior {plan.interior}: grain 0 is the last of a lane's {G})"
                )
            slot = slots.pop() if len(slots) == 1 else -1
    if plan.shape.driver_slot == slot:
        return plan
    return replace(plan, shape=replace(plan.shape, driver_slot=slot))


SHARED_BYTES = 227 * 1024
"""Shared memory one block may use on the GPUs this was measured on (sm_90: 227 KiB; Warp's CPU blocks: 256 KiB)."""


def shared_bytes(features: Features, shape: TileShape) -> int:
    """Bytes of shared memory a block of the fused kernel uses: the two edge tiles, the driver's powers, and with
    event-aware steps the block's state at t_n, one result per grain and the flags."""
    size = 8 if features.precision == "float64" else 4
    B, G, Q = shape.block_dim, shape.grains_per_lane, features.values
    events = features.event_window > 0
    total = 2 * B * edge_values(features) * size
    if features.surface == "driven":
        total += B * 8
    if events:
        total += 2 * B * G * Q * size + B * 4
    return total


REGISTER_FILE = 65536
"""32-bit registers per block on every CUDA GPU since compute capability 5.x (sm_90 included)."""
REGISTERS_PER_THREAD = 255
"""The most registers a CUDA thread can be given."""


def launchable_register_cap(block_dim: int) -> int:
    """A register cap that lets a block of ``block_dim`` threads launch whatever the features cost, or 0 when
    none is needed (even 255 registers per thread fit). Without it the compiler may give a heavy variant
    (a drive, response windows, event steps) more registers than a large block can hold, and the launch
    fails ("too many resources requested"); with it, the excess spills to local memory."""
    threads = -(-block_dim // 32) * 32
    if threads * REGISTERS_PER_THREAD <= REGISTER_FILE:
        return 0
    return REGISTER_FILE // threads // 8 * 8
