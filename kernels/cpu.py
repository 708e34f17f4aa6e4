"""CPU chain kernel: one thread per chain, many steps per launch, neighbours carried in registers.

Warp runs a CPU launch on one thread, so the per-step kernel (a thread per grain, a launch per
step) spends its time on launch and index overhead and re-reads each neighbour three times. Here
one thread integrates a whole chain for ``steps`` steps: each step sweeps the grains from the
surface to the bottom, predicting grain ``i + 1`` just before it is needed and carrying the
predicted position and the force of the contact above grain ``i`` from the previous grain, so
each contact is evaluated once. The sweep updates the chain in place (in ``x_out``, after copying
``x_in``): grain ``i``'s corrector needs its own old values and its neighbours' *predicted*
positions, which are already in registers, so overwriting grain ``i`` cannot disturb grain
``i + 1``.

The arithmetic is ``kernels/step.py``'s expression for expression (bitwise equal on the CPU;
``tests/kernels/test_chain_kernel.py``), the driven surface grain and the driver's work included
(``tests/kernels/test_fused_features.py``), and damping (viscous and dashpot) with the dissipated energy
(``tests/core/test_drive.py``): the dashpot of the contact above grain ``i`` needs grain ``i − 1``'s old
and predicted values, which are carried from the previous grain since ``x_out`` already holds its new
ones. Traces are written inside the launch after each step k·stride, as the per-step kernel writes them.

One chain on several threads: a launch may sweep a window of the chain, in an array of its own, and write back
the grains far enough from the window's cut ends to be exact (a grain's step reads only its neighbours, so an
error at a cut end travels one grain a step; ``launch_chain``). The window's bounds are launch values: no shape
is compiled in.

A composed method (yoshida4) sweeps the chain once per velocity-Verlet substep, each sweep with its
substep's weight w (kernels/step.py's substep launches, in the same order; the in-place neighbour logic
is the same per substep).
"""

import functools
from types import SimpleNamespace

import warp as wp
from hertzian.kernels.events import event_functions
from hertzian.kernels.features import KERNEL_OPTIONS, STATUS_NON_FINITE, SUBSTEP_WEIGHTS, Features, take
from hertzian.kernels.gear import nordsieck_functions, refuse_composed_extras, substep_weight_function
from hertzian.kernels.physics import (
    contact_functions,
    contact_parameters,
    damping_functions,
    loss_functions,
    product_rn,
)
from hertzian.kernels.threads import BARRIER_SPIN_LIMIT, FIRST_WAIT_FACTOR, barrier


