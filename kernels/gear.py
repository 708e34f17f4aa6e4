"""Nordsieck predictor and corrector as ``@wp.func`` (SPEC §4), shared by the per-step and CPU kernels.

The state of a grain is its scaled Nordsieck vector x0 = u, x1 = dt·v, x2 = dt²/2·a, x3 = dt³/6·ȧ, …
(Verlet keeps x0, x1, x2 the same way). Prediction is the Pascal-triangle matrix; the corrector
adds C_k·(dt²/2·a(u_pred) − x2_pred) with Allen & Tildesley's coefficients, written as exact
fractions so float64 kernels see correctly rounded constants.
"""

import functools

import warp as wp

from .features import GEAR_CORRECTOR, GEAR_VALUES


@functools.cache
def nordsieck_functions(method: str, precision: str):
    """``(predicted_position, correct)`` for one method and precision (cached).

    ``predicted_position(x, c, j)`` → u of grain j of chain c at t + dt (x has shape (values, chains, grains)).
    ``correct(x_src, x_dst, c, i, u_pred, half_h2_acc)`` writes grain i's corrected vector to ``x_dst``
    (``x_src`` may be the same array: grain i's old values are read before any is written) and
    returns (x0, x1) = (u, dt·v).
    """
    real = wp.float64 if precision == "float64" else wp.float32
    vec2 = wp.types.vector(2, real)
    Q = GEAR_VALUES[method]
    GEAR = method != "verlet"
    C = GEAR_CORRECTOR.get(method, ((0, 1),) * 6)
    C = C + ((0, 1),) * (6 - len(C))

    @wp.func
    def predicted_position(x: wp.array3d(dtype=real), c: int, j: int) -> real:
        p = x[0, c, j] + x[1, c, j] + x[2, c, j]
        if wp.static(Q >= 4):
            p += x[3, c, j]
        if wp.static(Q >= 5):
            p += x[4, c, j]
        if wp.static(Q >= 6):
            p += x[5, c, j]
        return p

    @wp.func
    def correct(x_src: wp.array3d(dtype=real), x_dst: wp.array3d(dtype=real), c: int, i: int,
                u_pred: real, half_h2_acc: real) -> vec2:
        x0 = real(0)
        x1 = real(0)
        if wp.static(GEAR):
            p1 = x_src[1, c, i] + real(2) * x_src[2, c, i]
            p2 = x_src[2, c, i]
            p3 = real(0)
            p4 = real(0)
            p5 = real(0)
            if wp.static(Q >= 4):
                x3 = x_src[3, c, i]
                p1 += real(3) * x3
                p2 += real(3) * x3
                p3 = x3
            if wp.static(Q >= 5):
                x4 = x_src[4, c, i]
                p1 += real(4) * x4
                p2 += real(6) * x4
                p3 += real(4) * x4
                p4 = x4
            if wp.static(Q >= 6):
                x5 = x_src[5, c, i]
                p1 += real(5) * x5
                p2 += real(10) * x5
                p3 += real(10) * x5
                p4 += real(5) * x5
                p5 = x5
            corr = half_h2_acc - p2
            x0 = u_pred + real(wp.static(C[0][0])) / real(wp.static(C[0][1])) * corr
            x1 = p1 + real(wp.static(C[1][0])) / real(wp.static(C[1][1])) * corr
            x_dst[0, c, i] = x0
            x_dst[1, c, i] = x1
            x_dst[2, c, i] = half_h2_acc  # C2 = 1
            x_dst[3, c, i] = p3 + real(wp.static(C[3][0])) / real(wp.static(C[3][1])) * corr
            if wp.static(Q >= 5):
                x_dst[4, c, i] = p4 + real(wp.static(C[4][0])) / real(wp.static(C[4][1])) * corr
            if wp.static(Q >= 6):
                x_dst[5, c, i] = p5 + real(wp.static(C[5][0])) / real(wp.static(C[5][1])) * corr
        else:
            # velocity Verlet: dt·v_new = dt·v + dt²/2 (a + a_new)
            x0 = u_pred
            x1 = x_src[1, c, i] + x_src[2, c, i] + half_h2_acc
            x_dst[0, c, i] = x0
            x_dst[1, c, i] = x1
            x_dst[2, c, i] = half_h2_acc
        return vec2(x0, x1)

    return predicted_position, correct
