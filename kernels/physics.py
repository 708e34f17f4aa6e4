"""Contact-law helpers as ``@wp.func`` (docs/model.md §1): V(δ) = a·max(δ,0)^n, F = n·a·max(δ,0)^(n−1).

The step kernels work with *excess* forces relative to the static state,
``F(δ0 + d) − F(δ0)``: in exact arithmetic this is the full equation of motion (the
static forces, gravity and a surface load cancel by the sum rule, paper eq. 4), and in
floating point a scene without excitation stays exactly at rest.
"""

import functools

import warp as wp

# The fast path of the CUDA compiler's correctly rounded float64 sqrt (sqrt.rn.f64 on sm_90), written
# out so that a lane's G + 1 square roots carry no branch each: one test for the rare inputs that need
# the slow path (zero, subnormal, huge, negative, inf/nan), which then take wp.sqrt. In range it is the
# same instruction sequence, hence the same bits; tests/kernels/test_tile.py and the GPU bench check this.
_SQRT_FAST_PATH = """
#if defined(__CUDA_ARCH__)
    double y0_hi;
    asm("rsqrt.approx.ftz.f64 %0, %1;" : "=d"(y0_hi) : "d"(x));
    const double y0 = __hiloint2double(__double2hiint(y0_hi), __double2hiint(x) - 0x3500000);
    const double e = __fma_rn(-__dmul_rn(y0, y0), x, 1.0);
    const double p = __fma_rn(e, 0.375, 0.5);
    const double y1 = __fma_rn(p, __dmul_rn(y0, e), y0);
    const double s = __dmul_rn(y1, x);
    const double h = __hiloint2double(__double2hiint(y1) - 0x100000, __double2loint(y1));
    return __fma_rn(__fma_rn(s, -s, x), h, s);
#else
    return sqrt(x);
#endif
"""

_SQRT_NEEDS_SLOW_PATH = """
#if defined(__CUDA_ARCH__)
    return ((unsigned int)(__double2hiint(x) - 0x3500000) >= 0x7ca00000u) ? 1 : 0;
#else
    return 0;
#endif
"""


# a·b rounded as a product on CUDA (__dmul_rn is never contracted into a fused multiply-add): the driver's
# displacement A·sin ωt, which the kernels then subtract or split into float32 parts, has the same bits in every
# kernel whatever contractions each compiler chooses around it
_PRODUCT_RN = """
#if defined(__CUDA_ARCH__)
    return __dmul_rn(a, b);
#else
    return a * b;
#endif
"""


@wp.func_native(_PRODUCT_RN)
def product_rn(a: wp.float64, b: wp.float64) -> wp.float64: ...


@wp.func_native(_SQRT_FAST_PATH)
def sqrt_fast_path(x: wp.float64) -> wp.float64: ...


@wp.func_native(_SQRT_NEEDS_SLOW_PATH)
def sqrt_needs_slow_path(x: wp.float64) -> int: ...


LJ_MINIMUM = 2.0 ** (1.0 / 6.0)
"""ρ_e/σ: the Lennard-Jones pair at rest sits at the potential's minimum, ρ_e = 2^(1/6)·σ."""


@functools.cache
def expm1_function(precision: str):
    """``expm1(x) -> e^x − 1`` without the cancellation of ``exp(x) − 1`` near 0 (Kahan's form (u − 1)·x / log u,
    a few ulps; Warp has no expm1)."""
    real = wp.float64 if precision == "float64" else wp.float32

    @wp.func
    def expm1(x: real) -> real:
        u = wp.exp(x)
        if u == real(1) or wp.abs(x) > real(0.5):
            if u == real(1):
                return x
            return u - real(1)
        return (u - real(1)) * x / wp.log(u)

    return expm1


