"""The fused kernel's layout: which feature sets it runs (``fusable``), the launch shape (``TileShape``), the
compile-time constants every builder of kernels/tile.py reads (``TileLayout``), and the block-wide primitives."""

from dataclasses import dataclass
from typing import Any

import warp as wp
from hertzian.kernels.events import event_functions
from hertzian.kernels.features import SUBSTEP_WEIGHTS, Features
from hertzian.kernels.gear import nordsieck_functions, substep_weight_function
from hertzian.kernels.physics import (
    contact_forces,
    contact_functions,
    contact_parameters,
    damping_functions,
)


def fusable(features: Features) -> bool:
    """True when the fused kernels implement every feature of this set (traces: written inside the launch; the
    contact dashpot in compensated float32 is not implemented here: the per-step kernel runs it on CUDA). A ring, and
    a composed method (yoshida4, yoshida6: a step of several velocity-Verlet substeps), fuse in whole chains only
    (``plan_tile``)."""
    return not (features.damping == "contact" and features.compensation)


@dataclass(frozen=True)
class TileShape:
    """Compile-time launch shape of a fused kernel."""

    grains_per_lane: int
    """G: consecutive grains one thread holds in registers."""
    lanes_per_chain: int
    """Threads per chain (or per window of a long chain)."""
    chains_per_block: int = 1
    """Chains sharing one block (1 when windowed)."""
    windowed: bool = False
    """Long-chain mode: several blocks per chain, each a window with ghost zones (see hertzian.kernels.ghost)."""
    masked: bool = True
    """Compile the padding and free-end masks (off only when every lane is full and both ends are walls)."""
    max_registers: int = 0
    """CUDA register cap per thread (0: the compiler's choice); lower caps fit more blocks per SM."""
    inline_event_step: bool = True
    """Event-aware steps: the event step (written once, in the loop over rounds) inlined; False: an out-of-line
    function (CUDA ``__noinline__``). Same bits. With the event steps in shared memory and rounds, inlined compiles
    without spills at G = 4 where out of line spills (sm_90, ptxas)."""
    driver_slot: int = -1
    """A driven surface: grain 0's position among its lane's G grains when it is the same in every block that holds
    grain 0 (``plan_tile`` sets it), so the driver's code indexes a fixed register; -1: found at run time, by a
    select over the lane's G positions each time (the same bits, more instructions a step)."""

    @property
    def block_dim(self) -> int:
        return self.lanes_per_chain * self.chains_per_block

    def describe(self, windows: str = "") -> str:
        """Short text, e.g. 'G=8 lanes=125 regs<=168'; ``windows`` (the plan's window layout) goes after the
        chains per block."""
        text = f"G={self.grains_per_lane} lanes={self.lanes_per_chain}"
        if self.chains_per_block > 1:
            text += f" chains/block={self.chains_per_block}"
        if windows:
            text += f" {windows}"
        if self.max_registers:
            text += f" regs<={self.max_registers}"
        if not self.inline_event_step:
            text += " event-step=call"
        return text

    @property
    def window(self) -> int:
        """Grains one chain (or window) holds on-chip."""
        return self.lanes_per_chain * self.grains_per_lane


def out_of_line(event_step, values_t, vec3, real):
    """``event_step`` (kernels/events.py) behind a ``@wp.func`` the compiler keeps out of line."""

    @wp.func(inline=False)
    def event_step_call(
        own: values_t,
        above: values_t,
        below: values_t,
        has_above: bool,
        has_below: bool,
        p_above: vec3,
        p_below: vec3,
        inv_m: real,
        h: real,
    ) -> values_t:
        return event_step(own, above, below, has_above, has_below, p_above, p_below, inv_m, h)

    return event_step_call


@wp.func_native("""
#if defined(__CUDA_ARCH__)
return __syncthreads_or(flag);
#else
WP_TILE_SYNC();
return 1;
#endif
""")
def block_any(flag: int) -> int:
    """A barrier that returns nonzero if any thread of the block passed a nonzero ``flag`` (CUDA:
    __syncthreads_or). CPU blocks (tests) answer 1 after a plain barrier: every lane then takes the branch it
    guards, which must give the same bits as skipping it."""
    ...


@wp.func_native("WP_TILE_SYNC();")
def block_sync(unused: int):
    """A barrier for every thread of the block (CUDA: __syncthreads; CPU blocks: Warp's fiber barrier); it also
    makes the block's earlier writes to device memory visible to the whole block."""
    ...