@functools.cache
def chain_kernel(features: Features):
    """The chain-per-thread kernel for one feature set (cached): it implements every feature (traces are sampled
    inside the launch)."""
    layout = _chain_layout(features)
    functions = _chain_functions(layout)
    f, real, Q, SURFACE_WALL, DRIVEN, BOTTOM_WALL = take(layout, "f real Q SURFACE_WALL DRIVEN BOTTOM_WALL")
    FIXED, RING, STATIC, HETERO, contact_force, vec4 = take(layout, "FIXED RING STATIC HETERO contact_force vec4")
    nordsieck, predicted_position, correct = take(layout, "nordsieck predicted_position correct")
    predicted_at, gap, rounded, EVENTS, values_t = take(layout, "predicted_at gap rounded EVENTS values_t")
    params, DAMPED, VISCOUS, DASHPOT, TRACES = take(layout, "params DAMPED VISCOUS DASHPOT TRACES")
    predicted_rate, dashpot, COMPOSED, SUBSTEPS = take(layout, "predicted_rate dashpot COMPOSED SUBSTEPS")
    substep_predicted_at, substep_correct = take(layout, "substep_predicted_at substep_correct")
    substep_weight, contacts_t = take(layout, "substep_weight contacts_t")
    contact, chain_shape, driver_values = take(functions, "contact chain_shape driver_values")
    write_traces, copy_grains, exchange = take(functions, "write_traces copy_grains exchange")
    damped_forces, event_correct = take(functions, "damped_forces event_correct")

    @wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
    def chain_steps(
        x_in: wp.array3d(dtype=real),
        clock_in: wp.array(dtype=wp.int32),
        inverse_mass: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        static_overlap: wp.array2d(dtype=real),
        law_parameters: wp.array(dtype=real),
        status: wp.array(dtype=wp.int32),
        dt: wp.float64,
        steps: int,
        drive: wp.array2d(dtype=wp.float64),
        work_in: wp.array(dtype=wp.float64),
        power_in: wp.array(dtype=wp.float64),
        x_out: wp.array3d(dtype=real),
        clock_out: wp.array(dtype=wp.int32),
        work_out: wp.array(dtype=wp.float64),
        power_out: wp.array(dtype=wp.float64),
        damping: wp.array(dtype=real),
        dissipated: wp.array2d(dtype=wp.float64),
        traced_grain: wp.array(dtype=wp.int32),
        trace_stride: int,
        trace_x: wp.array4d(dtype=real),
        first_chain: int,
        window: wp.vec4i,
        x_window: wp.array3d(dtype=real),
        exchange_every: int,
        barrier_state: wp.array(dtype=wp.uint32),
        parties: int,
        patience: wp.int64,
    ):
        # window = (lo, hi, own_lo, own_hi): grains [lo, hi) are swept in x_window, and [own_lo, own_hi) of them
        # written to x_out (the whole chain: x_window is x_out, and nothing is copied back). Only the sweep's
        # copy in x_window is written in place; what other windows read or write (x_out, the dissipated energy,
        # traces, the clock, the driver's work) is written for owned grains only
        c = wp.tid() + first_chain
        n_grains = x_in.shape[2]
        lo = window[0]
        hi = window[1]
        own_lo = window[2]
        own_hi = window[3]
        windowed = hi - lo < n_grains
        if c == 0 and own_lo == 0:
            clock_out[0] = clock_in[0] + steps
        for i in range(lo, hi):
            for q in range(wp.static(Q)):
                x_window[q, c, i] = x_in[q, c, i]
        if wp.static(DRIVEN):
            if lo == 0:
                work_out[c] = work_in[c]
                power_out[c] = power_in[c]
        if status[c] == wp.static(STATUS_NON_FINITE):
            # a blown-up chain is frozen (its trace samples repeat the frozen state, as in kernels/step.py)
            if wp.static(TRACES):
                for _frozen in range(steps):
                    write_traces(
                        trace_x, traced_grain, trace_stride, x_window, c, clock_in[0] + _frozen + 1, own_lo, own_hi
                    )
            if windowed:
                copy_grains(x_window, x_out, c, own_lo, own_hi)
            return

        n = chain_shape(law_parameters, c)
        a_c0 = contact_constant[c, 0]
        delta00 = real(0)
        if wp.static(STATIC):
            delta00 = static_overlap[c, 0]
        force00 = contact_force(delta00, a_c0, n)
        cs = contacts_t()  # what a contact's force reads
        cs.static_overlap = static_overlap
        cs.contact_constant = contact_constant
        cs.c = c
        cs.a_c0 = a_c0
        cs.delta00 = delta00
        cs.force00 = force00
        cs.n = n
        inv_m = inverse_mass[c, 0]
        h = real(dt)
        last = n_grains - 1
        amplitude = wp.float64(0)
        omega = wp.float64(0)
        if wp.static(DRIVEN):
            amplitude = drive[c, 0]
            omega = drive[c, 1]
            work = work_in[c]
            power_prev = power_in[c]
            step_first = clock_in[0]

        passes = steps  # sweeps of the chain: one per step, or per substep of a composed method
        if wp.static(COMPOSED):
            passes = steps * wp.static(SUBSTEPS)
        for _step in range(passes):  # (a composed method is never driven: _step counts steps where it is used)
            w = substep_weight(_step % wp.static(SUBSTEPS))
            # compensated float32: positions as (hi, lo) for the contacts (kernels/gear.py)
            if wp.static(COMPOSED):
                position_here = substep_predicted_at(x_window, c, lo, w)
            else:
                position_here = predicted_at(x_window, c, lo)
            step_new = int(0)
            t_new = wp.float64(0)
            u_drive = wp.float64(0)
            if wp.static(DRIVEN):
                # kernels/step.py's driven grain 0: prescribed u_0, and the driver's work (state at t_n)
                step_new = step_first + _step + 1
                t_new = wp.float64(step_new) * dt
                u_drive = product_rn(amplitude, wp.sin(omega * t_new))
                t_old = wp.float64(step_new - 1) * dt
                d_old = x_window[0, c, 0] - x_window[0, c, 1]
                force_old = wp.float64(contact(cs, 1, d_old))
                if wp.static(DASHPOT):
                    # the driver also pushes through the dashpot of its contact (work includes it)
                    rate_old = real(dt * amplitude * omega * wp.cos(omega * t_old)) - x_window[1, c, 1]
                    p01 = params(static_overlap, contact_constant, law_parameters, c, 1)
                    force_old += wp.float64(dashpot(p01[0], d_old, rate_old, damping[c], h))
                power = force_old * amplitude * omega * wp.cos(omega * t_old)
                if wp.static(DASHPOT):
                    if step_new != 1:  # W(0) = 0: the dashpot's power at t = 0 is not zero
                        work = work + dt * wp.float64(0.5) * (power_prev + power)
                else:
                    work = work + dt * wp.float64(0.5) * (power_prev + power)
                power_prev = power
                x1_drive = real(dt * amplitude * omega * wp.cos(omega * t_new))
                if lo == 0:  # else grain lo is no driven grain, and a wrong position there would reach a grain further
                    position_here = nordsieck.exact_position(u_drive)
                if wp.static(EVENTS):
                    driver_old = driver_values(amplitude, omega, t_old, dt)
            if wp.static(EVENTS):
                u_above = real(0)  # predicted position of the grain above (0: the wall)
                above_old = values_t()  # its Nordsieck vector at t_n (already overwritten in x_window)
            force_above = real(0)  # excess force of the contact above the current grain
            # (dashpot) the grain above at t_n and predicted (its x_window values are already overwritten)
            above_u = real(0)
            above_u_old = real(0)
            above_rate = real(0)
            above_rate_old = real(0)
            if wp.static(SURFACE_WALL):
                if wp.static(f.compensation):
                    # a wall is a grain at rest at 0 (as the fused kernel's padding grains)
                    force_above = contact(cs, 0, gap(nordsieck.exact_position(wp.float64(0.0)), position_here))
                else:
                    force_above = contact(cs, 0, -rounded(position_here))
            if wp.static(RING):
                # the closing contact: grain N − 1's and grain 0's positions predicted before this pass overwrites
                # grain 0; grain N − 1 takes the same force as the contact below it
                if wp.static(COMPOSED):
                    position_last = substep_predicted_at(x_window, c, last, w)
                else:
                    position_last = predicted_at(x_window, c, last)
                force_above = contact(cs, 0, gap(position_last, position_here))
                force_ring = force_above
            for i in range(lo, hi):
                u_here = rounded(position_here)
                position_next = position_here
                u_next = real(0)
                force_below = real(0)
                if i < last:
                    if wp.static(COMPOSED):
                        position_next = substep_predicted_at(x_window, c, i + 1, w)
                    else:
                        position_next = predicted_at(x_window, c, i + 1)
                    u_next = rounded(position_next)
                    force_below = contact(cs, i + 1, gap(position_here, position_next))
                else:
                    if wp.static(BOTTOM_WALL):
                        if wp.static(f.compensation):
                            force_below = contact(
                                cs, n_grains, gap(position_here, nordsieck.exact_position(wp.float64(0.0)))
                            )
                        else:
                            force_below = contact(cs, n_grains, u_here)
                    elif wp.static(RING):
                        force_below = force_ring
                held = False
                if wp.static(FIXED):
                    held = i == last
                if wp.static(EVENTS):
                    own_old = nordsieck.load(x_window, c, i)
                own_u_old = real(0)
                if wp.static(DASHPOT):
                    own_u = predicted_position(x_window, c, i)
                    own_u_old = x_window[0, c, i]
                    own_rate_dash = predicted_rate(x_window, c, i)
                    own_rate_dash_old = x_window[1, c, i]
                if wp.static(DRIVEN):
                    if i == 0:
                        held = True
                        x_window[0, c, 0] = real(u_drive)
                        x_window[1, c, 0] = x1_drive
                        for k in range(2, wp.static(Q)):
                            x_window[k, c, 0] = real(0)
                if not held:
                    m_inv = inv_m
                    if wp.static(HETERO):
                        m_inv = inverse_mass[c, i]
                    up = force_above
                    down = force_below
                    if wp.static(DAMPED):
                        up, down = damped_forces(
                            up,
                            down,
                            x_window,
                            c,
                            i,
                            last,
                            u_here,
                            own_u_old,
                            vec4(above_u, above_u_old, above_rate, above_rate_old),
                            m_inv,
                            damping,
                            dissipated,
                            static_overlap,
                            contact_constant,
                            law_parameters,
                            h,
                            dt,
                            own_lo,
                            own_hi,
                            wp.vec4d(u_drive, amplitude, omega, t_new),
                            step_new,
                        )
                    half_h2_acc = real(0.5) * h * h * (up - down) * m_inv
                    if wp.static(VISCOUS):
                        half_h2_acc -= real(0.5) * h * damping[c] * predicted_rate(x_window, c, i)  # h²/2 · (−γ v)
                    if wp.static(EVENTS):
                        event_correct(
                            x_window,
                            c,
                            i,
                            last,
                            own_old,
                            above_old,
                            u_above,
                            u_here,
                            u_next,
                            m_inv,
                            h,
                            half_h2_acc,
                            static_overlap,
                            contact_constant,
                            law_parameters,
                        )
                    elif wp.static(COMPOSED):
                        substep_correct(x_window, x_window, c, i, u_here, half_h2_acc, w)
                    else:
                        correct(x_window, x_window, c, i, u_here, half_h2_acc)
                force_above = force_below
                if wp.static(DASHPOT):
                    above_u = own_u
                    above_u_old = own_u_old
                    above_rate = own_rate_dash
                    above_rate_old = own_rate_dash_old
                if wp.static(EVENTS):
                    u_above = u_here
                    above_old = own_old
                    if wp.static(DRIVEN):
                        if i == 0:
                            above_old = driver_old  # step.py: grain 1 sees the driver's vector at t_n
                position_here = position_next
            if wp.static(TRACES):
                if _step % wp.static(SUBSTEPS) == wp.static(SUBSTEPS - 1):  # after a whole step (all its substeps)
                    step_done = clock_in[0] + _step / wp.static(SUBSTEPS) + 1
                    write_traces(trace_x, traced_grain, trace_stride, x_window, c, step_done, own_lo, own_hi)
            if windowed:
                if (_step + 1) % exchange_every == 0 and _step + 1 < passes:
                    # the first wait also covers the other threads' start: a generous patience for it
                    wait = patience
                    if _step + 1 == exchange_every:
                        wait = patience * wp.int64(FIRST_WAIT_FACTOR)
                    if not exchange(x_window, x_out, c, window, barrier_state, parties, wait):
                        return
        if wp.static(DRIVEN):
            if lo == 0:
                work_out[c] = work
                power_out[c] = power_prev
        if windowed:
            copy_grains(x_window, x_out, c, own_lo, own_hi)

    return chain_steps