@functools.cache
def contact_functions(precision: str, hertz: bool, potential: str = "hertz"):
    """(force, excess_force) for one precision and contact law (docs/model.md §1, docs/lattices.md).

    hertz: the power law without tension, ``force(δ, a_c, n)``; ``hertz`` uses δ·sqrt(δ) instead of pow. A lattice
    law takes its per-chain shape as a vec2 ``p`` (``contact_parameters``' ``shape``): with δ the compression and
    a = a_c its strength,

    * harmonic: F = a·δ;
    * fput: F = a·(δ − α δ² + β δ³), p = (α, β) (V = a(δ²/2 − αδ³/3 + βδ⁴/4): the FPUT V(r) at r = −δ);
    * toda: F = a·(e^{bδ} − 1), p = (b, ·);
    * morse: F = 2 a α (e^{2αδ} − e^{αδ}), p = (α, ·) (a is the well depth D);
    * lj: F = (24 a / ρ)(2 (σ/ρ)^12 − (σ/ρ)^6) at the distance ρ = 2^(1/6) σ − δ, p = (σ, ·) (a is ε).

    ``excess_force(δ0, d, a, p) = F(δ0 + d) − F(δ0)``, the difference itself, as for Hertz: every kernel (per-step,
    CPU chain, fused) computes it alike, and at δ0 = 0 it is F(d) exactly (F(0) = 0 for every law but lj, where the
    difference removes F's rounding at its minimum).
    """
    real = wp.float64 if precision == "float64" else wp.float32
    if potential == "hertz":

        @wp.func
        def contact_force(delta: real, a_c: real, n: real) -> real:
            if delta <= real(0):
                return real(0)  # no tension
            if wp.static(hertz):
                return real(5) / real(2) * a_c * delta * wp.sqrt(delta)
            else:
                return n * a_c * wp.pow(delta, n - real(1))

        @wp.func
        def excess_force(delta0: real, d: real, a_c: real, n: real) -> real:
            return contact_force(delta0 + d, a_c, n) - contact_force(delta0, a_c, n)

        return contact_force, excess_force
    return _lattice_functions(precision, potential)


@functools.cache
def _lattice_functions(precision: str, potential: str):
    """contact_functions of a lattice law (cached)."""
    real = wp.float64 if precision == "float64" else wp.float32
    vec2 = wp.types.vector(2, real)
    expm1 = expm1_function(precision)
    LAW = LATTICE_INDEX[potential]

    @wp.func
    def contact_force(delta: real, a_c: real, p: vec2) -> real:
        out = real(0)
        if wp.static(LAW == 0):  # fput
            out = a_c * delta * (real(1) - p[0] * delta + p[1] * delta * delta)
        elif wp.static(LAW == 1):  # toda
            out = a_c * expm1(p[0] * delta)
        elif wp.static(LAW == 2):  # morse
            t = wp.exp(p[0] * delta)
            out = real(2) * a_c * p[0] * t * (t - real(1))
        elif wp.static(LAW == 3):  # lj
            rho = real(wp.static(LJ_MINIMUM)) * p[0] - delta
            s2 = (p[0] / rho) * (p[0] / rho)
            s6 = s2 * s2 * s2
            out = real(24) * a_c / rho * (real(2) * s6 * s6 - s6)
        else:  # harmonic
            out = a_c * delta
        return out

    @wp.func
    def excess_force(delta0: real, d: real, a_c: real, p: vec2) -> real:
        return contact_force(delta0 + d, a_c, p) - contact_force(delta0, a_c, p)

    return contact_force, excess_force


LATTICE_INDEX = {"fput": 0, "toda": 1, "morse": 2, "lj": 3, "harmonic": 4}
"""The branch of each lattice law in the generated code (only its own is compiled)."""


@functools.cache
def contact_forces(precision: str, hertz: bool, count: int, potential: str = "hertz"):
    """``forces(delta, a_c, force0, n) -> F(delta) − force0`` over a vector of ``count`` contacts.

    The fused kernel's form of the contact law (one lane's contacts at once). Hertz: the square root of a
    safe argument, then a select, instead of a branch per contact (the same bits as :func:`contact_functions`'
    ``contact_force``, more instruction-level parallelism); in float64, on CUDA, the sqrt's fast path with one
    slow-path test for all ``count`` contacts (same bits again). Other exponents and the lattice laws (``n`` then
    their vec2 shape): ``contact_force`` per contact.
    """
    real = wp.float64 if precision == "float64" else wp.float32
    contact_vec = wp.types.vector(length=count, dtype=real)
    LATTICE = potential != "hertz"
    BRANCHLESS = hertz and not LATTICE
    FAST_SQRT = BRANCHLESS and precision == "float64"
    contact_force, _ = contact_functions(precision, hertz, potential)
    shape_t = wp.types.vector(2, real) if LATTICE else real

    @wp.func
    def forces(delta: contact_vec, a_c: contact_vec, force0: contact_vec, n: shape_t) -> contact_vec:
        force = contact_vec()
        if wp.static(BRANCHLESS):
            # F = 5/2 a δ sqrt(δ), 0 for δ ≤ 0 (no tension), without a branch per contact
            root = contact_vec()
            slow = int(0)
            for k in range(wp.static(count)):
                safe = wp.where(delta[k] <= real(0), real(1), delta[k])
                if wp.static(FAST_SQRT):
                    root[k] = sqrt_fast_path(safe)
                    slow = slow | sqrt_needs_slow_path(safe)
                else:
                    root[k] = wp.sqrt(safe)
            if wp.static(FAST_SQRT):
                if slow != 0:
                    for k in range(wp.static(count)):
                        root[k] = wp.sqrt(wp.where(delta[k] <= real(0), real(1), delta[k]))
            for k in range(wp.static(count)):
                hertz_force = real(5) / real(2) * a_c[k] * delta[k] * root[k]
                force[k] = wp.where(delta[k] <= real(0), real(0), hertz_force) - force0[k]
        else:
            for k in range(wp.static(count)):
                force[k] = contact_force(delta[k], a_c[k], n) - force0[k]
        return force

    return forces


