"""Fused window kernels: many steps per launch with each chain (or a window of it) on-chip.

A block of ``lanes_per_chain × chains_per_block`` threads holds whole chains (or, for long chains,
*windows* of them) in registers: lane ``l`` of a chain keeps the Nordsieck values of ``G`` consecutive
grains ``base … base + G − 1`` as one small matrix (values × G). One step is

1. predict every grain of the lane (registers only);
2. publish the lane's first and last predicted position to a shared tile (one barrier); read the
   neighbour lanes' edge positions from it (double-buffered by step parity, so one barrier a step);
3. sweep the lane's G + 1 contacts once each (the edge contacts are also computed by the
   neighbour lane: (G + 1)/G contact evaluations per grain), correct each grain.

The predictor/corrector (kernels/gear.py) and the contact law (kernels/physics.py) are the per-step
kernel's own functions; only the loops around them differ, so on
the same device the results agree to the last bit wherever the compiler contracts alike.

Grains outside the chain (padding of the last lane, or of a window past an end) hold value 0 and are
never moved, so a padding grain next to a wall *is* the wall (docs/model.md §1: a wall is a grain at rest at
its static position). Free ends mask the one contact they lack.

Long chains (more grains than a block holds) are cut into windows of ``interior`` grains plus
``ghost`` grains of each neighbour on both sides. Information moves one grain per step, so after
``steps ≤ ghost`` steps a window's interior is exact; only the interior is written back. Windows read
``x_in`` and write ``x_out`` (never the same buffer), so no window sees another's partial update.

Event-aware steps (kernels/events.py, ``Features.event_window > 0``): before the corrector each of a lane's G + 1
contacts is tested once, without a branch, into one bit per flagged grain, and the block votes (one
``__syncthreads_or``) whether any grain is flagged. Most steps none is, and the block goes on to its corrector. When
one is, every lane publishes its state at t_n to shared memory and the chain's flagged grains are stepped by its lanes
in rounds (lane j takes the chain's grain j + m·L in round m, so neighbouring flagged grains, which sit in one lane, go
to neighbouring lanes); each event step reads its neighbours at t_n from shared memory, as the per-step kernel does,
and its result goes to the grain's slot of a shared tile, from which the owning lane takes it after its corrector.
The event step is written once (inlined by default, ``TileShape.inline_event_step``); on the CPU every lane takes the
event branch each step (same bits).

A driven surface (``surface = "driven"``), in kernels/step.py's arithmetic (grain 1 must sit in grain 0's lane):
the lane holding grain 0 takes the driver's u_0(t_{n+1}) as that grain's predicted position, by a select in every
lane (no branch: its reconvergence slowed every block each step). The driver's sin ωt and cos ωt come from a
table in device memory that ``drive_table`` fills before the launches (with the per-step kernel's argument
ω·(n·dt), so the same bits); every lane loads the next step's row one step ahead (one address per chain: a
broadcast). Each step logs what the driver's power needs (grain 0's overlap change); after the step loop the
block's lanes evaluate one step's power each and the driver's lane sums the work in step order, so no contact
force of the driver's lies on a step's critical path. The driver's own register column is never overwritten:
traces and the write-back take its values from the phases.
Traces are written inside the launch after each step k·stride, from the lanes that keep the traced grains
(a window's interior), as the per-step kernel writes them, by an out-of-line function called only when a sample is
due (its code in the step loop slowed every step).

Damping, in the per-step kernel's arithmetic. Viscous (``damping = "viscous"``: force −γ m v on every integrated
grain) adds kernels/step.py's −h²/2·γ·(dt·v predicted) to each corrector. The contact dashpot (``"contact"``) adds
each contact's γ·δ̇ at the predicted t_{n+1} to its Hertz force; its lanes also exchange their edge grains' predicted
rates and the first grain's (u, dt·v) at t_n, and the driver's work includes its contact's dashpot. Each grain's
dissipated energy (the trapezoid of the loss power at t_n and at the predicted t_{n+1}) is accumulated in registers
from the stored value and written back for the interior once per launch. Not here: the dashpot in compensated
float32.
"""

import functools
from dataclasses import dataclass, replace
from typing import Any

import warp as wp
from hertzian.kernels.events import event_functions
from hertzian.kernels.features import KERNEL_OPTIONS, STATUS_NON_FINITE, SUBSTEP_WEIGHTS, Features
from hertzian.kernels.gear import nordsieck_functions
from hertzian.kernels.physics import (
    contact_forces,
    contact_functions,
    contact_parameters,
    damping_functions,
    product_rn,
)


def fusable(features: Features) -> bool:
    """True when the fused kernels implement every feature of this set (traces: written inside the launch;
    composed methods such as yoshida4, and the contact dashpot in compensated float32, are not implemented here:
    the per-step kernel runs them on CUDA)."""
    if features.damping == "contact" and features.compensation:
        return False
    return features.method not in SUBSTEP_WEIGHTS


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
    contact_force: Any
    forces: Any  # the lane's G + 1 contact forces
    one_force: Any  # one contact's force, with the lane's contact law
    nordsieck: Any
    dashpot: Any
    near_event: Any  # event-aware steps (None without them)
    event_step: Any


def tile_layout(features: Features, shape: TileShape) -> TileLayout:
    """The fused kernel's constants, types and device functions for ``features`` and ``shape``; raises ValueError
    for a feature set the fused kernels do not implement (``fusable``)."""
    f = features
    if f.damping == "contact" and f.compensation:
        raise ValueError(
            "fused kernels do not implement damping='contact' in compensated float32 (the per-step and CPU "
            "chain kernels do)"
        )
    if not fusable(f):
        raise ValueError(f"fused kernels do not implement method={f.method!r}")
    real = wp.float64 if f.precision == "float64" else wp.float32
    G = shape.grains_per_lane
    DRIVEN = f.surface == "driven"
    EVENTS = f.event_window > 0
    contact_force, _ = contact_functions(f.precision, f.hertz)
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
        FREE_END=(f.surface != "wall" and not DRIVEN) or f.bottom == "free",
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
        params=contact_parameters(f.precision, f.static, f.heterogeneous, f.hertz),
        contact_force=contact_force,
        forces=contact_forces(f.precision, f.hertz, G + 1),
        one_force=contact_forces(f.precision, f.hertz, 1),
        nordsieck=nordsieck,
        dashpot=damping_functions(f.precision, f.nordsieck_values)[1],
        near_event=near_event,
        event_step=event_step,
    )


@functools.cache
def tile_kernel(features: Features, shape: TileShape):
    """The fused kernel for one feature set and compile-time launch shape (cached), built from per-concern builders;
    raises ValueError for a feature set the fused kernels do not implement."""
    t = tile_layout(features, shape)
    predicted_rate, column, shared_column, at_driver = register_functions(t)
    driver_log_entry, driver_power, work_step, driver_values = driver_functions(t)
    dissipation, lane_rates, dashpot_forces, dashpot_losses = loss_functions(t, predicted_rate, column, at_driver)
    shared_event_steps = event_steps_function(t, shared_column)
    advance = advance_function(t, predicted_rate, column, at_driver, lane_rates, dashpot_forces, shared_event_steps)
    fused_step = step_function(
        t,
        advance=advance,
        dissipation=dissipation,
        dashpot_losses=dashpot_losses,
        write_traces=trace_function(t, driver_values),
        driver_log_entry=driver_log_entry,
    )
    return fused_kernel(t, fused_step, driver_power, work_step, driver_values)