def _chain_layout(features: Features) -> SimpleNamespace:
    """The chain kernel's compile-time constants and the device functions it takes from kernels/gear.py,
    kernels/physics.py and kernels/events.py, for one feature set."""
    f = features
    f = features
    real = wp.float64 if f.precision == "float64" else wp.float32
    Q = f.values
    SURFACE_WALL = f.surface == "wall"
    DRIVEN = f.surface == "driven"
    BOTTOM_WALL = f.bottom == "wall"
    FIXED = f.bottom == "fixed"
    RING = f.surface == "periodic"  # grain N − 1 touches grain 0 (padded contacts 0 and N); whole chains, no windows
    STATIC = f.static != "none"
    PROFILE = f.static == "profile"
    HETERO = f.heterogeneous
    HERTZ = f.hertz
    contact_force, excess_force = contact_functions(f.precision, f.hertz, f.potential)
    LATTICE = f.potential != "hertz"
    shape_t = wp.types.vector(2, real) if LATTICE else real
    vec4 = wp.types.vector(4, real)

    @wp.struct
    class ChainContacts:
        """What a chain's contact force reads: the per-contact arrays, the chain, and its first contact's constant,
        static overlap and static force (one for every contact of a uniform chain), and the law's shape."""

        static_overlap: wp.array2d(dtype=real)
        contact_constant: wp.array2d(dtype=real)
        c: int
        a_c0: real
        delta00: real
        force00: real
        n: shape_t

    contacts_t = ChainContacts
    nordsieck = nordsieck_functions(f.method, f.precision, f.compensation)
    predicted_position, correct = nordsieck.predicted_position, nordsieck.correct
    predicted_at, gap, rounded = nordsieck.predicted_at, nordsieck.gap, nordsieck.rounded
    EVENTS = f.event_window > 0
    values_t = nordsieck.values
    params = contact_parameters(f.precision, f.static, f.heterogeneous, f.hertz, f.potential)
    if EVENTS:
        near_event, event_step = event_functions(f)
    else:
        near_event = event_step = None
    DAMPED = f.damping != "none"
    VISCOUS = f.damping == "viscous"
    DASHPOT = f.damping == "contact"
    ORDER = f.nordsieck_values  # rows of the Nordsieck vector (kernels/gear.py)
    TRACES = f.traces

    predicted_rate, dashpot = damping_functions(f.precision, ORDER)
    viscous_losses, dashpot_losses = loss_functions(f.precision, ORDER)
    COMPOSED = f.method in SUBSTEP_WEIGHTS
    WEIGHTS = SUBSTEP_WEIGHTS.get(f.method, (1.0,))
    SUBSTEPS = len(WEIGHTS)
    refuse_composed_extras(f)
    substep_predicted_at, substep_correct = nordsieck.substep_predicted_at, nordsieck.substep_correct
    substep_weight = substep_weight_function(f.method, f.precision)
    return SimpleNamespace(**{name: value for name, value in locals().items() if name != "features"})


