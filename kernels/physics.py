"""Contact-law helpers as ``@wp.func`` (SPEC §1): V(δ) = a·max(δ,0)^n, F = n·a·max(δ,0)^(n−1).

The step kernels work with *excess* forces relative to the static state,
``F(δ0 + d) − F(δ0)``: in exact arithmetic this is the full equation of motion (the
static forces, gravity and a surface load cancel by the sum rule, paper eq. 4), and in
floating point a scene without excitation stays exactly at rest.
"""


import functools

import warp as wp


@functools.cache
def contact_functions(precision: str, hertz: bool):
    """(force, excess_force) for one precision; ``hertz`` uses δ·sqrt(δ) instead of pow."""
    real = wp.float64 if precision == "float64" else wp.float32

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


@functools.cache
def contact_parameters(precision: str, static: str, heterogeneous: bool, hertz: bool):
    """``params(static_overlap, contact_constant, exponent, c, k) -> (δ0, a_c, n)`` of padded contact k.

    Reads only the arrays the features use: one δ0 per contact ('profile') or per chain
    ('uniform') or none; a_c per contact (impurities) or per chain; n per chain or 5/2.
    """
    real = wp.float64 if precision == "float64" else wp.float32
    vec3 = wp.types.vector(3, real)
    STATIC, PROFILE = static != "none", static == "profile"

    @wp.func
    def params(static_overlap: wp.array2d(dtype=real), contact_constant: wp.array2d(dtype=real),
               exponent: wp.array(dtype=real), c: int, k: int) -> vec3:
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
            n = exponent[c]
        return vec3(delta0, a_c, n)

    return params


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
