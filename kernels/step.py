"""One integration step per launch over a (chain, grain) grid: Gear predictor–corrector or velocity Verlet.

State per grain is a scaled Nordsieck vector in an array of shape (values, chains, grains):
x0 = u, x1 = dt·v, x2 = dt²/2·a, x3 = dt³/6·ȧ, …  (Verlet keeps x0, x1, x2 the same way).
A step reads ``x_in`` and writes ``x_out`` (never the same buffer): each thread predicts its own
grain and both neighbours, evaluates the force at the predicted positions, and corrects.

A composed method (yoshida4, ``SUBSTEP_WEIGHTS``) takes one velocity-Verlet substep of w·dt per launch:
``substep`` (0, 1, 2) selects w; the clock advances and traces are written only by the last substep of a
step, so records and checks between launches of whole steps see whole steps only.
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
    shape_function,
)


@functools.cache
def step_kernel(features: Features):
    """The step kernel for one feature set (cached; a feature that is off generates no code)."""
    layout = _step_layout(features)
    functions = _step_functions(layout)
    real, Q, SURFACE_WALL, DRIVEN, BOTTOM_WALL, FIXED = take(layout, "real Q SURFACE_WALL DRIVEN BOTTOM_WALL FIXED")
    HETERO, params, nordsieck, correct, predicted_at = take(layout, "HETERO params nordsieck correct predicted_at")
    rounded, EVENTS, values_t, near_event, event_step = take(layout, "rounded EVENTS values_t near_event event_step")
    DAMPED, VISCOUS, predicted_rate, driver_values = take(layout, "DAMPED VISCOUS predicted_rate driver_values")
    COMPOSED, LAST_SUBSTEP, substep_predicted_at = take(layout, "COMPOSED LAST_SUBSTEP substep_predicted_at")
    substep_correct, substep_weight = take(layout, "substep_correct substep_weight")
    write_trace, driven_grain, contact_forces = take(functions, "write_trace driven_grain contact_forces")
    (damped_forces,) = take(functions, "damped_forces")

    # grid_stride=False: one thread per (chain, grain), no grid-stride loop (less index work per thread)
    @wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False, grid_stride=False)
    def step(
        x_in: wp.array3d(dtype=real),
        clock_in: wp.array(dtype=wp.int32),
        inverse_mass: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        static_overlap: wp.array2d(dtype=real),
        law_parameters: wp.array(dtype=real),
        drive: wp.array2d(dtype=wp.float64),
        status: wp.array(dtype=wp.int32),
        trace_slot: wp.array(dtype=wp.int32),
        trace_stride: int,
        work_in: wp.array(dtype=wp.float64),
        power_in: wp.array(dtype=wp.float64),
        dt: wp.float64,
        substep: int,
        x_out: wp.array3d(dtype=real),
        clock_out: wp.array(dtype=wp.int32),
        trace_x: wp.array4d(dtype=real),
        work_out: wp.array(dtype=wp.float64),
        power_out: wp.array(dtype=wp.float64),
        damping: wp.array(dtype=real),
        dissipated: wp.array2d(dtype=wp.float64),
    ):
        c, i = wp.tid()
        n_grains = x_in.shape[2]
        step_new = clock_in[0] + 1
        ends_step = True  # a composed method's step ends with its last substep
        if wp.static(COMPOSED):
            ends_step = substep == wp.static(LAST_SUBSTEP)
            if not ends_step:
                step_new = clock_in[0]
        if c == 0 and i == 0:
            clock_out[0] = step_new
        h = real(dt)
        w = substep_weight(substep)

        frozen = status[c] == wp.static(STATUS_NON_FINITE)
        held = frozen
        if wp.static(FIXED):
            held = held or i == n_grains - 1
        if held:
            # a blown-up chain is frozen; a fixed bottom grain never moves
            for k in range(wp.static(Q)):
                x_out[k, c, i] = x_in[k, c, i]
            if ends_step:
                write_trace(trace_x, trace_slot, trace_stride, c, i, step_new, x_in[0, c, i], x_in[1, c, i])
            return

        amplitude = wp.float64(0)  # a driven surface: the driver's amplitude, ω, t_n+1 and u_0(t_n+1)
        omega = wp.float64(0)
        t_new = wp.float64(0)
        u_drive = wp.float64(0)
        if wp.static(DRIVEN):
            amplitude = drive[c, 0]
            omega = drive[c, 1]
            t_new = wp.float64(step_new) * dt
            u_drive = product_rn(amplitude, wp.sin(omega * t_new))
            if i == 0:
                driven_grain(
                    x_in,
                    static_overlap,
                    contact_constant,
                    law_parameters,
                    c,
                    i,
                    step_new,
                    dt,
                    h,
                    amplitude,
                    omega,
                    t_new,
                    u_drive,
                    damping,
                    work_in,
                    power_in,
                    work_out,
                    power_out,
                    x_out,
                    trace_x,
                    trace_slot,
                    trace_stride,
                )
                return

        # compensated float32: positions as (hi, lo) for the contacts (kernels/gear.py)
        if wp.static(COMPOSED):
            position_p = substep_predicted_at(x_in, c, i, w)
        else:
            position_p = predicted_at(x_in, c, i)
        u_p = rounded(position_p)
        if wp.static(EVENTS):
            # a grain touching a contact near an opening or closing takes an event step (kernels/events.py)
            own = nordsieck.load(x_in, c, i)
            above = values_t()
            below = values_t()
            u_above_p = real(0)
            u_below_p = real(0)
            has_above = False
            has_below = False
            if i > 0:
                has_above = True
                if wp.static(DRIVEN):
                    if i == 1:
                        above = driver_values(amplitude, omega, wp.float64(step_new - 1) * dt, dt)
                        u_above_p = real(u_drive)
                    else:
                        above = nordsieck.load(x_in, c, i - 1)
                        u_above_p = nordsieck.predict_position(above)
                else:
                    above = nordsieck.load(x_in, c, i - 1)
                    u_above_p = nordsieck.predict_position(above)
            else:
                has_above = wp.static(SURFACE_WALL)
            if i < n_grains - 1:
                has_below = True
                below = nordsieck.load(x_in, c, i + 1)
                u_below_p = nordsieck.predict_position(below)
            else:
                has_below = wp.static(BOTTOM_WALL)
            p_above = params(static_overlap, contact_constant, law_parameters, c, i)
            p_below = params(static_overlap, contact_constant, law_parameters, c, i + 1)
            flagged = False
            if has_above:
                flagged = near_event(
                    p_above[0] + (above[0] - own[0]), p_above[0] + (u_above_p - u_p), above[1] - own[1], h
                )
            if has_below:
                flagged = flagged or near_event(
                    p_below[0] + (own[0] - below[0]), p_below[0] + (u_p - u_below_p), own[1] - below[1], h
                )
            if flagged:
                inv_m_event = real(0)
                if wp.static(HETERO):
                    inv_m_event = inverse_mass[c, i]
                else:
                    inv_m_event = inverse_mass[c, 0]
                new_values = event_step(own, above, below, has_above, has_below, p_above, p_below, inv_m_event, h)
                nordsieck.store(x_out, c, i, new_values)
                write_trace(trace_x, trace_slot, trace_stride, c, i, step_new, new_values[0], new_values[1])
                return
        up, down = contact_forces(
            x_in, static_overlap, contact_constant, law_parameters, c, i, n_grains, position_p, u_p, w, u_drive
        )
        inv_m = real(0)
        if wp.static(HETERO):
            inv_m = inverse_mass[c, i]
        else:
            inv_m = inverse_mass[c, 0]
        if wp.static(DAMPED):
            up, down = damped_forces(
                up,
                down,
                x_in,
                static_overlap,
                contact_constant,
                law_parameters,
                c,
                i,
                n_grains,
                u_p,
                inv_m,
                h,
                dt,
                step_new,
                amplitude,
                omega,
                t_new,
                u_drive,
                damping,
                dissipated,
            )
        half_h2_acc = real(0.5) * h * h * (up - down) * inv_m
        if wp.static(VISCOUS):
            half_h2_acc -= real(0.5) * h * damping[c] * predicted_rate(x_in, c, i)  # h²/2 · (−γ v)

        if wp.static(COMPOSED):
            new = substep_correct(x_in, x_out, c, i, u_p, half_h2_acc, w)
            if ends_step:
                write_trace(trace_x, trace_slot, trace_stride, c, i, step_new, new[0], new[1])
        else:
            new = correct(x_in, x_out, c, i, u_p, half_h2_acc)
            write_trace(trace_x, trace_slot, trace_stride, c, i, step_new, new[0], new[1])

    return step


def _step_layout(features: Features) -> SimpleNamespace:
    """The step kernel's compile-time constants and the device functions it takes from kernels/gear.py,
    kernels/physics.py and kernels/events.py, for one feature set."""
    f = features
    real = wp.float64 if f.precision == "float64" else wp.float32
    Q = f.values  # rows of the state (kernels/gear.py)
    ORDER = f.nordsieck_values  # of which the Nordsieck vector
    SURFACE_WALL = f.surface == "wall"
    DRIVEN = f.surface == "driven"
    BOTTOM_WALL = f.bottom == "wall"
    FIXED = f.bottom == "fixed"
    RING = f.surface == "periodic"  # grain N − 1 touches grain 0 (padded contacts 0 and N are that contact)
    HETERO = f.heterogeneous
    TRACES = f.traces
    _, excess_force = contact_functions(f.precision, f.hertz, f.potential)
    params = contact_parameters(f.precision, f.static, f.heterogeneous, f.hertz, f.potential)
    shape = shape_function(f.precision, f.potential)
    nordsieck = nordsieck_functions(f.method, f.precision, f.compensation)
    predicted_position, correct = nordsieck.predicted_position, nordsieck.correct
    predicted_at, gap, rounded = nordsieck.predicted_at, nordsieck.gap, nordsieck.rounded
    EVENTS = f.event_window > 0
    values_t = nordsieck.values
    position_t = nordsieck.position

    if EVENTS:
        near_event, event_step = event_functions(f)
    else:
        near_event = event_step = None
    DAMPED = f.damping != "none"
    VISCOUS = f.damping == "viscous"
    DASHPOT = f.damping == "contact"

    predicted_rate, dashpot = damping_functions(f.precision, ORDER)
    viscous_losses, dashpot_losses = loss_functions(f.precision, ORDER)

    driver_values = nordsieck.driver_values
    COMPOSED = f.method in SUBSTEP_WEIGHTS
    WEIGHTS = SUBSTEP_WEIGHTS.get(f.method, (1.0,))
    LAST_SUBSTEP = len(WEIGHTS) - 1
    refuse_composed_extras(f)
    substep_predicted_at, substep_correct = nordsieck.substep_predicted_at, nordsieck.substep_correct
    substep_weight = substep_weight_function(f.method, f.precision)
    return SimpleNamespace(**{name: value for name, value in locals().items() if name != "features"})


def _step_functions(layout: SimpleNamespace) -> SimpleNamespace:
    """The step kernel's own device functions: a contact's excess force, a trace sample, the driven grain 0 and the
    driver's work, the contact forces on a grain, and the damping forces and losses."""
    f, real, Q, SURFACE_WALL, DRIVEN, BOTTOM_WALL, RING = take(layout, "f real Q SURFACE_WALL DRIVEN BOTTOM_WALL RING")
    TRACES, excess_force, params, shape, nordsieck = take(layout, "TRACES excess_force params shape nordsieck")
    predicted_position, predicted_at, gap, position_t = take(layout, "predicted_position predicted_at gap position_t")
    VISCOUS, DASHPOT, predicted_rate, dashpot = take(layout, "VISCOUS DASHPOT predicted_rate dashpot")
    viscous_losses, dashpot_losses, COMPOSED = take(layout, "viscous_losses dashpot_losses COMPOSED")
    (substep_predicted_at,) = take(layout, "substep_predicted_at")

    @wp.func
    def contact(
        static_overlap: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        law_parameters: wp.array(dtype=real),
        c: int,
        k: int,
        d: real,
    ) -> real:
        # excess force of padded contact k (between grains k-1 and k) at relative displacement d
        p = params(static_overlap, contact_constant, law_parameters, c, k)
        return excess_force(p[0], d, p[1], shape(p))

    @wp.func
    def write_trace(
        trace_x: wp.array4d(dtype=real),
        trace_slot: wp.array(dtype=wp.int32),
        trace_stride: int,
        c: int,
        i: int,
        step_new: int,
        x0: real,
        x1: real,
    ):
        if wp.static(TRACES):
            slot = trace_slot[i]
            if slot >= 0 and step_new % trace_stride == 0:
                sample = (step_new / trace_stride) % trace_x.shape[2]
                trace_x[0, c, sample, slot] = x0
                trace_x[1, c, sample, slot] = x1

    @wp.func(inline=True)
    def driven_grain(
        x_in: wp.array3d(dtype=real),
        static_overlap: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        law_parameters: wp.array(dtype=real),
        c: int,
        i: int,
        step_new: int,
        dt: wp.float64,
        h: real,
        amplitude: wp.float64,
        omega: wp.float64,
        t_new: wp.float64,
        u_drive: wp.float64,
        damping: wp.array(dtype=real),
        work_in: wp.array(dtype=wp.float64),
        power_in: wp.array(dtype=wp.float64),
        work_out: wp.array(dtype=wp.float64),
        power_out: wp.array(dtype=wp.float64),
        x_out: wp.array3d(dtype=real),
        trace_x: wp.array4d(dtype=real),
        trace_slot: wp.array(dtype=wp.int32),
        trace_stride: int,
    ):
        # the prescribed grain 0: its (u_0, dt·v_0, 0, …) at t_n+1, and the driver's work on the rest of the chain,
        # the trapezoid of P = ΔF_01 · v_0 (state at t_n)
        # driver's work on the rest of the chain: trapezoid of P = ΔF_01 · v_0 (state at t_n)
        t_old = wp.float64(step_new - 1) * dt
        d_old = x_in[0, c, 0] - x_in[0, c, 1]
        force_old = wp.float64(contact(static_overlap, contact_constant, law_parameters, c, 1, d_old))
        if wp.static(DASHPOT):
            # the driver also pushes through the dashpot of its contact (work includes it)
            rate_old = real(dt * amplitude * omega * wp.cos(omega * t_old)) - x_in[1, c, 1]
            p01 = params(static_overlap, contact_constant, law_parameters, c, 1)
            force_old += wp.float64(dashpot(p01[0], d_old, rate_old, damping[c], h))
        power = force_old * amplitude * omega * wp.cos(omega * t_old)
        if wp.static(DASHPOT):
            if step_new == 1:
                work_out[c] = work_in[c]  # W(0) = 0: the dashpot's power at t = 0 is not zero
            else:
                work_out[c] = work_in[c] + dt * wp.float64(0.5) * (power_in[c] + power)
        else:
            work_out[c] = work_in[c] + dt * wp.float64(0.5) * (power_in[c] + power)
        power_out[c] = power
        x1_drive = real(dt * amplitude * omega * wp.cos(omega * t_new))
        x_out[0, c, 0] = real(u_drive)
        x_out[1, c, 0] = x1_drive
        for k in range(2, wp.static(Q)):
            x_out[k, c, 0] = real(0)
        write_trace(trace_x, trace_slot, trace_stride, c, i, step_new, real(u_drive), x1_drive)

    @wp.func(inline=True)
    def contact_forces(
        x_in: wp.array3d(dtype=real),
        static_overlap: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        law_parameters: wp.array(dtype=real),
        c: int,
        i: int,
        n_grains: int,
        position_p: position_t,
        u_p: real,
        w: real,
        u_drive: wp.float64,
    ):
        # the excess forces (up, down) of the contacts above and below grain i at the predicted positions (a wall,
        # the driver's prescribed grain 0, or a ring's closing contact at the ends)
        up = real(0)  # excess force of the contact above grain i (pushes it toward the bottom)
        down = real(0)  # excess force of the contact below grain i
        if i > 0:
            position_above = position_p
            if wp.static(DRIVEN):
                if i == 1:
                    position_above = nordsieck.exact_position(u_drive)
                else:
                    position_above = predicted_at(x_in, c, i - 1)
            else:
                if wp.static(COMPOSED):
                    position_above = substep_predicted_at(x_in, c, i - 1, w)
                else:
                    position_above = predicted_at(x_in, c, i - 1)
            up = contact(static_overlap, contact_constant, law_parameters, c, i, gap(position_above, position_p))
        else:
            if wp.static(SURFACE_WALL):
                if wp.static(f.compensation):
                    # a wall is a grain at rest at 0 (as the fused kernel's padding grains)
                    up = contact(
                        static_overlap,
                        contact_constant,
                        law_parameters,
                        c,
                        0,
                        gap(nordsieck.exact_position(wp.float64(0.0)), position_p),
                    )
                else:
                    up = contact(static_overlap, contact_constant, law_parameters, c, 0, -u_p)
            elif wp.static(RING):
                position_last = position_p
                if wp.static(COMPOSED):
                    position_last = substep_predicted_at(x_in, c, n_grains - 1, w)
                else:
                    position_last = predicted_at(x_in, c, n_grains - 1)
                up = contact(static_overlap, contact_constant, law_parameters, c, 0, gap(position_last, position_p))
        if i < n_grains - 1:
            position_below = position_p
            if wp.static(COMPOSED):
                position_below = substep_predicted_at(x_in, c, i + 1, w)
            else:
                position_below = predicted_at(x_in, c, i + 1)
            down = contact(static_overlap, contact_constant, law_parameters, c, i + 1, gap(position_p, position_below))
        else:
            if wp.static(BOTTOM_WALL):
                if wp.static(f.compensation):
                    down = contact(
                        static_overlap,
                        contact_constant,
                        law_parameters,
                        c,
                        n_grains,
                        gap(position_p, nordsieck.exact_position(wp.float64(0.0))),
                    )
                else:
                    down = contact(static_overlap, contact_constant, law_parameters, c, n_grains, u_p)
            elif wp.static(RING):
                position_first = position_p
                if wp.static(COMPOSED):
                    position_first = substep_predicted_at(x_in, c, 0, w)
                else:
                    position_first = predicted_at(x_in, c, 0)
                down = contact(
                    static_overlap, contact_constant, law_parameters, c, n_grains, gap(position_p, position_first)
                )
        return up, down

    @wp.func(inline=True)
    def damped_forces(
        up: real,
        down: real,
        x_in: wp.array3d(dtype=real),
        static_overlap: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        law_parameters: wp.array(dtype=real),
        c: int,
        i: int,
        n_grains: int,
        u_p: real,
        inv_m: real,
        h: real,
        dt: wp.float64,
        step_new: int,
        amplitude: wp.float64,
        omega: wp.float64,
        t_new: wp.float64,
        u_drive: wp.float64,
        damping: wp.array(dtype=real),
        dissipated: wp.array2d(dtype=wp.float64),
    ):
        # damping forces at the predicted velocities; the dissipated power's trapezoid (t_n exact,
        # t_n+1 predicted) is accumulated per grain: its own viscous loss, the dashpot of the contact
        # below it, and the one above where no integrated grain is above (wall, driver)
        gamma = damping[c]
        own_rate = predicted_rate(x_in, c, i)
        own_rate_old = x_in[1, c, i]
        loss_old = real(0)
        loss_new = real(0)
        if wp.static(VISCOUS):
            own_losses = viscous_losses(gamma, inv_m, own_rate, own_rate_old, h)
            loss_old = own_losses[0]
            loss_new = own_losses[1]
        if wp.static(DASHPOT):
            if i < n_grains - 1 or wp.static(BOTTOM_WALL):
                below_rate = real(0)
                below_rate_old = real(0)
                d_new = u_p
                d_old = x_in[0, c, i]
                if i < n_grains - 1:
                    below_rate = predicted_rate(x_in, c, i + 1)
                    below_rate_old = x_in[1, c, i + 1]
                    d_new = u_p - predicted_position(x_in, c, i + 1)
                    d_old = x_in[0, c, i] - x_in[0, c, i + 1]
                delta0_below = params(static_overlap, contact_constant, law_parameters, c, i + 1)[0]
                below_losses = dashpot_losses(
                    delta0_below,
                    d_new,
                    d_old,
                    own_rate - below_rate,
                    own_rate_old - below_rate_old,
                    gamma,
                    h,
                )
                down += below_losses[0]
                loss_new += below_losses[1]
                loss_old += below_losses[2]
            if i > 0 or wp.static(SURFACE_WALL):
                above_rate = real(0)
                above_rate_old = real(0)
                above_u = real(0)
                above_u_old = real(0)
                outer = i == 0  # the contact above belongs to no integrated grain above
                if i > 0:
                    above_u = predicted_position(x_in, c, i - 1)
                    above_u_old = x_in[0, c, i - 1]
                    above_rate = predicted_rate(x_in, c, i - 1)
                    above_rate_old = x_in[1, c, i - 1]
                    if wp.static(DRIVEN):
                        if i == 1:
                            outer = True
                            t_old_d = wp.float64(step_new - 1) * dt
                            above_u = real(u_drive)
                            above_u_old = real(product_rn(amplitude, wp.sin(omega * t_old_d)))
                            above_rate = real(dt * amplitude * omega * wp.cos(omega * t_new))
                            above_rate_old = real(dt * amplitude * omega * wp.cos(omega * t_old_d))
                delta0_above = params(static_overlap, contact_constant, law_parameters, c, i)[0]
                force_above_dashpot = dashpot(delta0_above, above_u - u_p, above_rate - own_rate, gamma, h)
                up += force_above_dashpot
                if outer:  # else the grain above counts this contact's loss as its own
                    above_losses = dashpot_losses(
                        delta0_above,
                        above_u - u_p,
                        above_u_old - x_in[0, c, i],
                        above_rate - own_rate,
                        above_rate_old - own_rate_old,
                        gamma,
                        h,
                    )
                    loss_new += above_losses[1]
                    loss_old += above_losses[2]
        dissipated[c, i] = dissipated[c, i] + dt * wp.float64(0.5) * (wp.float64(loss_old) + wp.float64(loss_new))
        return up, down

    return SimpleNamespace(
        contact=contact,
        write_trace=write_trace,
        driven_grain=driven_grain,
        contact_forces=contact_forces,
        damped_forces=damped_forces,
    )