def register_functions(t: TileLayout):
    """A lane's register helpers: a grain's predicted dt·v, a grain's column of the lane's state (registers, or the
    block's shared tile of states), and whether grain k of the lane is the driven grain 0."""
    Q, real, ORDER, DRIVER_SLOT, state_t, value_vec = t.Q, t.real, t.ORDER, t.DRIVER_SLOT, t.state_t, t.value_vec

    @wp.func
    def predicted_rate(v: value_vec) -> real:
        # kernels/physics.py damping_functions' predicted_rate on a register column: dt·v at t_n+1, Σ_q q·x_q
        rate = v[1] + real(2) * v[2]
        if wp.static(ORDER >= 4):
            rate += real(3) * v[3]
        if wp.static(ORDER >= 5):
            rate += real(4) * v[4]
        if wp.static(ORDER >= 6):
            rate += real(5) * v[5]
        return rate

    @wp.func
    def column(s: state_t, k: int) -> value_vec:
        v = value_vec()
        for q in range(Q):
            v[q] = s[q, k]
        return v

    @wp.func
    def shared_column(states: Any, lane: int, k: int) -> value_vec:
        # grain k's Nordsieck vector in lane ``lane``'s state of the shared tile (a run-time k: shared memory)
        v = value_vec()
        for q in range(Q):
            v[q] = wp.tile_extract(states, lane, q, k)
        return v

    @wp.func
    def at_driver(k: int, k0: int) -> bool:
        # grain k of the lane is the driven grain 0 (k0: its index in this lane, or -1). With a fixed slot the test of
        # k is settled when compiled (k is a constant in every unrolled loop), only k0 >= 0 is left to run
        if wp.static(DRIVER_SLOT >= 0):
            return k == wp.static(DRIVER_SLOT) and k0 >= 0
        return k == k0 and k0 >= 0

    return predicted_rate, column, shared_column, at_driver


def driver_functions(t: TileLayout):
    """A driven surface's per-step log entry, its power at t_n from that entry, one trapezoid step of its work, and
    its (u_0, dt·v_0) from its phases."""
    G, real, DRIVER_SLOT, DASHPOT, state_t, vec2 = t.G, t.real, t.DRIVER_SLOT, t.DASHPOT, t.state_t, t.vec2
    one_force, one_vec, dashpot = t.one_force, t.one_vec, t.dashpot

    @wp.func
    def driver_log_entry(s: state_t, k0: int, u_driver: real) -> wp.vec2d:
        # what the driver's power at t_n needs of the state besides cos(ω t_n) (kernels/step.py: P = ΔF_01 · v_0):
        # grain 0's overlap change d = u_0 − u_1 and, with the contact dashpot, grain 1's dt·v, as float64 (exact for
        # float32). Grains k0, k0 + 1 picked by selects over the static positions: an index known only at run time
        # would put the lane's whole register matrix in local memory, for every lane, every step
        d_old = real(0)
        below_rate_old = real(0)
        if wp.static(DRIVER_SLOT >= 0):
            # a fixed slot: no select, every lane computes the entry (the others' go to their scratch rows)
            d_old = u_driver - s[0, wp.static(min(DRIVER_SLOT + 1, G - 1))]
            if wp.static(DASHPOT):
                below_rate_old = s[1, wp.static(min(DRIVER_SLOT + 1, G - 1))]
        else:
            for k in range(G):  # range(G), not range(G - 1): Warp unrolls only a bound it reads as a constant
                if k == k0:
                    d_old = u_driver - s[0, wp.min(k + 1, G - 1)]
                    if wp.static(DASHPOT):
                        below_rate_old = s[1, wp.min(k + 1, G - 1)]
        return wp.vec2d(wp.float64(d_old), wp.float64(below_rate_old))

    @wp.func
    def driver_power(
        entry: wp.vec2d,
        cos_old: wp.float64,
        below0: real,
        below_ac: real,
        below_f0: real,
        n: real,
        amplitude: wp.float64,
        omega: wp.float64,
        dt: wp.float64,
        gamma: real,
    ) -> wp.float64:
        # kernels/step.py: the driver's power at t_n from its driver_log_entry and cos(ω t_n), with the lane's
        # contact law (branchless where the lane's is: the same bits as contact_force)
        d_old = real(entry[0])
        force_old = wp.float64(one_force(one_vec(below0 + d_old), one_vec(below_ac), one_vec(below_f0), n)[0])
        if wp.static(DASHPOT):
            # the driver also pushes through the dashpot of its contact (kernels/step.py: the work includes it)
            rate_old = real(dt * amplitude * omega * cos_old) - real(entry[1])
            force_old += wp.float64(dashpot(below0, d_old, rate_old, gamma, real(dt)))
        return force_old * amplitude * omega * cos_old

    @wp.func
    def work_step(work_power: wp.vec2d, power: wp.float64, step_old: int, dt: wp.float64) -> wp.vec2d:
        # kernels/step.py: the driver's work W and power P after the step from step_old, whose power at t_n is power
        if wp.static(DASHPOT):
            if step_old == 0:
                return wp.vec2d(work_power[0], power)  # W(0) = 0: the dashpot's power at t = 0 is not zero
        return wp.vec2d(work_power[0] + dt * wp.float64(0.5) * (work_power[1] + power), power)

    @wp.func
    def driver_values(amplitude: wp.float64, omega: wp.float64, phase: wp.vec2d, dt: wp.float64) -> vec2:
        # the prescribed surface grain's u_0 and dt·v_0 where (sin ωt, cos ωt) = phase, as kernels/step.py stores
        # them. The fused kernels never store them in the driver's register column during the launch: every step
        # reads the driver from its phases (its predicted position, its overlap change in driver_log_entry, an
        # event step's neighbour: driver_values_at), so its column is left to its own corrector (no select per
        # step), and traces and the write-back take these values
        return vec2(real(product_rn(amplitude, phase[0])), real(dt * amplitude * omega * phase[1]))

    return driver_log_entry, driver_power, work_step, driver_values