@dataclass(frozen=True)
class TileLayout:
    """What the fused kernel's builders share for one feature set and launch shape (``tile_layout``): compile-time
    constants and register types, under the names the kernel code reads, and the device functions it calls from
    kernels/gear.py, kernels/physics.py and kernels/events.py."""

    shape: TileShape
    real: Any  # wp.float64 or wp.float32
    Q: int  # values per grain (Features.values)
    G: int  # grains per lane
    L: int  # lanes per chain (or window)
    CPB: int  # chains per block
    B: int  # threads per block
    BG: int  # grains a block holds
    G1: int  # contacts a lane sweeps (a name: Warp unrolls range() only over a literal or a constant's name)
    MAX_UNROLL: int  # every loop over a lane's grains or contacts unrolled (Warp's default limit is 16): a loop
    # left to run indexes the lane's register vectors at run time, which puts them in local memory
    WINDOWED: bool
    MASKED: bool
    TRACES: bool
    SURFACE_WALL: bool
    DRIVEN: bool
    DRIVER_SLOT: int  # TileShape.driver_slot when driven, else -1
    BOTTOM_WALL: bool
    FIXED: bool  # a held bottom grain
    FREE_END: bool  # a free end's missing contact is masked out of the forces
    RING: bool  # a ring: the first lane's upper neighbour is the last lane, whose lower one is the first
    COMPOSED: bool  # a step is SUBSTEPS velocity-Verlet substeps of w_j·dt (yoshida4, yoshida6)
    SUBSTEPS: int
    substep_weight: Any  # substep_weight(j) -> w_j (kernels/gear.py)
    HETERO: bool
    HERTZ: bool
    VISCOUS: bool
    DASHPOT: bool
    DISSIPATES: bool  # the dissipated energy is accumulated per grain
    ORDER: int  # rows of the Nordsieck vector (kernels/gear.py), as kernels/step.py counts them
    EVENTS: bool
    COMP: bool  # compensated float32: predicted positions also carry their low parts (kernels/gear.py)
    EDGE_LO: int  # where the edge tile keeps the low parts of the edge positions
    state_t: Any  # a lane's state: values × G
    grain_vec: Any
    contact_vec: Any
    edge_t: Any  # what a lane publishes to its neighbours each step (edge_values)
    vec2: Any
    vec3: Any
    one_vec: Any
    value_vec: Any  # one grain's values
    loss_vec: Any  # the lane's grains' dissipated energy (float64)
    params: Any
    shape_t: Any  # the contact law's per-chain shape: n (real), or a lattice law's vec2
    LATTICE: bool
    contact_force: Any
    forces: Any  # the lane's G + 1 contact forces
    one_force: Any  # one contact's force, with the lane's contact law
    nordsieck: Any
    dashpot: Any
    near_event: Any  # event-aware steps (None without them)
    event_step: Any
    lane_t: Any  # a lane's values fixed for the launch (lane_struct)
    arrays_t: Any  # the launch's arrays a step reads (arrays_struct)


def tile_layout(features: Features, shape: TileShape) -> TileLayout:
    """The fused kernel's constants, types and device functions for ``features`` and ``shape``; raises ValueError
    for a feature set the fused kernels do not implement (``fusable``)."""
    f = features
    if not fusable(f):
        raise ValueError(
            "fused kernels do not implement damping='contact' in compensated float32 (the per-step and CPU "
            "chain kernels do)"
        )
    real = wp.float64 if f.precision == "float64" else wp.float32
    G = shape.grains_per_lane
    DRIVEN = f.surface == "driven"
    EVENTS = f.event_window > 0
    contact_force, _ = contact_functions(f.precision, f.hertz, f.potential)
    LATTICE = f.potential != "hertz"
    nordsieck = nordsieck_functions(f.method, f.precision, f.compensation)
    vec3 = wp.types.vector(3, real)
    near_event = event_step = None
    if EVENTS:
        near_event, event_step = event_functions(f)
        if not shape.inline_event_step:
            event_step = out_of_line(event_step, nordsieck.values, vec3, real)
    return TileLayout(
        shape=shape,
        real=real,
        Q=f.values,
        G=G,
        L=shape.lanes_per_chain,
        CPB=shape.chains_per_block,
        B=shape.block_dim,
        BG=shape.block_dim * G,
        G1=G + 1,
        MAX_UNROLL=max(16, G + 1),
        WINDOWED=shape.windowed,
        MASKED=shape.masked,
        TRACES=f.traces,
        SURFACE_WALL=f.surface == "wall",
        DRIVEN=DRIVEN,
        DRIVER_SLOT=shape.driver_slot if DRIVEN else -1,
        BOTTOM_WALL=f.bottom == "wall",
        FIXED=f.bottom == "fixed",
        # a driven surface is no free end: the contact above the driven grain 0 acts on grain 0, whose corrected
        # column no output reads (driver_values), and on padding (1/m = 0)
        FREE_END=(f.surface not in ("wall", "periodic") and not DRIVEN) or f.bottom == "free",
        RING=f.surface == "periodic",
        COMPOSED=f.method in SUBSTEP_WEIGHTS,
        SUBSTEPS=f.substeps,
        substep_weight=substep_weight_function(f.method, f.precision),
        HETERO=f.heterogeneous,
        HERTZ=f.hertz,
        VISCOUS=f.damping == "viscous",
        DASHPOT=f.damping == "contact",
        DISSIPATES=f.damping in ("viscous", "contact"),
        ORDER=f.nordsieck_values,
        EVENTS=EVENTS,
        COMP=f.compensation,
        EDGE_LO=6 if EVENTS else 2,
        state_t=wp.types.matrix(shape=(f.values, G), dtype=real),
        grain_vec=wp.types.vector(length=G, dtype=real),
        contact_vec=wp.types.vector(length=G + 1, dtype=real),
        edge_t=wp.types.vector(length=edge_values(f), dtype=real),
        vec2=wp.types.vector(2, real),
        vec3=vec3,
        one_vec=wp.types.vector(length=1, dtype=real),
        value_vec=nordsieck.values,
        loss_vec=wp.types.vector(length=G, dtype=wp.float64),
        params=contact_parameters(f.precision, f.static, f.heterogeneous, f.hertz, f.potential),
        shape_t=wp.types.vector(2, real) if LATTICE else real,
        LATTICE=LATTICE,
        contact_force=contact_force,
        forces=contact_forces(f.precision, f.hertz, G + 1, f.potential),
        one_force=contact_forces(f.precision, f.hertz, 1, f.potential),
        nordsieck=nordsieck,
        dashpot=damping_functions(f.precision, f.nordsieck_values)[1],
        near_event=near_event,
        event_step=event_step,
        lane_t=lane_struct(real, G, wp.types.vector(2, real) if LATTICE else real),
        arrays_t=arrays_struct(real),
    )


