"""Event-aware Gear steps: a grain near a contact that opens or closes is stepped without the kink.

The Hertz force F ∝ max(δ, 0)^{3/2} is C¹ at δ = 0 and its higher derivatives are singular there.
A Gear step whose interval contains (or lies close to) an opening or a closing carries Nordsieck
derivatives from one side of the kink into the other, and its local error is O(dt^{3.5}) with a
constant that depends on where the event falls between the steps: convergence becomes erratic.

Here, per contact and step, an *event* is a contact whose overlap changes sign between t_n and the
predicted t_{n+1}, or whose overlap is within ``window`` (a fixed time, not a number of steps, so
that the treatment keeps the method's order) of zero at its current rate, |δ| < |δ̇|·window. A grain
that touches such a contact is stepped by

1. extracting (u, v) at t_n from its Nordsieck vector (for gear4 the velocity component carries
   Gear's steady-state term dt⁴/24·u⁗, which is removed);
2. integrating u'' = a(u, t) over the step with ``SUBSTEPS`` classical Runge–Kutta substeps, the
   neighbours following their own Nordsieck (Taylor) polynomials from t_n, a wall at rest, a driver
   its sine (the same data every kernel has at hand, so every kernel computes the same bits);
3. restarting the Nordsieck vector at t_{n+1} from the exact local derivatives a, ȧ, ä
   (kernels/physics.py ``contact_derivatives``), in the form Gear's corrector keeps in steady state
   (for gear4: x1 = dt·v + dt⁴/24·ä, x3 = dt³/6·ȧ − dt⁴/12·ä; gear5/6: x3 = dt³/6·ȧ, x4 = dt⁴/24·ä,
   x5 = 0), so the following ordinary steps see a consistent history.

Neighbours of a treated grain take an ordinary step with its predicted position; the treated grain
uses the neighbours' Taylor polynomials, so each thread needs only x at t_n (bitwise deterministic,
no ordering between threads).
"""

import functools

import warp as wp
from hertzian.kernels.features import GEAR_VALUES, Features
from hertzian.kernels.gear import two_sum_function
from hertzian.kernels.physics import contact_derivatives, contact_forces, contact_functions

SUBSTEPS = 8
"""Runge–Kutta substeps over a step near an event (the error of the event step falls as SUBSTEPS^-3.5)."""