def loss_functions(t: TileLayout, predicted_rate, column, at_driver):
    """Damping: the viscous loss of one step, the lane's predicted rates, the contact dashpot's forces and its loss
    of one step."""
    G, G1, real, MASKED, FREE_END, DRIVEN, SURFACE_WALL = (
        t.G,
        t.G1,
        t.real,
        t.MASKED,
        t.FREE_END,
        t.DRIVEN,
        t.SURFACE_WALL,
    )
    state_t, grain_vec, contact_vec, loss_vec = t.state_t, t.grain_vec, t.contact_vec, t.loss_vec
    nordsieck, dashpot = t.nordsieck, t.dashpot

    @wp.func
    def dissipation(
        s: state_t, lost: loss_vec, inv_m: grain_vec, move_bits: int, k0: int, gamma: real, h: real, dt: wp.float64
    ) -> loss_vec:
        # kernels/step.py's viscous loss of one step for every integrated grain of the lane (not a held bottom
        # grain, not the driver, not padding): the trapezoid of γ m (dt·v)²/h² at t_n and at the predicted t_n+1
        out = lost
        for k in range(G):
            if (move_bits & (1 << k)) != 0 and not at_driver(k, k0):
                own_rate = predicted_rate(column(s, k))
                own_rate_old = s[1, k]
                m_i = real(1) / inv_m[k]
                loss_old = gamma * m_i * own_rate_old * own_rate_old / (h * h)
                loss_new = gamma * m_i * own_rate * own_rate / (h * h)
                out[k] = out[k] + dt * wp.float64(0.5) * (wp.float64(loss_old) + wp.float64(loss_new))
        return out

    @wp.func
    def lane_rates(
        s: state_t, k0: int, amplitude: wp.float64, omega: wp.float64, phase_new: wp.vec2d, dt: wp.float64
    ) -> grain_vec:
        # dt·v of the lane's grains predicted at t_n+1 (the contact dashpot); the driver's is its own at t_n+1
        rates = grain_vec()
        for k in range(G):
            rates[k] = predicted_rate(column(s, k))
        if wp.static(DRIVEN):
            if k0 >= 0:
                for k in range(G):
                    if at_driver(k, k0):
                        rates[k] = real(dt * amplitude * omega * phase_new[1])
        return rates

    @wp.func
    def dashpot_forces(
        up: grain_vec,
        rates: grain_vec,
        u_left: real,
        rate_left: real,
        u_right: real,
        rate_right: real,
        delta0: contact_vec,
        contact_bits: int,
        gamma: real,
        h: real,
    ) -> contact_vec:
        # kernels/step.py's dashpot γ·δ̇ of each of the lane's G + 1 contacts at the predicted t_n+1 (a contact the
        # chain lacks, at a free end, has none): upper minus lower grain, as both of its grains compute it there
        out = contact_vec()
        for j in range(G1):
            upper_u = u_left
            upper_rate = rate_left
            if j > 0:
                upper_u = up[wp.max(j - 1, 0)]
                upper_rate = rates[wp.max(j - 1, 0)]
            lower_u = u_right
            lower_rate = rate_right
            if j < G:
                lower_u = up[wp.min(j, G - 1)]
                lower_rate = rates[wp.min(j, G - 1)]
            exists = True
            if wp.static(MASKED and FREE_END):
                exists = (contact_bits & (1 << j)) != 0
            if exists:
                out[j] = dashpot(delta0[j], upper_u - lower_u, upper_rate - lower_rate, gamma, h)
        return out

    @wp.func
    def dashpot_losses(
        s: state_t,
        lost: loss_vec,
        edges: Any,
        lane: int,
        base: int,
        has_left: bool,
        has_right: bool,
        delta0: contact_vec,
        contact_bits: int,
        move_bits: int,
        k0: int,
        amplitude: wp.float64,
        omega: wp.float64,
        phase_old: wp.vec2d,
        phase_new: wp.vec2d,
        gamma: real,
        h: real,
        dt: wp.float64,
    ) -> loss_vec:
        # kernels/step.py's dissipated energy of one step (contact dashpot) from the state at t_n and this step's
        # edge tile (read before the next step's barrier): per integrated grain the trapezoid of the power of the
        # dashpot below it, and of the one above it where no integrated grain is above (wall, driver)
        up = grain_vec()
        for k in range(G):
            up[k] = nordsieck.predict_position(column(s, k))
        if wp.static(DRIVEN):
            if k0 >= 0:
                for k in range(G):
                    if at_driver(k, k0):
                        up[k] = real(product_rn(amplitude, phase_new[0]))
        rates = lane_rates(s, k0, amplitude, omega, phase_new, dt)
        u_left = real(0)
        rate_left = real(0)
        u_right = real(0)
        rate_right = real(0)
        u_right_old = real(0)
        rate_right_old = real(0)
        if has_left:
            u_left = wp.tile_extract(edges, lane - 1, 1)
            rate_left = wp.tile_extract(edges, lane - 1, 3)
        if has_right:
            u_right = wp.tile_extract(edges, lane + 1, 0)
            rate_right = wp.tile_extract(edges, lane + 1, 2)
            u_right_old = wp.tile_extract(edges, lane + 1, 4)
            rate_right_old = wp.tile_extract(edges, lane + 1, 5)
        damp = dashpot_forces(up, rates, u_left, rate_left, u_right, rate_right, delta0, contact_bits, gamma, h)
        out = lost
        for k in range(G):
            if (move_bits & (1 << k)) != 0 and not at_driver(k, k0):
                own_rate = rates[k]
                own_rate_old = s[1, k]
                loss_old = real(0)
                loss_new = real(0)
                below = True
                if wp.static(MASKED and FREE_END):
                    below = (contact_bits & (1 << (k + 1))) != 0
                if below:
                    below_rate = rate_right
                    below_rate_old = rate_right_old
                    below_u_old = u_right_old
                    if k < G - 1:
                        below_rate = rates[wp.min(k + 1, G - 1)]
                        below_rate_old = s[1, wp.min(k + 1, G - 1)]
                        below_u_old = s[0, wp.min(k + 1, G - 1)]
                    loss_new += damp[k + 1] * (own_rate - below_rate) / h
                    f_old = dashpot(delta0[k + 1], s[0, k] - below_u_old, own_rate_old - below_rate_old, gamma, h)
                    loss_old += f_old * (own_rate_old - below_rate_old) / h
                outer = False
                above_rate = real(0)
                above_rate_old = real(0)
                above_u_old = real(0)
                if wp.static(SURFACE_WALL):
                    outer = base + k == 0
                if wp.static(DRIVEN):
                    if k0 >= 0 and at_driver(k - 1, k0):
                        outer = True
                        above_rate = real(dt * amplitude * omega * phase_new[1])
                        above_u_old = real(product_rn(amplitude, phase_old[0]))
                        above_rate_old = real(dt * amplitude * omega * phase_old[1])
                if outer:
                    loss_new += damp[k] * (above_rate - own_rate) / h
                    f_old = dashpot(delta0[k], above_u_old - s[0, k], above_rate_old - own_rate_old, gamma, h)
                    loss_old += f_old * (above_rate_old - own_rate_old) / h
                out[k] = out[k] + dt * wp.float64(0.5) * (wp.float64(loss_old) + wp.float64(loss_new))
        return out

    return dissipation, lane_rates, dashpot_forces, dashpot_losses


def event_steps_function(t: TileLayout, shared_column):
    """Event-aware steps: the event steps of a chain's flagged grains, shared among its lanes (None without events)."""
    if not t.EVENTS:
        return None
    G, L, real, DRIVEN, HETERO, MASKED, FIXED = t.G, t.L, t.real, t.DRIVEN, t.HETERO, t.MASKED, t.FIXED
    value_vec, vec3, params, event_step = t.value_vec, t.vec3, t.params, t.event_step
    driver_values_at = t.nordsieck.driver_values_at
    LO_CONTACT = 0 if t.SURFACE_WALL else 1  # padded contacts c with LO_CONTACT <= c <= n_grains - HI_OFFSET exist
    HI_OFFSET = 0 if t.BOTTOM_WALL else 1

    @wp.func
    def shared_event_steps(
        states: Any,
        flags: Any,
        results: Any,
        lane_c: int,
        segment: int,
        first: int,
        cc: int,
        n_grains: int,
        static_overlap: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        exponent: wp.array(dtype=real),
        inverse_mass: wp.array2d(dtype=real),
        n: real,
        h: real,
        amplitude: wp.float64,
        omega: wp.float64,
        phase_old: wp.vec2d,
        dt: wp.float64,
    ):
        # The event steps of a chain's flagged grains, shared among the chain's L lanes: in round m lane j takes
        # the chain's grain j + m·L (neighbouring flagged grains, which sit in one lane, go to neighbouring
        # lanes). A worker reads everything from t_n's shared state and the parameter arrays, nothing from its
        # own lane's registers, and writes the new Nordsieck vector to the grain's slot of ``results``; rounds
        # no lane needs are skipped by one vote.
        m = int(0)
        while m < G:  # (a loop: one copy of the event step)
            chain_grain = lane_c + m * L
            owner_c = chain_grain / G
            k = chain_grain - owner_c * G
            owner = segment * L + owner_c
            mine = (wp.tile_extract(flags, owner) >> k) & 1
            if block_any(mine) != 0:
                new = value_vec()
                if mine != 0:
                    g = first + owner_c * G + k
                    own = shared_column(states, owner, k)
                    above = value_vec()
                    if k > 0:
                        above = shared_column(states, owner, k - 1)
                    elif owner_c > 0:
                        above = shared_column(states, owner - 1, G - 1)
                    below = value_vec()
                    if k < G - 1:
                        below = shared_column(states, owner, k + 1)
                    elif owner_c < L - 1:
                        below = shared_column(states, owner + 1, 0)
                    if wp.static(DRIVEN):
                        if g == 1:  # grain 1 sees the driver's vector at t_n above it
                            above = driver_values_at(amplitude, omega, phase_old[0], phase_old[1], dt)
                    has_above = g >= LO_CONTACT and g <= n_grains - HI_OFFSET
                    has_below = g + 1 >= LO_CONTACT and g + 1 <= n_grains - HI_OFFSET
                    p_above = params(static_overlap, contact_constant, exponent, cc, wp.min(wp.max(g, 0), n_grains))
                    p_below = params(static_overlap, contact_constant, exponent, cc, wp.min(wp.max(g + 1, 0), n_grains))
                    inside = g >= 0 and g < n_grains
                    inv_m_event = real(0)
                    if wp.static(HETERO):
                        inv_m_event = inverse_mass[cc, wp.min(wp.max(g, 0), n_grains - 1)]
                    else:
                        inv_m_event = inverse_mass[cc, 0]
                    if wp.static(MASKED):
                        if not inside:
                            inv_m_event = real(0)
                    new = event_step(
                        own,
                        above,
                        below,
                        has_above,
                        has_below,
                        vec3(p_above[0], p_above[1], n),
                        vec3(p_below[0], p_below[1], n),
                        inv_m_event,
                        h,
                    )
                    if wp.static(FIXED):
                        if not inside or g == n_grains - 1:  # a held bottom grain (or padding) stays
                            new = own
                wp.tile_scatter_masked(results, owner * G + k, new, mine != 0)
            m += 1

    return shared_event_steps