@functools.cache
def damping_functions(precision: str, order: int):
    """``(predicted_rate, dashpot)`` ``@wp.func``s of the damped kernels (per-step and CPU chain kernel), cached.

    ``predicted_rate(x, c, j)``: dt·v of grain j predicted at t + dt from its Nordsieck vector of ``order``
    rows, Σ_q q·x_q (Verlet: x1 + 2·x2). ``dashpot(delta0, d, rate, gamma, h)``: the dashpot force γ·δ̇ of a
    contact (rate = dt·δ̇), only while it is closed (δ0 + d > 0).
    """
    real = wp.float64 if precision == "float64" else wp.float32

    @wp.func
    def predicted_rate(x: wp.array3d(dtype=real), c: int, j: int) -> real:
        rate = x[1, c, j] + real(2) * x[2, c, j]
        if wp.static(order >= 4):
            rate += real(3) * x[3, c, j]
        if wp.static(order >= 5):
            rate += real(4) * x[4, c, j]
        if wp.static(order >= 6):
            rate += real(5) * x[5, c, j]
        return rate

    @wp.func
    def dashpot(delta0: real, d: real, rate: real, gamma: real, h: real) -> real:
        out = real(0)
        if delta0 + d > real(0):
            out = gamma * rate / h
        return out

    return predicted_rate, dashpot


@functools.cache
def loss_functions(precision: str, order: int):
    """``(viscous_losses, dashpot_losses)`` ``@wp.func``s: the damping forces and dissipated powers of one grain that
    the per-step and CPU chain kernels share, on values each kernel gathers its own way (cached).

    ``viscous_losses(gamma, inv_m, rate, rate_old, h) -> (P(t_n), P(t_n+1))``: the grain's power γ m v² at t_n and at
    the predicted t_n+1 (rates are dt·v). ``dashpot_losses(delta0, d, d_old, rate, rate_old, gamma, h) -> (F, P,
    P(t_n))``: the dashpot of one contact, its force at the predicted t_n+1 and its power there and at t_n, from the
    relative displacement d and relative rate (dt·δ̇) at both times (a grain that does not count the contact's loss
    takes its force from ``dashpot`` alone).
    """
    real = wp.float64 if precision == "float64" else wp.float32
    vec2 = wp.types.vector(2, real)
    vec3 = wp.types.vector(3, real)
    _, dashpot = damping_functions(precision, order)

    @wp.func
    def viscous_losses(gamma: real, inv_m: real, rate: real, rate_old: real, h: real) -> vec2:
        m_i = real(1) / inv_m
        return vec2(gamma * m_i * rate_old * rate_old / (h * h), gamma * m_i * rate * rate / (h * h))

    @wp.func
    def dashpot_losses(delta0: real, d: real, d_old: real, rate: real, rate_old: real, gamma: real, h: real) -> vec3:
        force = dashpot(delta0, d, rate, gamma, h)
        return vec3(force, force * rate / h, dashpot(delta0, d_old, rate_old, gamma, h) * rate_old / h)

    return viscous_losses, dashpot_losses