def _chain_functions(layout: SimpleNamespace) -> SimpleNamespace:
    """The chain kernel's own device functions: a contact's excess force, the law's shape, traces, the window
    exchange, the damping forces and losses, and the event-aware corrector."""
    real, Q, SURFACE_WALL, DRIVEN, BOTTOM_WALL = take(layout, "real Q SURFACE_WALL DRIVEN BOTTOM_WALL")
    PROFILE, HETERO, HERTZ, contact_force, contacts_t = take(layout, "PROFILE HETERO HERTZ contact_force contacts_t")
    excess_force, LATTICE, shape_t, vec4, nordsieck = take(layout, "excess_force LATTICE shape_t vec4 nordsieck")
    predicted_position, correct, values_t, params = take(layout, "predicted_position correct values_t params")
    near_event, event_step, VISCOUS, DASHPOT = take(layout, "near_event event_step VISCOUS DASHPOT")
    predicted_rate, dashpot, viscous_losses = take(layout, "predicted_rate dashpot viscous_losses")
    (dashpot_losses,) = take(layout, "dashpot_losses")

    @wp.func(inline=True)
    def contact(cs: contacts_t, k: int, d: real) -> real:
        # excess force of padded contact k of chain cs.c at relative displacement d (step.py's `contact`)
        if wp.static(PROFILE or HETERO):
            delta0 = cs.delta00
            if wp.static(PROFILE):
                delta0 = cs.static_overlap[cs.c, k]
            a_c = cs.a_c0
            if wp.static(HETERO):
                a_c = cs.contact_constant[cs.c, k]
            return excess_force(delta0, d, a_c, cs.n)
        else:
            # one δ0 and one a_c per chain: F(δ0) is the same for every contact, computed once
            return contact_force(cs.delta00 + d, cs.a_c0, cs.n) - cs.force00

    @wp.func
    def chain_shape(law_parameters: wp.array(dtype=real), c: int) -> shape_t:
        # the law's shape of chain c: n (5/2 compiled in for Hertz) or a lattice law's (p0, p1)
        if wp.static(LATTICE):
            return shape_t(law_parameters[2 * c], law_parameters[2 * c + 1])
        else:
            n = real(0)
            if wp.static(not HERTZ):
                n = law_parameters[c]
            return n

    driver_values = nordsieck.driver_values

    @wp.func
    def write_traces(
        trace_x: wp.array4d(dtype=real),
        traced_grain: wp.array(dtype=wp.int32),
        trace_stride: int,
        x: wp.array3d(dtype=real),
        c: int,
        step_new: int,
        own_lo: int,
        own_hi: int,
    ):
        # kernels/step.py's trace sample: (u, dt·v) of each traced grain after a step k·stride, ring slot k % length
        if step_new % trace_stride == 0:
            sample = (step_new / trace_stride) % trace_x.shape[2]
            for slot in range(traced_grain.shape[0]):
                i = traced_grain[slot]
                if i >= own_lo and i < own_hi:
                    trace_x[0, c, sample, slot] = x[0, c, i]
                    trace_x[1, c, sample, slot] = x[1, c, i]

    @wp.func
    def copy_grains(source: wp.array3d(dtype=real), target: wp.array3d(dtype=real), c: int, first: int, end: int):
        for i in range(first, end):
            for q in range(wp.static(Q)):
                target[q, c, i] = source[q, c, i]

    @wp.func
    def exchange(
        x_window: wp.array3d(dtype=real),
        x_out: wp.array3d(dtype=real),
        c: int,
        window: wp.vec4i,
        barrier_state: wp.array(dtype=wp.uint32),
        parties: int,
        patience: wp.int64,
    ) -> bool:
        # the owned grains next to each cut go out, the window's grains past each cut come in from the neighbour's
        lo = window[0]
        hi = window[1]
        own_lo = window[2]
        own_hi = window[3]
        copy_grains(x_window, x_out, c, own_lo, wp.min(own_lo + (own_lo - lo), own_hi))
        copy_grains(x_window, x_out, c, wp.max(own_hi - (hi - own_hi), own_lo), own_hi)
        if not barrier(barrier_state, parties, patience):
            return False
        copy_grains(x_out, x_window, c, lo, own_lo)
        copy_grains(x_out, x_window, c, own_hi, hi)
        # the next exchange writes what the neighbour has just read
        return barrier(barrier_state, parties, patience)

    @wp.func(inline=True)
    def damped_forces(
        up: real,
        down: real,
        x_window: wp.array3d(dtype=real),
        c: int,
        i: int,
        last: int,
        u_here: real,
        own_u_old: real,
        above: vec4,
        m_inv: real,
        damping: wp.array(dtype=real),
        dissipated: wp.array2d(dtype=wp.float64),
        static_overlap: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        law_parameters: wp.array(dtype=real),
        h: real,
        dt: wp.float64,
        own_lo: int,
        own_hi: int,
        driver: wp.vec4d,
        step_new: int,
    ):
        # step.py's damping block for grain i: (up, down) with the dashpot's forces at the predicted velocities, and
        # the loss power's trapezoid (t_n exact, t_n+1 predicted) added to the grain's dissipated energy. Grain i's
        # old values are still in x_window, grain i+1's too; grain i-1's are carried: above = (u, u at t_n, dt·v,
        # dt·v at t_n); driver = (u_0 at t_n+1, amplitude, omega, t_n+1) of a driven surface
        above_u = above[0]
        above_u_old = above[1]
        above_rate = above[2]
        above_rate_old = above[3]
        u_drive = driver[0]
        amplitude = driver[1]
        omega = driver[2]
        t_new = driver[3]
        gamma = damping[c]
        own_rate = predicted_rate(x_window, c, i)
        own_rate_old = x_window[1, c, i]
        loss_old = real(0)
        loss_new = real(0)
        if wp.static(VISCOUS):
            own_losses = viscous_losses(gamma, m_inv, own_rate, own_rate_old, h)
            loss_old = own_losses[0]
            loss_new = own_losses[1]
        if wp.static(DASHPOT):
            if i < last or wp.static(BOTTOM_WALL):
                below_rate = real(0)
                below_rate_old = real(0)
                d_new = u_here
                d_old_b = own_u_old
                if i < last:
                    below_rate = predicted_rate(x_window, c, i + 1)
                    below_rate_old = x_window[1, c, i + 1]
                    d_new = u_here - predicted_position(x_window, c, i + 1)
                    d_old_b = own_u_old - x_window[0, c, i + 1]
                delta0_below = params(static_overlap, contact_constant, law_parameters, c, i + 1)[0]
                below_losses = dashpot_losses(
                    delta0_below,
                    d_new,
                    d_old_b,
                    own_rate - below_rate,
                    own_rate_old - below_rate_old,
                    gamma,
                    h,
                )
                down += below_losses[0]
                loss_new += below_losses[1]
                loss_old += below_losses[2]
            if i > 0 or wp.static(SURFACE_WALL):
                a_u = real(0)
                a_u_old = real(0)
                a_rate = real(0)
                a_rate_old = real(0)
                outer = i == 0  # the contact above belongs to no integrated grain above
                if i > 0:
                    a_u = above_u
                    a_u_old = above_u_old
                    a_rate = above_rate
                    a_rate_old = above_rate_old
                    if wp.static(DRIVEN):
                        if i == 1:
                            outer = True
                            t_old_d = wp.float64(step_new - 1) * dt
                            a_u = real(u_drive)
                            a_u_old = real(product_rn(amplitude, wp.sin(omega * t_old_d)))
                            a_rate = real(dt * amplitude * omega * wp.cos(omega * t_new))
                            a_rate_old = real(dt * amplitude * omega * wp.cos(omega * t_old_d))
                delta0_above = params(static_overlap, contact_constant, law_parameters, c, i)[0]
                force_above_dashpot = dashpot(delta0_above, a_u - u_here, a_rate - own_rate, gamma, h)
                up += force_above_dashpot
                if outer:  # else the grain above counts this contact's loss as its own
                    above_losses = dashpot_losses(
                        delta0_above,
                        a_u - u_here,
                        a_u_old - own_u_old,
                        a_rate - own_rate,
                        a_rate_old - own_rate_old,
                        gamma,
                        h,
                    )
                    loss_new += above_losses[1]
                    loss_old += above_losses[2]
        if i >= own_lo and i < own_hi:
            dissipated[c, i] = dissipated[c, i] + dt * wp.float64(0.5) * (wp.float64(loss_old) + wp.float64(loss_new))
        return up, down

    @wp.func(inline=True)
    def event_correct(
        x_window: wp.array3d(dtype=real),
        c: int,
        i: int,
        last: int,
        own_old: values_t,
        above_old: values_t,
        u_above: real,
        u_here: real,
        u_next: real,
        m_inv: real,
        h: real,
        half_h2_acc: real,
        static_overlap: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        law_parameters: wp.array(dtype=real),
    ):
        # kernels/step.py's event test and event step for grain i, on the same data: its corrector, or its event step
        # when a contact of it is near opening or closing
        below = values_t()
        has_below = wp.static(BOTTOM_WALL)
        if i < last:
            below = nordsieck.load(x_window, c, i + 1)
            has_below = True
        has_above = wp.static(SURFACE_WALL)
        if i > 0:
            has_above = True
        p_above = params(static_overlap, contact_constant, law_parameters, c, i)
        p_below = params(static_overlap, contact_constant, law_parameters, c, i + 1)
        flagged = False
        if has_above:
            flagged = near_event(
                p_above[0] + (above_old[0] - own_old[0]),
                p_above[0] + (u_above - u_here),
                above_old[1] - own_old[1],
                h,
            )
        if has_below:
            flagged = flagged or near_event(
                p_below[0] + (own_old[0] - below[0]),
                p_below[0] + (u_here - u_next),
                own_old[1] - below[1],
                h,
            )
        if flagged:
            nordsieck.store(
                x_window,
                c,
                i,
                event_step(own_old, above_old, below, has_above, has_below, p_above, p_below, m_inv, h),
            )
        else:
            correct(x_window, x_window, c, i, u_here, half_h2_acc)

    return SimpleNamespace(
        contact=contact,
        chain_shape=chain_shape,
        driver_values=driver_values,
        write_traces=write_traces,
        copy_grains=copy_grains,
        exchange=exchange,
        damped_forces=damped_forces,
        event_correct=event_correct,
    )