def lane_struct(real, G: int, shape_t):
    """The ``@wp.struct`` of a lane's values that stay fixed through a launch: where its grains are, its contacts'
    constants, the driver's amplitude and frequency, the step's size and the damping rate."""

    @wp.struct
    class Lane:
        lane: int  # the thread's index in its block
        lane_c: int  # ... among its chain's (or window's) lanes
        segment: int  # the block's chain this lane works on (chains per block > 1)
        first: int  # the window's first grain (0 for whole chains)
        base: int  # the lane's first grain
        cc: int  # the chain (clamped to the launch's chains)
        n_grains: int
        keep_lo: int  # the interior written back: [keep_lo, keep_hi)
        keep_hi: int
        live: wp.bool  # the lane holds grains of a chain of the launch
        frozen: wp.bool  # the chain is NON_FINITE: it keeps its state
        has_left: wp.bool  # a lane above in the chain (or window)
        has_right: wp.bool  # ... below
        delta0: wp.types.vector(length=G + 1, dtype=real)  # the lane's contacts' static overlaps
        a_c: wp.types.vector(length=G + 1, dtype=real)  # ... their constants
        force0: wp.types.vector(length=G + 1, dtype=real)  # ... their static forces
        n: shape_t  # the contact law's per-chain shape
        inv_m: wp.types.vector(length=G, dtype=real)  # the lane's grains' 1/m (0 for padding)
        contact_bits: int  # bit k: contact k of the lane exists
        move_bits: int  # bit k: grain k of the lane is integrated
        h: real  # dt in the state's precision
        hh: real  # h²/2
        gamma: real  # viscous damping rate
        k0: int  # grain 0's index in this lane (a driven surface), else -1
        log_row: int  # the driver log's row this lane writes
        step0: int  # the clock at the launch's start
        trace_stride: int
        dt: wp.float64
        amplitude: wp.float64  # the driver's amplitude and angular frequency
        omega: wp.float64

    return Lane


def arrays_struct(real):
    """The ``@wp.struct`` of the launch's arrays that a step reads: the contacts' parameters, the masses, the state
    at the launch's start, the driver's log and the traces."""

    @wp.struct
    class Arrays:
        static_overlap: wp.array2d(dtype=real)
        contact_constant: wp.array2d(dtype=real)
        law_parameters: wp.array(dtype=real)
        inverse_mass: wp.array2d(dtype=real)
        x_in: wp.array3d(dtype=real)
        driver_log: wp.array2d(dtype=wp.vec2d)
        trace_slot: wp.array(dtype=wp.int32)
        trace_x: wp.array4d(dtype=real)

    return Arrays


def edge_values(features: Features) -> int:
    """Values a lane publishes to its neighbours each step: its edge grains' predicted positions (2), with event-aware
    steps also their (u, dt·v) at t_n (4 more), with compensated float32 the positions' low parts (2 more); with the
    contact dashpot the predicted rates and the first grain's (u, dt·v) at t_n (6 in all)."""
    if features.damping == "contact":
        return 6
    return (6 if features.event_window > 0 else 2) + (2 if features.compensation else 0)