@functools.cache
def contact_parameters(precision: str, static: str, heterogeneous: bool, hertz: bool, potential: str = "hertz"):
    """``params(static_overlap, contact_constant, law_parameters, c, k) -> (δ0, a_c, n)`` of padded contact k.

    Reads only the arrays the features use: one δ0 per contact ('profile') or per chain
    ('uniform') or none; a_c per contact (impurities) or per chain; n per chain or 5/2. A lattice law
    (``potential`` other than hertz) returns (δ0, a_c, p0, p1), its two per-chain shape parameters
    (``law_parameters[2c]``, ``[2c + 1]``); :func:`shape_function` picks the law's shape out of either.
    """
    real = wp.float64 if precision == "float64" else wp.float32
    vec3 = wp.types.vector(3, real)
    vec4 = wp.types.vector(4, real)
    vec2 = wp.types.vector(2, real)
    STATIC, PROFILE = static != "none", static == "profile"
    LATTICE = potential != "hertz"

    @wp.func
    def overlap_and_constant(
        static_overlap: wp.array2d(dtype=real), contact_constant: wp.array2d(dtype=real), c: int, k: int
    ) -> vec2:
        delta0 = real(0)
        if wp.static(PROFILE):
            delta0 = static_overlap[c, k]
        elif wp.static(STATIC):
            delta0 = static_overlap[c, 0]
        a_c = real(0)
        if wp.static(heterogeneous):
            a_c = contact_constant[c, k]
        else:
            a_c = contact_constant[c, 0]
        return vec2(delta0, a_c)

    if LATTICE:

        @wp.func
        def params(
            static_overlap: wp.array2d(dtype=real),
            contact_constant: wp.array2d(dtype=real),
            law_parameters: wp.array(dtype=real),
            c: int,
            k: int,
        ) -> vec4:
            both = overlap_and_constant(static_overlap, contact_constant, c, k)
            return vec4(both[0], both[1], law_parameters[2 * c], law_parameters[2 * c + 1])

        return params

    @wp.func
    def params(
        static_overlap: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        law_parameters: wp.array(dtype=real),
        c: int,
        k: int,
    ) -> vec3:
        delta0 = real(0)
        if wp.static(PROFILE):
            delta0 = static_overlap[c, k]
        elif wp.static(STATIC):
            delta0 = static_overlap[c, 0]
        a_c = real(0)
        if wp.static(heterogeneous):
            a_c = contact_constant[c, k]
        else:
            a_c = contact_constant[c, 0]
        n = real(5) / real(2)
        if wp.static(not hertz):
            n = law_parameters[c]
        return vec3(delta0, a_c, n)

    return params


@functools.cache
def shape_function(precision: str, potential: str = "hertz"):
    """``shape(p)``: the law's shape out of ``params``' vector, what ``contact_functions``' forces take: n
    (hertz) or the vec2 (p0, p1) of a lattice law. ``chain_shape(law_parameters, c)`` reads chain c's."""
    real = wp.float64 if precision == "float64" else wp.float32
    vec2 = wp.types.vector(2, real)
    if potential == "hertz":

        @wp.func
        def shape(p: wp.types.vector(3, real)) -> real:
            return p[2]

        return shape

    @wp.func
    def shape(p: wp.types.vector(4, real)) -> vec2:
        return vec2(p[2], p[3])

    return shape


@wp.func
def contact_potential(delta: wp.float64, a_c: wp.float64, n: wp.float64) -> wp.float64:
    if delta <= wp.float64(0.0):
        return wp.float64(0.0)
    return a_c * wp.pow(delta, n)


@wp.func
def excess_potential(delta0: wp.float64, d: wp.float64, a_c: wp.float64, n: wp.float64) -> wp.float64:
    # V(δ0 + d) − V(δ0) − V'(δ0)·d, computed without the cancellation of the naive form:
    # for |d/δ0| small a binomial series, so that deep in a compressed column (V(δ0) ≫ the
    # pulse energy) the energy error is not swamped by rounding of V(δ0).
    if delta0 <= wp.float64(0.0):
        return contact_potential(d, a_c, n)
    if delta0 + d <= wp.float64(0.0):
        return -a_c * wp.pow(delta0, n) - n * a_c * wp.pow(delta0, n - wp.float64(1.0)) * d
    r = d / delta0
    scale = a_c * wp.pow(delta0, n)
    if wp.abs(r) < wp.float64(0.05):
        term = n * (n - wp.float64(1.0)) / wp.float64(2.0) * r * r
        total = term
        for k in range(3, 16):
            kf = wp.float64(k)
            term = term * (n - kf + wp.float64(1.0)) / kf * r
            total = total + term
        return scale * total
    return scale * (wp.pow(wp.float64(1.0) + r, n) - wp.float64(1.0) - n * r)