def advance_function(t: TileLayout, predicted_rate, column, at_driver, lane_rates, dashpot_forces, shared_event_steps):
    """One step of a lane: predict, exchange the edge positions, (event-aware steps: test, vote, step the flagged
    grains), contact forces, correct."""
    Q, G, G1, real, EDGE_LO = t.Q, t.G, t.G1, t.real, t.EDGE_LO
    COMP, DRIVEN, EVENTS, DASHPOT, VISCOUS, MASKED, FREE_END, FIXED = (
        t.COMP,
        t.DRIVEN,
        t.EVENTS,
        t.DASHPOT,
        t.VISCOUS,
        t.MASKED,
        t.FREE_END,
        t.FIXED,
    )
    state_t, grain_vec, contact_vec, edge_t, value_vec, vec2 = (
        t.state_t,
        t.grain_vec,
        t.contact_vec,
        t.edge_t,
        t.value_vec,
        t.vec2,
    )
    nordsieck, forces, near_event = t.nordsieck, t.forces, t.near_event
    driver_values_at = nordsieck.driver_values_at

    @wp.func
    def advance(
        s: state_t,
        edges: Any,
        states: Any,
        flags: Any,
        results: Any,
        lane: int,
        lane_c: int,
        segment: int,
        first: int,
        cc: int,
        n_grains: int,
        static_overlap: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        exponent: wp.array(dtype=real),
        inverse_mass: wp.array2d(dtype=real),
        has_left: bool,
        has_right: bool,
        delta0: contact_vec,
        a_c: contact_vec,
        force0: contact_vec,
        n: real,
        inv_m: grain_vec,
        hh: real,
        contact_bits: int,
        move_bits: int,
        h: real,
        k0: int,
        amplitude: wp.float64,
        omega: wp.float64,
        phase_old: wp.vec2d,
        phase_new: wp.vec2d,
        dt: wp.float64,
        gamma: real,
    ) -> state_t:
        # k0: grain 0's index in this lane, or -1 (undriven, or grain 0 elsewhere); phase_old, phase_new:
        # (sin ωt, cos ωt) of the driver at t_n and t_{n+1}
        # 1. predict
        up = grain_vec()
        up_lo = grain_vec()  # compensated: the low parts (0 otherwise, unused)
        for k in range(G):
            if wp.static(COMP):
                position = nordsieck.predicted(column(s, k))
                up[k] = position[0]
                up_lo[k] = position[1]
            else:
                up[k] = nordsieck.predict_position(column(s, k))
        if wp.static(DRIVEN):
            # selects over the static positions, false in every lane but the driver's (k0 = -1): no branch, whose
            # reconvergence every block of the driven kernel paid each step
            if wp.static(COMP):
                driver_position = nordsieck.exact_position(product_rn(amplitude, phase_new[0]))
                for k in range(G):
                    if at_driver(k, k0):
                        up[k] = driver_position[0]
                        up_lo[k] = driver_position[1]
            else:
                driver_u = real(product_rn(amplitude, phase_new[0]))
                for k in range(G):
                    if at_driver(k, k0):
                        up[k] = driver_u
        # 2. exchange the lane's edge positions with its neighbours (virtual grains outside sit at 0)
        if wp.static(EVENTS):
            # the event test also needs the neighbour lanes' edge grains' (u, dt·v) at t_n
            edge = edge_t()
            edge[0] = up[0]
            edge[1] = up[G - 1]
            edge[2] = s[0, 0]
            edge[3] = s[1, 0]
            edge[4] = s[0, G - 1]
            edge[5] = s[1, G - 1]
            if wp.static(COMP):
                edge[wp.static(EDGE_LO)] = up_lo[0]
                edge[wp.static(EDGE_LO + 1)] = up_lo[G - 1]
            wp.tile_assign(edges, wp.tile(edge, preserve_type=True))
        elif wp.static(COMP):
            wp.tile_assign(edges, wp.tile(edge_t(up[0], up[G - 1], up_lo[0], up_lo[G - 1]), preserve_type=True))
        elif wp.static(DASHPOT):
            rates = lane_rates(s, k0, amplitude, omega, phase_new, dt)
            wp.tile_assign(
                edges, wp.tile(edge_t(up[0], up[G - 1], rates[0], rates[G - 1], s[0, 0], s[1, 0]), preserve_type=True)
            )
        else:
            wp.tile_assign(edges, wp.tile(edge_t(up[0], up[G - 1]), preserve_type=True))
        u_left = real(0)
        u_right = real(0)
        u_left_lo = real(0)
        u_right_lo = real(0)
        if has_left:
            u_left = wp.tile_extract(edges, lane - 1, 1)
            if wp.static(COMP):
                u_left_lo = wp.tile_extract(edges, lane - 1, wp.static(EDGE_LO + 1))
        if has_right:
            u_right = wp.tile_extract(edges, lane + 1, 0)
            if wp.static(COMP):
                u_right_lo = wp.tile_extract(edges, lane + 1, wp.static(EDGE_LO))
        if wp.static(EVENTS):
            left_values = vec2()  # (u, dt·v) at t_n of the grains beyond the lane's edges (0: none)
            right_values = vec2()
            if has_left:
                left_values = vec2(wp.tile_extract(edges, lane - 1, 4), wp.tile_extract(edges, lane - 1, 5))
            if has_right:
                right_values = vec2(wp.tile_extract(edges, lane + 1, 2), wp.tile_extract(edges, lane + 1, 3))
        # 3. every contact of the lane once (the two edge contacts also in the neighbour lane)
        delta = contact_vec()
        if wp.static(COMP):
            # the contacts' relative displacements from (hi, lo) pairs (kernels/gear.py gap)
            delta[0] = delta0[0] + nordsieck.gap(vec2(u_left, u_left_lo), vec2(up[0], up_lo[0]))
            for k in range(G):
                position_below = vec2(u_right, u_right_lo)
                if k < G - 1:
                    position_below = vec2(up[wp.min(k + 1, G - 1)], up_lo[wp.min(k + 1, G - 1)])
                delta[k + 1] = delta0[k + 1] + nordsieck.gap(vec2(up[k], up_lo[k]), position_below)
        else:
            delta[0] = delta0[0] + (u_left - up[0])
            for k in range(G):
                u_below = u_right
                if k < G - 1:
                    u_below = up[wp.min(k + 1, G - 1)]
                delta[k + 1] = delta0[k + 1] + (up[k] - u_below)
        if wp.static(EVENTS):
            # grains touching a contact near an opening or closing (kernels/step.py's event test), from t_n's (u, dt·v)
            # and the predicted positions, before the corrector, so that t_n's state need not outlive it
            driver_above = value_vec()  # the driver's vector at t_n: what grain 1 sees above it
            if wp.static(DRIVEN):
                if k0 >= 0:
                    driver_above = driver_values_at(amplitude, omega, phase_old[0], phase_old[1], dt)
            # each of the lane's G + 1 contacts tested once, without a branch (branches around the tests broke the
            # step into pieces the compiler could not interleave, and the kernel ran several times slower); a grain is
            # flagged when either of its contacts is. Contact c joins grains c - 1 (above) and c of the lane.
            contact_flags = int(0)
            for c in range(G1):
                upper_u = left_values[0]
                upper_hv = left_values[1]
                upper_pred = u_left
                if c > 0:
                    upper_u = s[0, wp.max(c - 1, 0)]
                    upper_hv = s[1, wp.max(c - 1, 0)]
                    upper_pred = up[wp.max(c - 1, 0)]
                lower_u = right_values[0]
                lower_hv = right_values[1]
                lower_pred = u_right
                if c < G:
                    lower_u = s[0, wp.min(c, G - 1)]
                    lower_hv = s[1, wp.min(c, G - 1)]
                    lower_pred = up[wp.min(c, G - 1)]
                if wp.static(DRIVEN):
                    driver_above_here = at_driver(c - 1, k0)
                    upper_u = wp.where(driver_above_here, driver_above[0], upper_u)
                    upper_hv = wp.where(driver_above_here, driver_above[1], upper_hv)
                hit = near_event(
                    delta0[c] + (upper_u - lower_u), delta0[c] + (upper_pred - lower_pred), upper_hv - lower_hv, h
                )
                contact_flags = contact_flags | ((int(hit) & ((contact_bits >> c) & 1)) << c)
            event_bits = (contact_flags | (contact_flags >> 1)) & ((1 << G) - 1)
            # one vote a step: a block with no flagged grain (most steps) skips the rest; otherwise every lane
            # publishes its t_n state to shared memory, where the event steps read their neighbours
            any_event = block_any(event_bits)
            if any_event != 0:
                wp.tile_assign(states, wp.tile(s, preserve_type=True))
                wp.tile_assign(flags, wp.tile(event_bits))
                shared_event_steps(
                    states,
                    flags,
                    results,
                    lane_c,
                    segment,
                    first,
                    cc,
                    n_grains,
                    static_overlap,
                    contact_constant,
                    exponent,
                    inverse_mass,
                    n,
                    h,
                    amplitude,
                    omega,
                    phase_old,
                    dt,
                )
                s = wp.tile_extract(states, lane)  # (so that the lane's registers need not hold s meanwhile)
        # the contact forces after the event section (which needs only the overlaps), so that with event-aware steps
        # the forces and the corrector are scheduled together, not split by the section's branch
        force = forces(delta, a_c, force0, n)
        if wp.static(MASKED and FREE_END):
            for k in range(G1):
                if (contact_bits & (1 << k)) == 0:
                    force[k] = real(0)
        if wp.static(DASHPOT):
            # each contact's dashpot at the predicted t_n+1 (kernels/step.py: added to its Hertz force). The lane's
            # rates are recomputed rather than kept from the edge tile above: keeping them across the barrier cost
            # registers (sm_90, ptxas: 255 against 251 on gpu_10k's tile kernel)
            rate_left = real(0)
            rate_right = real(0)
            if has_left:
                rate_left = wp.tile_extract(edges, lane - 1, 3)
            if has_right:
                rate_right = wp.tile_extract(edges, lane + 1, 2)
            damp = dashpot_forces(
                up,
                lane_rates(s, k0, amplitude, omega, phase_new, dt),
                u_left,
                rate_left,
                u_right,
                rate_right,
                delta0,
                contact_bits,
                gamma,
                h,
            )
            for k in range(G1):
                force[k] = force[k] + damp[k]
        # 4. corrector. Padding grains have 1/m = 0: at rest they stay exactly 0. A fixed bottom grain is held.
        out = s
        for k in range(G):
            half_h2_acc = hh * (force[k] - force[k + 1]) * inv_m[k]
            if wp.static(VISCOUS):
                half_h2_acc -= real(0.5) * h * gamma * predicted_rate(column(s, k))  # h²/2 · (−γ v)
            new = nordsieck.corrected(column(s, k), up[k], half_h2_acc)
            if wp.static(FIXED):
                moving = (move_bits & (1 << k)) != 0
                for q in range(Q):
                    out[q, k] = wp.where(moving, new[q], s[q, k])
            else:
                for q in range(Q):
                    out[q, k] = new[q]
        if wp.static(EVENTS):
            if any_event != 0:
                for k in range(G):  # the lane's flagged grains take their event steps' results
                    if ((event_bits >> k) & 1) != 0:
                        taken = wp.tile_extract(results, lane * G + k)
                        for q in range(Q):
                            out[q, k] = taken[q]
        # (the driver's own column is left to its corrector: see driver_values)
        return out

    return advance