@functools.cache
def event_functions(features: Features):
    """``(near_event, event_step)`` ``@wp.func``s for one feature set (cached); see the module docstring.

    ``near_event(delta_now, delta_pred, rate_h, h) -> bool``: the contact test; ``rate_h`` = dt·δ̇.
    ``event_step(own, above, below, has_above, has_below, p_above, p_below, inv_m, h) -> values``:
    the new Nordsieck vector of a grain (compensated float32: with the low parts of u and dt·v, the
    substeps accumulated as offsets from t_n's values); ``above``/``below`` are the neighbours' Nordsieck vectors at
    t_n (zeros for a wall), ``has_*`` False where the grain has no contact on that side, ``p_*`` the
    contacts' (δ0, a_c, n).
    """
    f = features
    real = wp.float64 if f.precision == "float64" else wp.float32
    Q = GEAR_VALUES[f.method]
    COMP = f.compensation  # float32: u and dt·v carried as hi + lo (kernels/gear.py), rows Q and Q + 1
    LO_U = Q
    LO_RATE = Q + 1
    values_t = wp.types.vector(f.values, real)
    two_sum = two_sum_function(f.precision)
    vec3 = wp.types.vector(3, real)
    vec2 = wp.types.vector(2, real)
    WINDOW = float(f.event_window)
    M = SUBSTEPS
    GEAR4 = Q == 4
    TOP = Q - 2  # Horner's loops below run over names and literals only, so that Warp unrolls them
    contact_force, excess_force = contact_functions(f.precision, f.hertz)
    # the two contacts' forces of a substep at once, branchless (float64 Hertz: the sqrt's fast path): the same bits
    # as excess_force's, with F(δ0) computed once an event step instead of once a force (kernels/physics.py)
    pair_forces = contact_forces(f.precision, f.hertz, 2)
    derivatives = contact_derivatives(f.precision, f.hertz)

    @wp.func
    def near_event(delta_now: real, delta_pred: real, rate_h: real, h: real) -> bool:
        # both halves evaluated, no branch (the fused kernels test every contact every step)
        crossed = (delta_now > real(0)) != (delta_pred > real(0))
        near = wp.abs(delta_now) * h < wp.abs(rate_h) * real(wp.static(WINDOW))
        return crossed or near

    @wp.func
    def taylor(x: values_t, tau: real) -> vec3:
        # (u, dt·u', dt²·u'') of a Nordsieck polynomial at t_n + tau·dt (Horner)
        u = x[Q - 1]
        du = real(Q - 1) * x[Q - 1]
        ddu = real((Q - 1) * (Q - 2)) * x[Q - 1]
        for j in range(TOP, -1, -1):
            u = u * tau + x[j]
        for j in range(TOP, 0, -1):
            du = du * tau + real(j) * x[j]
        for j in range(TOP, 1, -1):
            ddu = ddu * tau + real(j * (j - 1)) * x[j]
        return vec3(u, du, ddu)

    @wp.func
    def acceleration(
        u: real,
        u_above: real,
        u_below: real,
        has_above: bool,
        has_below: bool,
        p_above: vec3,
        p_below: vec3,
        force0: vec2,
        inv_m: real,
    ) -> real:
        # (F_above − F_below)/m in excess of the static forces ``force0`` = (F(δ0_above), F(δ0_below)); a contact the
        # grain lacks contributes 0 (computed and discarded: no branch)
        excess = pair_forces(
            vec2(p_above[0] + (u_above - u), p_below[0] + (u - u_below)),
            vec2(p_above[1], p_below[1]),
            force0,
            p_above[2],
        )
        up = wp.where(has_above, excess[0], real(0))
        down = wp.where(has_below, excess[1], real(0))
        return (up - down) * inv_m

    @wp.func
    def jerks(
        u: real,
        hv: real,
        hha: real,
        above: vec3,
        below: vec3,
        has_above: bool,
        has_below: bool,
        p_above: vec3,
        p_below: vec3,
        inv_m: real,
        hh: real,
    ) -> vec2:
        # (dt³·ȧ, dt⁴·ä) from (u, dt·v, dt²·a) of the grain and the neighbours' Taylor values
        j3 = real(0)
        j4 = real(0)
        if has_above:
            d = derivatives(p_above[0] + (above[0] - u), p_above[1], p_above[2])
            rate = above[1] - hv
            j3 += d[0] * rate
            j4 += d[1] * rate * rate + d[0] * (above[2] - hha)
        if has_below:
            d = derivatives(p_below[0] + (u - below[0]), p_below[1], p_below[2])
            rate = hv - below[1]
            j3 -= d[0] * rate
            j4 -= d[1] * rate * rate + d[0] * (hha - below[2])
        return vec2(hh * j3 * inv_m, hh * j4 * inv_m)

    @wp.func
    def event_step(
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
        hh = h * h
        force0 = vec2(
            contact_force(p_above[0], p_above[1], p_above[2]), contact_force(p_below[0], p_below[1], p_below[2])
        )
        u = own[0]
        hv = own[1]  # dt·v
        if wp.static(GEAR4):
            # remove Gear's steady-state term dt⁴/24·u⁗ from x1
            ta = taylor(above, real(0))
            tb = taylor(below, real(0))
            hha = hh * acceleration(u, ta[0], tb[0], has_above, has_below, p_above, p_below, force0, inv_m)
            j = jerks(u, hv, hha, ta, tb, has_above, has_below, p_above, p_below, inv_m, hh)
            hv = hv - j[1] / real(24)
        # classical Runge–Kutta in (u, dt·v) over M substeps of dt/M; time in units of dt
        s = real(1) / real(wp.static(M))
        m = int(0)
        while m < wp.static(M):  # a loop, not unrolled: the substeps' neighbour values are not all held at once
            mf = real(m)
            m += 1
            t0 = mf * s
            tm = (mf + real(0.5)) * s
            t1 = (mf + real(1)) * s
            k1u = hv
            k1v = hh * acceleration(
                u, taylor(above, t0)[0], taylor(below, t0)[0], has_above, has_below, p_above, p_below, force0, inv_m
            )
            u2 = u + real(0.5) * s * k1u
            k2u = hv + real(0.5) * s * k1v
            k2v = hh * acceleration(
                u2, taylor(above, tm)[0], taylor(below, tm)[0], has_above, has_below, p_above, p_below, force0, inv_m
            )
            u3 = u + real(0.5) * s * k2u
            k3u = hv + real(0.5) * s * k2v
            k3v = hh * acceleration(
                u3, taylor(above, tm)[0], taylor(below, tm)[0], has_above, has_below, p_above, p_below, force0, inv_m
            )
            u4 = u + s * k3u
            k4u = hv + s * k3v
            k4v = hh * acceleration(
                u4, taylor(above, t1)[0], taylor(below, t1)[0], has_above, has_below, p_above, p_below, force0, inv_m
            )
            u = u + s / real(6) * (k1u + real(2) * k2u + real(2) * k3u + k4u)
            hv = hv + s / real(6) * (k1v + real(2) * k2v + real(2) * k3v + k4v)
        # restart the Nordsieck vector from the exact derivatives at t_{n+1}
        ta = taylor(above, real(1))
        tb = taylor(below, real(1))
        hha = hh * acceleration(u, ta[0], tb[0], has_above, has_below, p_above, p_below, force0, inv_m)
        j = jerks(u, hv, hha, ta, tb, has_above, has_below, p_above, p_below, inv_m, hh)
        new = values_t()
        new[0] = u
        new[1] = hv
        new[2] = real(0.5) * hha
        new[3] = j[0] / real(6)
        if wp.static(GEAR4):
            new[1] = hv + j[1] / real(24)
            new[3] = j[0] / real(6) - j[1] / real(12)
        if wp.static(Q >= 5):
            new[4] = j[1] / real(24)
        return new

    @wp.func
    def offset(x: values_t, tau: real) -> real:
        # compensated: a Nordsieck polynomial at t_n + tau·dt minus its hi part x0 (Horner, low parts added)
        o = x[Q - 1]
        for j in range(TOP, 0, -1):
            o = o * tau + x[j]
        return o * tau + (x[wp.static(LO_RATE)] * tau + x[wp.static(LO_U)])

    @wp.func
    def acceleration_of_offset(
        u0: real,
        du: real,
        above: values_t,
        below: values_t,
        tau: real,
        has_above: bool,
        has_below: bool,
        p_above: vec3,
        p_below: vec3,
        inv_m: real,
    ) -> real:
        # acceleration() with the contacts' relative displacements formed as (hi − hi) + (offset − offset),
        # so that they keep their digits when u ≫ δ (kernels/gear.py gap)
        up = real(0)
        down = real(0)
        if has_above:
            up = excess_force(p_above[0], (above[0] - u0) + (offset(above, tau) - du), p_above[1], p_above[2])
        if has_below:
            down = excess_force(p_below[0], (u0 - below[0]) + (du - offset(below, tau)), p_below[1], p_below[2])
        return (up - down) * inv_m

    @wp.func
    def event_step_compensated(
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
        # event_step in compensated float32: u = u0 + du and dt·v = hv0 + dhv, the substeps' small
        # increments accumulated in the offsets (a plain float32 u would drop their low bits), the
        # forces from offsets (acceleration_of_offset), the offsets folded back into (hi, lo) by TwoSum
        hh = h * h
        u0 = own[0]
        hv0 = own[1]
        du = own[wp.static(LO_U)]
        dhv = own[wp.static(LO_RATE)]
        if wp.static(GEAR4):
            ta = taylor(above, real(0))
            tb = taylor(below, real(0))
            hha = hh * acceleration_of_offset(
                u0, du, above, below, real(0), has_above, has_below, p_above, p_below, inv_m
            )
            j = jerks(u0 + du, hv0 + dhv, hha, ta, tb, has_above, has_below, p_above, p_below, inv_m, hh)
            dhv = dhv - j[1] / real(24)
        s = real(1) / real(wp.static(M))
        for m in range(wp.static(M)):
            mf = real(m)
            t0 = mf * s
            tm = (mf + real(0.5)) * s
            t1 = (mf + real(1)) * s
            k1u = hv0 + dhv
            k1v = hh * acceleration_of_offset(u0, du, above, below, t0, has_above, has_below, p_above, p_below, inv_m)
            k2u = hv0 + (dhv + real(0.5) * s * k1v)
            k2v = hh * acceleration_of_offset(
                u0, du + real(0.5) * s * k1u, above, below, tm, has_above, has_below, p_above, p_below, inv_m
            )
            k3u = hv0 + (dhv + real(0.5) * s * k2v)
            k3v = hh * acceleration_of_offset(
                u0, du + real(0.5) * s * k2u, above, below, tm, has_above, has_below, p_above, p_below, inv_m
            )
            k4u = hv0 + (dhv + s * k3v)
            k4v = hh * acceleration_of_offset(
                u0, du + s * k3u, above, below, t1, has_above, has_below, p_above, p_below, inv_m
            )
            du = du + s / real(6) * (k1u + real(2) * k2u + real(2) * k3u + k4u)
            dhv = dhv + s / real(6) * (k1v + real(2) * k2v + real(2) * k3v + k4v)
        u = u0 + du
        hv = hv0 + dhv
        ta = taylor(above, real(1))
        tb = taylor(below, real(1))
        hha = hh * acceleration_of_offset(u0, du, above, below, real(1), has_above, has_below, p_above, p_below, inv_m)
        j = jerks(u, hv, hha, ta, tb, has_above, has_below, p_above, p_below, inv_m, hh)
        new = values_t()
        position = two_sum(u0, du)
        new[0] = position[0]
        new[wp.static(LO_U)] = position[1]
        rate_extra = real(0)
        if wp.static(GEAR4):
            rate_extra = j[1] / real(24)
        rate = two_sum(hv0, dhv + rate_extra)
        new[1] = rate[0]
        new[wp.static(LO_RATE)] = rate[1]
        new[2] = real(0.5) * hha
        new[3] = j[0] / real(6)
        if wp.static(GEAR4):
            new[3] = j[0] / real(6) - j[1] / real(12)
        if wp.static(Q >= 5):
            new[4] = j[1] / real(24)
        return new

    if COMP:
        return near_event, event_step_compensated
    return near_event, event_step