@functools.cache
def lattice_excess_potential(potential: str):
    """``excess(δ0, d, a, p) -> V(δ0 + d) − V(δ0) − F(δ0)·d`` of a lattice law in float64 (the record kernels' energy
    relative to the static state; laws as in ``contact_functions``), written without the cancellation of that
    difference where the law allows it: with ε(x) = e^x − 1 − x,

    * harmonic: a d²/2;  fput: a (d²/2 − α(δ0 d² + d³/3) + β(3/2 δ0² d² + δ0 d³ + d⁴/4));
    * toda: (a/b) e^{bδ0} ε(bd);  morse: a (e^{2αδ0} ε(2αd) − 2 e^{αδ0} ε(αd));
    * lj: the difference itself, V(ρ) = 4a((σ/ρ)^12 − (σ/ρ)^6) + a.
    """
    LAW = LATTICE_INDEX[potential]
    real = wp.float64
    force, _ = contact_functions("float64", False, potential)
    expm1 = expm1_function("float64")

    @wp.func
    def exp_excess(x: real) -> real:
        # e^x − 1 − x: its series where the subtraction would cancel
        if wp.abs(x) < real(0.1):
            term = x * x / real(2)
            total = term
            for k in range(3, 14):
                term = term * x / real(k)
                total = total + term
            return total
        return expm1(x) - x

    @wp.func
    def lj_potential(delta: real, a_c: real, sigma: real) -> real:
        rho = real(wp.static(LJ_MINIMUM)) * sigma - delta
        s2 = (sigma / rho) * (sigma / rho)
        s6 = s2 * s2 * s2
        return real(4) * a_c * (s6 * s6 - s6) + a_c

    @wp.func
    def excess(delta0: real, d: real, a_c: real, p: wp.vec2d) -> real:
        out = real(0)
        if wp.static(LAW == 0):
            d2 = d * d
            out = a_c * (
                d2 / real(2)
                - p[0] * (delta0 * d2 + d2 * d / real(3))
                + p[1] * (real(1.5) * delta0 * delta0 * d2 + delta0 * d2 * d + d2 * d2 / real(4))
            )
        elif wp.static(LAW == 1):
            out = a_c / p[0] * wp.exp(p[0] * delta0) * exp_excess(p[0] * d)
        elif wp.static(LAW == 2):
            t0 = wp.exp(p[0] * delta0)
            out = a_c * (t0 * t0 * exp_excess(real(2) * p[0] * d) - real(2) * t0 * exp_excess(p[0] * d))
        elif wp.static(LAW == 3):
            out = lj_potential(delta0 + d, a_c, p[0]) - lj_potential(delta0, a_c, p[0]) - force(delta0, a_c, p) * d
        else:
            out = a_c * d * d / real(2)
        return out

    return excess


@functools.cache
def contact_derivatives(precision: str, hertz: bool):
    """``derivatives(delta, a_c, n) -> vec2(F'(δ), F''(δ))`` of F = n·a·max(δ,0)^(n−1); 0 for δ ≤ 0.

    Used by event-aware steps (kernels/events.py) to restart a grain's Nordsieck vector from its
    exact derivatives: ȧ = Σ ±F'·δ̇/m, ä = Σ ±(F''·δ̇² + F'·δ̈)/m. F'' is singular at δ → 0⁺ for
    Hertz (n − 3 < 0); the restart only happens away from δ = 0 (see kernels/events.py).
    """
    real = wp.float64 if precision == "float64" else wp.float32
    vec2 = wp.types.vector(2, real)

    @wp.func
    def derivatives(delta: real, a_c: real, n: real) -> vec2:
        if delta <= real(0):
            return vec2(real(0), real(0))
        if wp.static(hertz):
            root = wp.sqrt(delta)
            return vec2(real(15) / real(4) * a_c * root, real(15) / real(8) * a_c / root)
        else:
            first = n * (n - real(1)) * a_c * wp.pow(delta, n - real(2))
            return vec2(first, first * (n - real(2)) / delta)

    return derivatives