def trace_function(t: TileLayout, driver_values):
    """Traces: the trace sample after a step when one is due (written out of line)."""
    G, real, DRIVEN, state_t = t.G, t.real, t.DRIVEN, t.state_t

    @wp.func(inline=False)
    def write_trace_sample(
        s: state_t,
        x_in: wp.array3d(dtype=real),
        frozen: bool,
        live: bool,
        cc: int,
        base: int,
        keep_lo: int,
        keep_hi: int,
        trace_slot: wp.array(dtype=wp.int32),
        trace_stride: int,
        step_new: int,
        trace_x: wp.array4d(dtype=real),
        amplitude: wp.float64,
        omega: wp.float64,
        phase: wp.vec2d,
        dt: wp.float64,
    ) -> int:
        # kernels/step.py's trace sample after step ``step_new`` (a multiple of the stride): (u, dt·v) of the traced
        # grains this lane keeps (a frozen chain: its frozen state; the driven grain 0: its driver_values at
        # ``phase``), ring slot k % length. Out of line: written into the step loop, this code makes every step of the
        # traced window kernel slower on a GPU (measured), though it runs once a stride
        if live:
            sample = (step_new / trace_stride) % trace_x.shape[2]
            for k in range(G):
                g = base + k
                if g >= keep_lo and g < keep_hi:
                    slot = trace_slot[g]
                    if slot >= 0:
                        if frozen:
                            trace_x[0, cc, sample, slot] = x_in[0, cc, g]
                            trace_x[1, cc, sample, slot] = x_in[1, cc, g]
                        else:
                            u = s[0, k]
                            rate = s[1, k]
                            if wp.static(DRIVEN):
                                if g == 0:
                                    driver = driver_values(amplitude, omega, phase, dt)
                                    u = driver[0]
                                    rate = driver[1]
                            trace_x[0, cc, sample, slot] = u
                            trace_x[1, cc, sample, slot] = rate
        return 0

    @wp.func
    def write_traces(
        s: state_t,
        x_in: wp.array3d(dtype=real),
        frozen: bool,
        live: bool,
        cc: int,
        base: int,
        keep_lo: int,
        keep_hi: int,
        trace_slot: wp.array(dtype=wp.int32),
        trace_stride: int,
        step_new: int,
        next_trace: int,
        trace_x: wp.array4d(dtype=real),
        amplitude: wp.float64,
        omega: wp.float64,
        phase: wp.vec2d,
        dt: wp.float64,
    ) -> int:
        # after a step: the trace sample when ``step_new`` reaches ``next_trace``, the first multiple of the stride not
        # yet passed (one comparison a step, not a modulo); returns the next one
        if step_new != next_trace:
            return next_trace
        write_trace_sample(
            s,
            x_in,
            frozen,
            live,
            cc,
            base,
            keep_lo,
            keep_hi,
            trace_slot,
            trace_stride,
            step_new,
            trace_x,
            amplitude,
            omega,
            phase,
            dt,
        )
        return next_trace + trace_stride

    return write_traces