def launch_chain(
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
    damping,
    dissipated,
    traced_grain,
    trace_stride: int,
    trace_x,
    chains: tuple[int, int] | None = None,
    window: tuple[int, int, int, int] | None = None,
    x_window=None,
    exchange_every: int = 1 << 30,
    barrier_state=None,
    parties: int = 1,
    patience: int = BARRIER_SPIN_LIMIT,
):
    """Launch ``steps`` steps of the chain kernel for chains ``chains = (first, end)`` (default: all), one
    kernel thread per chain.

    Warp runs a CPU launch on one OS thread and releases Python's GIL while it runs, so launches over
    disjoint chain ranges may run at once from several Python threads (ensemble/core/solvers/chain.py): each
    chain is integrated by one thread with the same arithmetic, so the split changes no bit.
    ``drive`` (chains, 2), ``work_*``/``power_*`` (chains,): the model's and states' arrays (size 0 undriven);
    ``damping`` (chains,) γ and ``dissipated`` (chains, grains), updated in place (size 0 undamped);
    ``traced_grain`` (traced,), ``trace_stride`` and the ring ``trace_x`` (2, chains, length, traced): traces
    (unused, size 0, without them).

    ``window = (lo, hi, own_lo, own_hi)`` with ``x_window`` (an array shaped as ``x_out``, this launch's own) sweeps
    only grains [lo, hi) in ``x_window`` and writes grains [own_lo, own_hi) to ``x_out``. An error from a cut end of
    [lo, hi) travels one grain a pass (a step, or a substep of a composed method), so with ``lo − own_lo`` and
    ``hi − own_hi`` at least ``exchange_every`` where there is a cut, ``parties`` such launches running at once on
    as many threads, one per window, exchange the grains next to their cuts every ``exchange_every`` passes
    (through ``x_out``, two :func:`hertzian.kernels.threads.barrier` waits on ``barrier_state``, each giving up after
    ``patience`` spins) and together take
    the steps of the whole chain (:class:`hertzian.core.solvers.chain.ChainSolver`). Default: the whole chain, swept
    in ``x_out``."""
    first, end = chains if chains is not None else (0, x_in.shape[1])
    grains = x_in.shape[2]
    if window is None:
        window, x_window = (0, grains, 0, grains), x_out
    wp.launch(
        kernel,
        dim=end - first,
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
            drive,
            work_in,
            power_in,
        ],
        outputs=[
            x_out,
            clock_out,
            work_out,
            power_out,
            damping,
            dissipated,
            traced_grain,
            trace_stride,
            trace_x,
            first,
            wp.vec4i(*window),
            x_window,
            exchange_every,
            barrier_state,
            parties,
            wp.int64(patience),
        ],
        device=device,
    )
