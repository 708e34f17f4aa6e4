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

import warp as wp
from hertzian.kernels.features import KERNEL_OPTIONS, STATUS_NON_FINITE, Features
from hertzian.kernels.tile_advance import advance_function, event_steps_function, register_functions, step_function
from hertzian.kernels.tile_driver import drive_table, driver_functions, launch_drive_table, trace_function
from hertzian.kernels.tile_layout import TileLayout, TileShape, block_sync, edge_values, fusable, tile_layout
from hertzian.kernels.tile_losses import loss_functions
from hertzian.kernels.tile_plan import SHARED_BYTES, TilePlan, plan_tile, shared_bytes, with_driver_slot

__all__ = [  # the fused kernel family's public names, each defined in the module of its concern
    "SHARED_BYTES",
    "TileLayout",
    "TilePlan",
    "TileShape",
    "block_sync",
    "drive_table",
    "edge_values",
    "fusable",
    "launch_drive_table",
    "launch_tile",
    "plan_tile",
    "shared_bytes",
    "tile_kernel",
    "tile_layout",
    "with_driver_slot",
]


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


def fused_kernel(t: TileLayout, fused_step, driver_power, work_step, driver_values):
    """The ``@wp.kernel`` of the fused steps: a lane's grains and constants loaded, ``fused_step`` taken ``steps``
    times, the driver's work summed and the interior written back."""
    real, Q, G, G1, L, CPB, B, BG = t.real, t.Q, t.G, t.G1, t.L, t.CPB, t.B, t.BG
    WINDOWED, MASKED, TRACES, SURFACE_WALL, BOTTOM_WALL = t.WINDOWED, t.MASKED, t.TRACES, t.SURFACE_WALL, t.BOTTOM_WALL
    DRIVEN, FIXED, HETERO, HERTZ, LATTICE = t.DRIVEN, t.FIXED, t.HETERO, t.HERTZ, t.LATTICE
    DISSIPATES, EVENTS, RING = t.DISSIPATES, t.EVENTS, t.RING
    state_t, grain_vec, contact_vec, edge_t = t.state_t, t.grain_vec, t.contact_vec, t.edge_t
    value_vec, loss_vec, shape_t, lane_t, arrays_t = t.value_vec, t.loss_vec, t.shape_t, t.lane_t, t.arrays_t
    params, contact_force = t.params, t.contact_force

    # the module's block size is the launch's: Warp hashes a module's source for its default block size when the
    # kernel is made and again for each other size it is loaded with (each hash walks every function the kernel calls)
    @wp.kernel(
        module="unique",
        module_options=dict(KERNEL_OPTIONS, block_dim=B, max_unroll=t.MAX_UNROLL),
        enable_backward=False,
        grid_stride=False,
        cuda_max_registers=t.shape.max_registers or None,
    )
    def fused(
        x_in: wp.array3d(dtype=real),
        clock_in: wp.array(dtype=wp.int32),
        inverse_mass: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        static_overlap: wp.array2d(dtype=real),
        law_parameters: wp.array(dtype=real),
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
        if wp.static(LATTICE):  # the law's per-chain shape: a lattice law's (p0, p1), else n (5/2 compiled in)
            n = shape_t(law_parameters[2 * cc], law_parameters[2 * cc + 1])
        else:
            n = real(0)
            if wp.static(not HERTZ):
                n = law_parameters[cc]
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
            p = params(static_overlap, contact_constant, law_parameters, cc, kk)
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
        if wp.static(RING):  # the first and last lanes are neighbours
            has_left = True
            has_right = True
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
        # the lanes' edge tiles: one for the even steps, one for the odd (a composed step: its substeps alternate)
        even = wp.tile_zeros(shape=B, dtype=edge_t, storage="shared")
        odd = wp.tile_zeros(shape=B, dtype=edge_t, storage="shared")
        if wp.static(EVENTS):
            # event steps: every lane's state at t_n, its flagged grains, one event step's result per lane
            states = wp.tile_empty(shape=B, dtype=state_t, storage="shared")
            flags = wp.tile_zeros(shape=B, dtype=int, storage="shared")
            results = wp.tile_empty(shape=BG, dtype=value_vec, storage="shared")
        else:
            states = even  # (unused)
            flags = even
            results = even
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
        ln = lane_t()  # the lane's values for the steps (and the arrays they read)
        ln.lane = lane
        ln.lane_c = lane_c
        ln.segment = segment
        ln.first = first
        ln.base = base
        ln.cc = cc
        ln.n_grains = n_grains
        ln.keep_lo = keep_lo
        ln.keep_hi = keep_hi
        ln.live = live
        ln.frozen = frozen
        ln.has_left = has_left
        ln.has_right = has_right
        ln.delta0 = delta0
        ln.a_c = a_c
        ln.force0 = force0
        ln.n = n
        ln.inv_m = inv_m
        ln.contact_bits = contact_bits
        ln.move_bits = move_bits
        ln.h = h
        ln.hh = hh
        ln.gamma = gamma
        ln.k0 = k0
        ln.log_row = log_row
        ln.step0 = step0
        ln.trace_stride = trace_stride
        ln.dt = dt
        ln.amplitude = amplitude
        ln.omega = omega
        ar = arrays_t()
        ar.static_overlap = static_overlap
        ar.contact_constant = contact_constant
        ar.law_parameters = law_parameters
        ar.inverse_mass = inverse_mass
        ar.x_in = x_in
        ar.driver_log = driver_log
        ar.trace_slot = trace_slot
        ar.trace_x = trace_x
        for _pair in range(steps / 2):
            if wp.static(DRIVEN):
                phase_new = phase_next
                phase_next = phases[cc, first_row + 2 * _pair + 1 + 1]  # (a row past the launch's last)
            s, lost, next_trace = fused_step(
                s, even, odd, states, flags, results, lost, next_trace, ln, ar, phase_old, phase_new, 2 * _pair
            )
            phase_old = phase_new
            if wp.static(DRIVEN):
                phase_new = phase_next
                phase_next = phases[cc, first_row + 2 * _pair + 2 + 1]  # (a row past the launch's last)
            s, lost, next_trace = fused_step(
                s, odd, even, states, flags, results, lost, next_trace, ln, ar, phase_old, phase_new, 2 * _pair + 1
            )
            phase_old = phase_new
        if steps % 2 == 1:
            if wp.static(DRIVEN):
                phase_new = phase_next
            s, lost, next_trace = fused_step(
                s, even, odd, states, flags, results, lost, next_trace, ln, ar, phase_old, phase_new, steps - 1
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
                p01 = params(static_overlap, contact_constant, law_parameters, cc, 1)
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


def launch_tile(
    plan: TilePlan,
    kernel,
    *,
    x_in,
    clock_in,
    inverse_mass,
    contact_constant,
    static_overlap,
    law_parameters,
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
            law_parameters,
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