def step_function(t: TileLayout, *, advance, dissipation, dashpot_losses, write_traces, driver_log_entry):
    """One step of the fused kernel's loop, inlined at each of its three call sites (CUDA ``__forceinline__``): the
    driver's log entry, the viscous loss, ``advance``, the contact dashpot's loss and the trace sample; returns the
    lane's new state, its grains' dissipated energy and the next trace step."""
    real, DRIVEN, VISCOUS, DASHPOT, TRACES = t.real, t.DRIVEN, t.VISCOUS, t.DASHPOT, t.TRACES
    state_t, grain_vec, contact_vec, loss_vec = t.state_t, t.grain_vec, t.contact_vec, t.loss_vec

    @wp.func(inline=True)
    def fused_step(
        s: state_t,
        edges: Any,
        states: Any,
        flags: Any,
        results: Any,
        lost: loss_vec,
        next_trace: int,
        lane: int,
        lane_c: int,
        segment: int,
        first: int,
        cc: int,
        n_grains: int,
        static_overlap: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        exponent: wp.array(dtype=real),
        inverse_mass: wp.array2d(dtype=real),
        has_left: bool,
        has_right: bool,
        delta0: contact_vec,
        a_c: contact_vec,
        force0: contact_vec,
        n: real,
        inv_m: grain_vec,
        hh: real,
        contact_bits: int,
        move_bits: int,
        h: real,
        k0: int,
        amplitude: wp.float64,
        omega: wp.float64,
        phase_old: wp.vec2d,
        phase_new: wp.vec2d,
        dt: wp.float64,
        gamma: real,
        driver_log: wp.array2d(dtype=wp.vec2d),
        log_row: int,
        step: int,
        step0: int,
        x_in: wp.array3d(dtype=real),
        frozen: bool,
        live: bool,
        base: int,
        keep_lo: int,
        keep_hi: int,
        trace_slot: wp.array(dtype=wp.int32),
        trace_stride: int,
        trace_x: wp.array4d(dtype=real),
    ):
        # ``step``: the launch's step taken from phase_old's t_n to phase_new's t_n+1
        if wp.static(DRIVEN):
            driver_log[log_row, step] = driver_log_entry(s, k0, real(product_rn(amplitude, phase_old[0])))
        if wp.static(VISCOUS):
            lost = dissipation(s, lost, inv_m, move_bits, k0, gamma, h, dt)
        s_new = advance(
            s,
            edges,
            states,
            flags,
            results,
            lane,
            lane_c,
            segment,
            first,
            cc,
            n_grains,
            static_overlap,
            contact_constant,
            exponent,
            inverse_mass,
            has_left,
            has_right,
            delta0,
            a_c,
            force0,
            n,
            inv_m,
            hh,
            contact_bits,
            move_bits,
            h,
            k0,
            amplitude,
            omega,
            phase_old,
            phase_new,
            dt,
            gamma,
        )
        if wp.static(DASHPOT):
            lost = dashpot_losses(
                s,
                lost,
                edges,
                lane,
                base,
                has_left,
                has_right,
                delta0,
                contact_bits,
                move_bits,
                k0,
                amplitude,
                omega,
                phase_old,
                phase_new,
                gamma,
                h,
                dt,
            )
        if wp.static(TRACES):
            next_trace = write_traces(
                s_new,
                x_in,
                frozen,
                live,
                cc,
                base,
                keep_lo,
                keep_hi,
                trace_slot,
                trace_stride,
                step0 + step + 1,
                next_trace,
                trace_x,
                amplitude,
                omega,
                phase_new,
                dt,
            )
        return s_new, lost, next_trace

    return fused_step


def fused_kernel(t: TileLayout, fused_step, driver_power, work_step, driver_values):
    """The ``@wp.kernel`` of the fused steps: a lane's grains and constants loaded, ``fused_step`` taken ``steps``
    times, the driver's work summed and the interior written back."""
    shape, real, Q, G, G1, L, CPB, B, BG, MAX_UNROLL = (
        t.shape,
        t.real,
        t.Q,
        t.G,
        t.G1,
        t.L,
        t.CPB,
        t.B,
        t.BG,
        t.MAX_UNROLL,
    )
    WINDOWED, MASKED, TRACES, SURFACE_WALL, BOTTOM_WALL, DRIVEN, FIXED, HETERO, HERTZ = (
        t.WINDOWED,
        t.MASKED,
        t.TRACES,
        t.SURFACE_WALL,
        t.BOTTOM_WALL,
        t.DRIVEN,
        t.FIXED,
        t.HETERO,
        t.HERTZ,
    )
    DISSIPATES, EVENTS = t.DISSIPATES, t.EVENTS
    state_t, grain_vec, contact_vec, edge_t, value_vec, loss_vec = (
        t.state_t,
        t.grain_vec,
        t.contact_vec,
        t.edge_t,
        t.value_vec,
        t.loss_vec,
    )
    params, contact_force = t.params, t.contact_force

    # the module's block size is the launch's: Warp hashes a module's source for its default block size when the
    # kernel is made and again for each other size it is loaded with (each hash walks every function the kernel calls)
    @wp.kernel(
        module="unique",
        module_options=dict(KERNEL_OPTIONS, block_dim=B, max_unroll=MAX_UNROLL),
        enable_backward=False,
        grid_stride=False,
        cuda_max_registers=shape.max_registers or None,
    )
    def fused(
        x_in: wp.array3d(dtype=real),
        clock_in: wp.array(dtype=wp.int32),
        inverse_mass: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        static_overlap: wp.array2d(dtype=real),
        exponent: wp.array(dtype=real),
        status: wp.array(dtype=wp.int32),
        dt: wp.float64,
        steps: int,
        interior: int,
        ghost: int,
        blocks_per_chain: int,
        drive: wp.array2d(dtype=wp.float64),
        work_in: wp.array(dtype=wp.float64),
        power_in: wp.array(dtype=wp.float64),
        x_out: wp.array3d(dtype=real),
        clock_out: wp.array(dtype=wp.int32),
        work_out: wp.array(dtype=wp.float64),
        power_out: wp.array(dtype=wp.float64),
        trace_slot: wp.array(dtype=wp.int32),
        trace_stride: int,
        trace_x: wp.array4d(dtype=real),
        damping: wp.array(dtype=real),
        dissipated: wp.array2d(dtype=wp.float64),
        phases: wp.array2d(dtype=wp.vec2d),
        phase_first: wp.array(dtype=wp.int32),
        driver_log: wp.array2d(dtype=wp.vec2d),
    ):
        block, lane = wp.tid()
        chain_count = x_in.shape[1]
        n_grains = x_in.shape[2]
        segment = lane / L
        lane_c = lane - segment * L
        c = int(0)
        first = int(0)  # first grain of the window
        keep_lo = int(0)  # interior written back: [keep_lo, keep_hi)
        keep_hi = n_grains
        if wp.static(WINDOWED):
            c = block / blocks_per_chain
            piece = block - c * blocks_per_chain
            keep_lo = piece * interior
            keep_hi = wp.min(keep_lo + interior, n_grains)
            first = keep_lo - ghost
        else:
            c = block * CPB + segment
        base = first + lane_c * G
        live = c < chain_count
        cc = wp.min(c, chain_count - 1)
        if block == 0 and lane == 0:
            clock_out[0] = clock_in[0] + steps

        # load the lane's grains (0 outside the chain)
        s = state_t()
        for k in range(G):
            g = base + k
            if live and g >= 0 and g < n_grains:
                for q in range(Q):
                    s[q, k] = x_in[q, cc, g]

        # per-contact and per-grain constants (contact base + k joins grains base + k − 1 and base + k)
        n = real(0)
        if wp.static(not HERTZ):
            n = exponent[cc]
        delta0 = contact_vec()
        a_c = contact_vec()
        force0 = contact_vec()
        inv_m = grain_vec()
        contact_bits = int(0)
        move_bits = int(0)
        lo = int(1)
        if wp.static(SURFACE_WALL):
            lo = 0
        hi = n_grains - 1
        if wp.static(BOTTOM_WALL):
            hi = n_grains
        for k in range(G1):
            kk = wp.min(wp.max(base + k, 0), n_grains)
            if base + k >= lo and base + k <= hi:
                contact_bits = contact_bits | (1 << k)
            p = params(static_overlap, contact_constant, exponent, cc, kk)
            d0 = p[0]
            ac = p[1]
            delta0[k] = d0
            a_c[k] = ac
            force0[k] = contact_force(d0, ac, n)
        for k in range(G):
            g = base + k
            inside = g >= 0 and g < n_grains
            if inside:
                move_bits = move_bits | (1 << k)
                if wp.static(FIXED):
                    if g == n_grains - 1:
                        move_bits = move_bits & (~(1 << k))
            # (written out here and in the event step alike: one shared @wp.func for it makes nvcc schedule the impact
            # window kernel's step loop worse, measurably)
            m_inv = real(0)
            if wp.static(HETERO):
                m_inv = inverse_mass[cc, wp.min(wp.max(g, 0), n_grains - 1)]
            else:
                m_inv = inverse_mass[cc, 0]
            if wp.static(MASKED):
                if not inside:
                    m_inv = real(0)
            inv_m[k] = m_inv

        h = real(dt)
        hh = real(0.5) * h * h
        has_left = lane_c > 0
        has_right = lane_c < L - 1
        k0 = int(-1)  # grain 0's index in this lane (driven surface), else -1
        amplitude = wp.float64(0)
        omega = wp.float64(0)
        step0 = clock_in[0]
        work_power = wp.vec2d()
        if wp.static(DRIVEN):
            if live and base <= 0 and base + G > 0:
                k0 = -base
            amplitude = drive[cc, 0]
            omega = drive[cc, 1]
        phase_old = wp.vec2d()  # the driver's (sin ωt, cos ωt) at the last step taken
        phase_new = wp.vec2d()
        phase_next = wp.vec2d()  # ... at the step after phase_new's, loaded one step ahead
        first_row = int(0)  # the row of drive_table's phases that holds step0
        log_row = int(0)
        if wp.static(DRIVEN):
            # the driver's power is evaluated after the step loop from a log of its state, one row per chain: every
            # lane stores its entry each step, the driver's lane into its chain's row and the others into their
            # block's scratch row (chain_count + block), so the store needs no branch (a branch there, not taken by
            # 157 of a column's 158 windows, made every window of the driven column's kernel slower)
            log_row = chain_count + block
            if k0 >= 0:
                log_row = cc
            first_row = step0 - phase_first[0]
            phase_old = phases[cc, first_row]
            phase_next = phases[cc, first_row + 1]
        edges_even = wp.tile_zeros(shape=B, dtype=edge_t, storage="shared")
        edges_odd = wp.tile_zeros(shape=B, dtype=edge_t, storage="shared")
        if wp.static(EVENTS):
            # event steps: every lane's state at t_n, its flagged grains, one event step's result per lane
            states = wp.tile_empty(shape=B, dtype=state_t, storage="shared")
            flags = wp.tile_zeros(shape=B, dtype=int, storage="shared")
            results = wp.tile_empty(shape=BG, dtype=value_vec, storage="shared")
        else:
            states = edges_even  # (unused)
            flags = edges_even
            results = edges_even
        frozen = status[cc] == wp.static(STATUS_NON_FINITE)
        next_trace = int(0)  # the first step after step0 that takes a trace sample (a multiple of the stride)
        if wp.static(TRACES):
            next_trace = (step0 / trace_stride + 1) * trace_stride
        gamma = real(0)
        lost = loss_vec()  # the interior grains' dissipated energy so far (damped)
        if wp.static(DISSIPATES):
            gamma = damping[cc]
            for k in range(G):
                g = base + k
                if live and g >= keep_lo and g < keep_hi:
                    lost[k] = dissipated[cc, g]
        for _pair in range(steps / 2):
            if wp.static(DRIVEN):
                phase_new = phase_next
                phase_next = phases[cc, first_row + 2 * _pair + 1 + 1]  # (a row past the launch's last)
            s, lost, next_trace = fused_step(
                s,
                edges_even,
                states,
                flags,
                results,
                lost,
                next_trace,
                lane,
                lane_c,
                segment,
                first,
                cc,
                n_grains,
                static_overlap,
                contact_constant,
                exponent,
                inverse_mass,
                has_left,
                has_right,
                delta0,
                a_c,
                force0,
                n,
                inv_m,
                hh,
                contact_bits,
                move_bits,
                h,
                k0,
                amplitude,
                omega,
                phase_old,
                phase_new,
                dt,
                gamma,
                driver_log,
                log_row,
                2 * _pair,
                step0,
                x_in,
                frozen,
                live,
                base,
                keep_lo,
                keep_hi,
                trace_slot,
                trace_stride,
                trace_x,
            )
            phase_old = phase_new
            if wp.static(DRIVEN):
                phase_new = phase_next
                phase_next = phases[cc, first_row + 2 * _pair + 2 + 1]  # (a row past the launch's last)
            s, lost, next_trace = fused_step(
                s,
                edges_odd,
                states,
                flags,
                results,
                lost,
                next_trace,
                lane,
                lane_c,
                segment,
                first,
                cc,
                n_grains,
                static_overlap,
                contact_constant,
                exponent,
                inverse_mass,
                has_left,
                has_right,
                delta0,
                a_c,
                force0,
                n,
                inv_m,
                hh,
                contact_bits,
                move_bits,
                h,
                k0,
                amplitude,
                omega,
                phase_old,
                phase_new,
                dt,
                gamma,
                driver_log,
                log_row,
                2 * _pair + 1,
                step0,
                x_in,
                frozen,
                live,
                base,
                keep_lo,
                keep_hi,
                trace_slot,
                trace_stride,
                trace_x,
            )
            phase_old = phase_new
        if steps % 2 == 1:
            if wp.static(DRIVEN):
                phase_new = phase_next
            s, lost, next_trace = fused_step(
                s,
                edges_even,
                states,
                flags,
                results,
                lost,
                next_trace,
                lane,
                lane_c,
                segment,
                first,
                cc,
                n_grains,
                static_overlap,
                contact_constant,
                exponent,
                inverse_mass,
                has_left,
                has_right,
                delta0,
                a_c,
                force0,
                n,
                inv_m,
                hh,
                contact_bits,
                move_bits,
                h,
                k0,
                amplitude,
                omega,
                phase_old,
                phase_new,
                dt,
                gamma,
                driver_log,
                log_row,
                steps - 1,
                step0,
                x_in,
                frozen,
                live,
                base,
                keep_lo,
                keep_hi,
                trace_slot,
                trace_stride,
                trace_x,
            )
            phase_old = phase_new

        if wp.static(DRIVEN):
            # read again after the loop, with the driver's work: what the loop keeps of them is only what its steps
            # read (the table's row of the last step's t_n+1 holds the same bits as the loop's phase_old)
            phase_old = phases[cc, first_row + steps]
            work_power = wp.vec2d(work_in[cc], power_in[cc])
            if first <= 0:  # the block holds grain 0 (a window at the surface; every block of whole chains)
                # the driver's power at each step's t_n from the log its lane wrote, one step per lane, then its
                # work summed by that lane in step order (kernels/step.py's trapezoid): off the steps' critical
                # path, where the driver's lane alone evaluated a contact force every step while its block waited
                # the powers go through shared memory: the sum's loads are the driver lane's serial path
                block_sync(0)
                p01 = params(static_overlap, contact_constant, exponent, cc, 1)
                below0 = p01[0]
                below_ac = p01[1]
                below_f0 = contact_force(below0, below_ac, n)
                powers = wp.tile_zeros(shape=B, dtype=wp.float64, storage="shared")
                round_first = int(0)
                while round_first < steps:  # rounds of L steps, one a lane
                    if round_first > 0:
                        block_sync(0)  # the driver's lane has read the last round
                    j = round_first + lane_c
                    power = wp.float64(0)
                    if live and j < steps:
                        power = driver_power(
                            driver_log[cc, j],
                            phases[cc, first_row + j][1],
                            below0,
                            below_ac,
                            below_f0,
                            n,
                            amplitude,
                            omega,
                            dt,
                            gamma,
                        )
                    powers[lane] = power
                    block_sync(0)
                    if k0 >= 0:
                        for q in range(wp.min(steps - round_first, L)):  # the trapezoid's steps in order
                            work_power = work_step(work_power, powers[segment * L + q], step0 + round_first + q, dt)
                    round_first += L
        # write back the interior; a frozen (non-finite) chain keeps its state
        if wp.static(DRIVEN):
            if k0 >= 0 and keep_lo <= 0:
                if frozen:
                    work_power = wp.vec2d(work_in[cc], power_in[cc])
                work_out[cc] = work_power[0]
                power_out[cc] = work_power[1]
        for k in range(G):
            g = base + k
            if live and g >= keep_lo and g < keep_hi:
                for q in range(Q):
                    if frozen:
                        x_out[q, cc, g] = x_in[q, cc, g]
                    else:
                        value = s[q, k]
                        if wp.static(DRIVEN):
                            if g == 0:  # the driven grain: kernels/step.py's (u_0, dt·v_0, 0, …) (driver_values)
                                value = real(0)
                                if q < 2:
                                    value = driver_values(amplitude, omega, phase_old, dt)[q]
                        x_out[q, cc, g] = value
                if wp.static(DISSIPATES):
                    if not frozen:
                        dissipated[cc, g] = lost[k]

    return fused


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
) -> TilePlan:
    """Lay out a fused launch for ``chain_count`` chains of ``grain_count`` grains.

    Whole chains: ``lanes_per_chain = ceil(grain_count / grains_per_lane)`` unless given (it must cover
    the chain), ``chains_per_block`` chains per block. Windowed: ``lanes_per_chain`` lanes hold a window,
    its ghost zones are ``steps_per_launch`` grains (see hertzian.kernels.ghost). Raises ValueError for shapes
    that cannot work (a block over 1024 threads, a window without interior).
    """
    from hertzian.kernels.ghost import plan_windows

    n = grain_count
    G = grains_per_lane
    free_end = features.surface != "wall" or features.bottom == "free"
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
        masked = lanes * G != n or free_end
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


def edge_values(features: Features) -> int:
    """Values a lane publishes to its neighbours each step: its edge grains' predicted positions (2), with event-aware
    steps also their (u, dt·v) at t_n (4 more), with compensated float32 the positions' low parts (2 more); with the
    contact dashpot the predicted rates and the first grain's (u, dt·v) at t_n (6 in all)."""
    if features.damping == "contact":
        return 6
    return (6 if features.event_window > 0 else 2) + (2 if features.compensation else 0)


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


@wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
def drive_table(
    clock: wp.array(dtype=wp.int32),
    drive: wp.array2d(dtype=wp.float64),
    dt: wp.float64,
    phases: wp.array2d(dtype=wp.vec2d),
    phase_first: wp.array(dtype=wp.int32),
):
    # the driver's (sin ωt, cos ωt) of chain c at step clock + row, with the per-step kernel's argument ω·(n·dt)
    # (the same bits); phase_first: the step of row 0
    c, row = wp.tid()
    first = clock[0]
    if c == 0 and row == 0:
        phase_first[0] = first
    omega = drive[c, 1]
    t = wp.float64(first + row) * dt
    phases[c, row] = wp.vec2d(wp.sin(omega * t), wp.cos(omega * t))


def launch_drive_table(*, clock, drive, dt: float, phases, phase_first, device, rows: int | None = None) -> None:
    """Fill the first ``rows`` rows (all by default) of ``phases`` (chains, rows) with the driver's phases at steps
    clock … clock + rows − 1 (the clock read on the device, so a captured graph replays it at any clock); driven
    fused launches of n steps in all from that clock read rows 0 … n + 1 (each loads the next step's row ahead)."""
    rows = phases.shape[1] if rows is None else min(rows, phases.shape[1])
    wp.launch(
        drive_table,
        dim=(phases.shape[0], rows),
        inputs=[clock, drive, dt],
        outputs=[phases, phase_first],
        device=device,
    )


def launch_tile(
    plan: TilePlan,
    kernel,
    *,
    x_in,
    clock_in,
    inverse_mass,
    contact_constant,
    static_overlap,
    exponent,
    status,
    dt: float,
    steps: int,
    x_out,
    clock_out,
    device,
    drive,
    work_in,
    power_in,
    work_out,
    power_out,
    trace_slot=None,
    trace_stride: int = 1,
    trace_x=None,
    damping=None,
    dissipated=None,
    phases=None,
    phase_first=None,
    driver_log=None,
    record_cmd: bool = False,
):
    """Launch ``steps`` fused steps (``steps ≤ plan.steps_per_launch`` when windowed); x_in and x_out differ.

    ``drive`` (chains, 2), ``work_*``/``power_*`` (chains,): the model's and states' arrays (size 0 undriven);
    ``trace_slot`` (grains,) each grain's column in the ring ``trace_x`` (2, chains, length, traced) or −1, and
    ``trace_stride``: traces (None without them). ``damping`` (chains,) γ and ``dissipated`` (chains, grains),
    updated in place: viscous damping (None undamped). ``phases``/``phase_first``: a driven surface's phase table
    (:func:`launch_drive_table`, filled from a clock at or before ``clock_in``'s and covering every step of this
    launch and the one after it; None undriven); ``driver_log`` (chains + plan.block_count, K) vec2d: the driver's
    per-step log (None undriven)."""
    if plan.shape.windowed and steps > plan.ghost:
        raise ValueError(f"steps = {steps}: a windowed launch takes at most {plan.ghost}")
    device = wp.get_device(device)
    if device.is_cpu and plan.shape.block_dim > 1:
        # Warp runs CPU blocks wider than one thread as cooperative fibers only when asked (1.19)
        wp.config.enable_cpu_blocks = True
    if trace_slot is None:
        trace_slot = wp.empty(0, dtype=wp.int32, device=device)
        trace_x = wp.empty((2, 0, 0, 0), dtype=x_in.dtype, device=device)
    if damping is None:
        damping = wp.empty(0, dtype=x_in.dtype, device=device)
        dissipated = wp.empty((0, 0), dtype=wp.float64, device=device)
    if phases is None:
        phases = wp.empty((0, 0), dtype=wp.vec2d, device=device)
        phase_first = wp.empty(0, dtype=wp.int32, device=device)
        driver_log = wp.empty((0, 0), dtype=wp.vec2d, device=device)
    return wp.launch_tiled(
        kernel,
        dim=[plan.block_count],
        inputs=[
            x_in,
            clock_in,
            inverse_mass,
            contact_constant,
            static_overlap,
            exponent,
            status,
            dt,
            steps,
            plan.interior,
            plan.ghost,
            plan.blocks_per_chain,
            drive,
            work_in,
            power_in,
        ],
        outputs=[
            x_out,
            clock_out,
            work_out,
            power_out,
            trace_slot,
            trace_stride,
            trace_x,
            damping,
            dissipated,
            phases,
            phase_first,
            driver_log,
        ],
        block_dim=plan.shape.block_dim,
        device=device,
        record_cmd=record_cmd,
    )
