"""Nordsieck predictor and corrector as ``@wp.func`` (docs/model.md §4), written once for every kernel.

The state of a grain is its scaled Nordsieck vector x0 = u, x1 = dt·v, x2 = dt²/2·a, x3 = dt³/6·ȧ, …
(Verlet keeps x0, x1, x2 the same way). Prediction is the Pascal-triangle matrix; the corrector
adds C_k·(dt²/2·a(u_pred) − x2_pred) with Allen & Tildesley's coefficients, written as exact
fractions so float64 kernels see correctly rounded constants.

The functions work on one grain's values as a vector (``wp.types.vector(rows, real)``): the per-step
and CPU kernels load it from the state array, the fused kernel from its registers. Every kernel
therefore performs the same operations in the same order, which is what keeps them bitwise equal.

**Compensated float32** (``compensated=True``, float32 only). u changes by ~dt·v per step, many orders
of magnitude below u itself, so a plain float32 update ``u ← u + Σ x_j`` drops most of the increment's
bits, every step (and dt·v loses its small increments dt²·a the same way): the error grows as dt
shrinks. Here u and dt·v are each carried as an unevaluated sum hi + lo of two float32 values, the low
parts in two extra rows after the Nordsieck values (row Q: lo of u, row Q + 1: lo of dt·v). The
increments are formed in float32 (they are small, so their own rounding is small) and added with
Knuth's error-free TwoSum, whose rounding error becomes the new low part. hi stays the correctly
rounded value of hi + lo, so whatever reads rows 0 and 1 (records, energy, traces) reads u and dt·v
to float32's rounding; positions predicted for the forces are rounded to float32 as before. float64
kernels are generated without these rows or operations (bit for bit unchanged).
"""

import functools
from typing import NamedTuple

import warp as wp
from hertzian.kernels.features import GEAR_CORRECTOR, GEAR_VALUES, SUBSTEP_WEIGHTS


class Nordsieck(NamedTuple):
    """The ``@wp.func``s of one method and precision (see :func:`nordsieck_functions`)."""

    values: type
    """``wp.types.vector(rows, real)``: one grain's Nordsieck vector (and, compensated, the low parts of u, dt·v)."""
    predict_position: object
    """``predict_position(v) -> real``: u at t + dt."""
    corrected: object
    """``corrected(v, u_pred, half_h2_acc) -> values``: the vector at t + dt (``u_pred`` from predict_position)."""
    load: object
    """``load(x, c, i) -> values``: grain i of chain c from a state array of shape (values, chains, grains)."""
    store: object
    """``store(x, c, i, v)``."""
    predicted_position: object
    """``predicted_position(x, c, j) -> real``: predict_position(load(x, c, j))."""
    correct: object
    """``correct(x_src, x_dst, c, i, u_pred, half_h2_acc) -> vec2(u, dt·v)``: corrects grain i into x_dst
    (``x_src`` may be ``x_dst``: the old values are read before any is written)."""
    driver_values: object
    """``driver_values(amplitude, omega, t, dt) -> values``: the driven grain's vector at t,
    x_j = dt^j/j! · d^j/dt^j (A sin ωt) (all arguments float64)."""
    driver_values_at: object
    """``driver_values_at(amplitude, omega, s, co, dt) -> values``: the same from s = sin ωt and co = cos ωt."""
    position: type
    """A predicted position as the forces use it: ``real``, or compensated ``vec2(hi, lo)``."""
    predicted: object
    """``predicted(v) -> position``: u at t + dt (compensated: hi = predict_position(v), and lo)."""
    predicted_at: object
    """``predicted_at(x, c, j) -> position``: predicted(load(x, c, j))."""
    gap: object
    """``gap(a, b) -> real``: u_a − u_b of two positions, the relative displacement of a contact
    (compensated: (hi_a − hi_b) + (lo_a − lo_b), so that the overlap keeps its digits when u ≫ δ)."""
    rounded: object
    """``rounded(p) -> real``: the position rounded to ``real`` (= predict_position's value)."""
    exact_position: object
    """``exact_position(u) -> position``: a float64 position (the driver's) as a position."""
    substep_predicted_at: object
    """Composed methods (yoshida4): ``substep_predicted_at(x, c, j, w) -> position``: u after a velocity-Verlet
    substep of w·dt, u + w·x1 + w²·x2 (x1, x2 scaled with the full dt)."""
    substep_correct: object
    """Composed methods: ``substep_correct(x_src, x_dst, c, i, u_pred, half_h2_acc, w) -> vec2(u, dt·v)``:
    the substep's corrector, dt·v += w·(x2 + x2_new), x2 = x2_new (``half_h2_acc`` = dt²/2·a(u_pred))."""
    substep_predicted: object
    """Composed methods: ``substep_predicted(v, w) -> position``: substep_predicted_at on a register column."""
    substep_corrected: object
    """Composed methods: ``substep_corrected(v, u_pred, half_h2_acc, w) -> values``: substep_correct's new vector."""


def state_rows(method: str, precision: str, compensated: bool) -> int:
    """Values per grain in the state: the Nordsieck vector, plus the low parts of u and dt·v when compensated."""
    return GEAR_VALUES[method] + (2 if compensated and precision != "float64" else 0)


@functools.cache
def two_sum_function(precision: str):
    """``two_sum(a, b) -> vec2(s, err)``: Knuth's TwoSum, s = fl(a + b) and s + err == a + b exactly
    (for any a, b; Warp compiles without fast-math, so the operations keep their order)."""
    real = wp.float64 if precision == "float64" else wp.float32
    vec2 = wp.types.vector(2, real)

    @wp.func
    def two_sum(a: real, b: real) -> vec2:
        s = a + b
        b_virtual = s - a
        err = (a - (s - b_virtual)) + (b - b_virtual)
        return vec2(s, err)

    return two_sum


@functools.cache
def nordsieck_functions(method: str, precision: str, compensated: bool = False) -> Nordsieck:
    """The predictor and corrector of one method and precision (cached); ``compensated``: float32 only,
    see the module docstring."""
    real = wp.float64 if precision == "float64" else wp.float32
    vec2 = wp.types.vector(2, real)
    Q = GEAR_VALUES[method]
    COMP = compensated and precision != "float64"
    ROWS = state_rows(method, precision, compensated)
    LO_U = Q  # row of u's low part (compensated only)
    LO_RATE = Q + 1  # row of dt·v's low part
    values_t = wp.types.vector(ROWS, real)
    GEAR = method in GEAR_CORRECTOR
    C = GEAR_CORRECTOR.get(method, ((0, 1),) * 6)
    C = C + ((0, 1),) * (6 - len(C))

    two_sum = two_sum_function(precision)

    @wp.func
    def position_increment(v: values_t) -> real:
        # compensated: u(t + dt) − hi = lo + Σ_{j≥1} x_j (dt·v with its own low part), small terms first
        inc = v[1] + v[wp.static(LO_RATE)]
        inc += v[2]
        if wp.static(Q >= 4):
            inc += v[3]
        if wp.static(Q >= 5):
            inc += v[4]
        if wp.static(Q >= 6):
            inc += v[5]
        return inc + v[wp.static(LO_U)]

    @wp.func
    def predicted_pair(v: values_t) -> vec2:
        return two_sum(v[0], position_increment(v))

    @wp.func
    def predict_position(v: values_t) -> real:
        if wp.static(COMP):
            return v[0] + position_increment(v)
        p = v[0] + v[1] + v[2]
        if wp.static(Q >= 4):
            p += v[3]
        if wp.static(Q >= 5):
            p += v[4]
        if wp.static(Q >= 6):
            p += v[5]
        return p

    @wp.func
    def corrected(v: values_t, u_pred: real, half_h2_acc: real) -> values_t:
        new = values_t()
        if wp.static(COMP and GEAR):
            # as below, with u and dt·v advanced by TwoSum (u_pred is recomputed unrounded)
            d1 = real(2) * v[2]  # p1 − x1
            d2 = real(0)  # p2 − x2
            p3 = real(0)
            p4 = real(0)
            p5 = real(0)
            if wp.static(Q >= 4):
                x3 = v[3]
                d1 += real(3) * x3
                d2 = real(3) * x3
                p3 = x3
            if wp.static(Q >= 5):
                x4 = v[4]
                d1 += real(4) * x4
                d2 += real(6) * x4
                p3 += real(4) * x4
                p4 = x4
            if wp.static(Q >= 6):
                x5 = v[5]
                d1 += real(5) * x5
                d2 += real(10) * x5
                p3 += real(10) * x5
                p4 += real(5) * x5
                p5 = x5
            # half_h2_acc − x2 is nearly exact (two close values); the small rest is subtracted after
            corr = (half_h2_acc - v[2]) - d2
            u = two_sum(v[0], position_increment(v) + real(wp.static(C[0][0])) / real(wp.static(C[0][1])) * corr)
            rate = two_sum(
                v[1], v[wp.static(LO_RATE)] + (d1 + real(wp.static(C[1][0])) / real(wp.static(C[1][1])) * corr)
            )
            new[0] = u[0]
            new[wp.static(LO_U)] = u[1]
            new[1] = rate[0]
            new[wp.static(LO_RATE)] = rate[1]
            new[2] = half_h2_acc  # C2 = 1
            if wp.static(Q >= 4):
                new[3] = p3 + real(wp.static(C[3][0])) / real(wp.static(C[3][1])) * corr
            if wp.static(Q >= 5):
                new[4] = p4 + real(wp.static(C[4][0])) / real(wp.static(C[4][1])) * corr
            if wp.static(Q >= 6):
                new[5] = p5 + real(wp.static(C[5][0])) / real(wp.static(C[5][1])) * corr
        elif wp.static(COMP):
            # velocity Verlet, compensated: u += dt·v + dt²/2·a, dt·v += dt²/2 (a + a_new), by TwoSum
            u = two_sum(v[0], position_increment(v))
            rate = two_sum(v[1], v[wp.static(LO_RATE)] + (v[2] + half_h2_acc))
            new[0] = u[0]
            new[wp.static(LO_U)] = u[1]
            new[1] = rate[0]
            new[wp.static(LO_RATE)] = rate[1]
            new[2] = half_h2_acc
        elif wp.static(GEAR):
            p1 = v[1] + real(2) * v[2]
            p2 = v[2]
            p3 = real(0)
            p4 = real(0)
            p5 = real(0)
            if wp.static(Q >= 4):
                x3 = v[3]
                p1 += real(3) * x3
                p2 += real(3) * x3
                p3 = x3
            if wp.static(Q >= 5):
                x4 = v[4]
                p1 += real(4) * x4
                p2 += real(6) * x4
                p3 += real(4) * x4
                p4 = x4
            if wp.static(Q >= 6):
                x5 = v[5]
                p1 += real(5) * x5
                p2 += real(10) * x5
                p3 += real(10) * x5
                p4 += real(5) * x5
                p5 = x5
            corr = half_h2_acc - p2
            new[0] = u_pred + real(wp.static(C[0][0])) / real(wp.static(C[0][1])) * corr
            new[1] = p1 + real(wp.static(C[1][0])) / real(wp.static(C[1][1])) * corr
            new[2] = half_h2_acc  # C2 = 1
            if wp.static(Q >= 4):
                new[3] = p3 + real(wp.static(C[3][0])) / real(wp.static(C[3][1])) * corr
            if wp.static(Q >= 5):
                new[4] = p4 + real(wp.static(C[4][0])) / real(wp.static(C[4][1])) * corr
            if wp.static(Q >= 6):
                new[5] = p5 + real(wp.static(C[5][0])) / real(wp.static(C[5][1])) * corr
        else:
            # velocity Verlet: dt·v_new = dt·v + dt²/2 (a + a_new)
            new[0] = u_pred
            new[1] = v[1] + v[2] + half_h2_acc
            new[2] = half_h2_acc
        return new

    @wp.func
    def load(x: wp.array3d(dtype=real), c: int, i: int) -> values_t:
        v = values_t()
        for q in range(wp.static(ROWS)):
            v[q] = x[q, c, i]
        return v

    @wp.func
    def store(x: wp.array3d(dtype=real), c: int, i: int, v: values_t):
        for q in range(wp.static(ROWS)):
            x[q, c, i] = v[q]

    @wp.func
    def predicted_position(x: wp.array3d(dtype=real), c: int, j: int) -> real:
        return predict_position(load(x, c, j))

    @wp.func
    def correct(
        x_src: wp.array3d(dtype=real), x_dst: wp.array3d(dtype=real), c: int, i: int, u_pred: real, half_h2_acc: real
    ) -> vec2:
        new = corrected(load(x_src, c, i), u_pred, half_h2_acc)
        store(x_dst, c, i, new)
        return vec2(new[0], new[1])

    @wp.func
    def driver_values_at(
        amplitude: wp.float64, omega: wp.float64, s: wp.float64, co: wp.float64, dt: wp.float64
    ) -> values_t:
        # the driver's scaled Nordsieck vector where sin ωt = s and cos ωt = co: x_j = dt^j/j! · d^j/dt^j (A sin ωt)
        v = values_t()
        scale = amplitude
        for j in range(wp.static(Q)):
            phase = j % 4
            w = s
            if phase == 1:
                w = co
            elif phase == 2:
                w = -s
            elif phase == 3:
                w = -co
            v[j] = real(scale * w)
            scale = scale * omega * dt / wp.float64(j + 1)
        return v

    @wp.func
    def driver_values(amplitude: wp.float64, omega: wp.float64, t: wp.float64, dt: wp.float64) -> values_t:
        # the driver's scaled Nordsieck vector at t
        return driver_values_at(amplitude, omega, wp.sin(omega * t), wp.cos(omega * t), dt)

    @wp.func
    def gap_pair(a: vec2, b: vec2) -> real:
        return (a[0] - b[0]) + (a[1] - b[1])

    @wp.func
    def gap_plain(a: real, b: real) -> real:
        return a - b

    @wp.func
    def rounded_pair(p: vec2) -> real:
        return p[0]

    @wp.func
    def rounded_plain(p: real) -> real:
        return p

    @wp.func
    def exact_pair(u: wp.float64) -> vec2:
        hi = real(u)
        return vec2(hi, real(u - wp.float64(hi)))

    @wp.func
    def exact_plain(u: wp.float64) -> real:
        return real(u)

    @wp.func
    def predicted_pair_at(x: wp.array3d(dtype=real), c: int, j: int) -> vec2:
        return predicted_pair(load(x, c, j))

    # ---- a velocity-Verlet substep of w·dt on the full-dt scaled values (composed methods, yoshida4) --------
    # u' = u + w·x1 + w²·x2, x2' = dt²/2·a(u'), x1' = x1 + w·(x2 + x2'): velocity Verlet with step w·dt
    # written in x1 = dt·v, x2 = dt²/2·a. Verlet itself keeps its own arithmetic above (bit for bit).

    @wp.func
    def substep_increment(v: values_t, w: real) -> real:
        # u' − u (compensated: with the low parts of u and dt·v), small terms after the large one
        inc = w * (v[1] + v[wp.static(LO_RATE)]) + (w * w) * v[2]
        return inc + v[wp.static(LO_U)]

    @wp.func
    def substep_pair(v: values_t, w: real) -> vec2:
        return two_sum(v[0], substep_increment(v, w))

    @wp.func
    def substep_position(v: values_t, w: real) -> real:
        if wp.static(COMP):
            return v[0] + substep_increment(v, w)
        return v[0] + w * v[1] + (w * w) * v[2]

    @wp.func
    def substep_pair_at(x: wp.array3d(dtype=real), c: int, j: int, w: real) -> vec2:
        return substep_pair(load(x, c, j), w)

    @wp.func
    def substep_position_at(x: wp.array3d(dtype=real), c: int, j: int, w: real) -> real:
        return substep_position(load(x, c, j), w)

    @wp.func
    def substep_corrected(v: values_t, u_pred: real, half_h2_acc: real, w: real) -> values_t:
        new = values_t()
        if wp.static(COMP):
            u = two_sum(v[0], substep_increment(v, w))
            rate = two_sum(v[1], v[wp.static(LO_RATE)] + w * (v[2] + half_h2_acc))
            new[0] = u[0]
            new[wp.static(LO_U)] = u[1]
            new[1] = rate[0]
            new[wp.static(LO_RATE)] = rate[1]
        else:
            new[0] = u_pred
            new[1] = v[1] + w * (v[2] + half_h2_acc)
        new[2] = half_h2_acc
        return new

    @wp.func
    def substep_correct(
        x_src: wp.array3d(dtype=real),
        x_dst: wp.array3d(dtype=real),
        c: int,
        i: int,
        u_pred: real,
        half_h2_acc: real,
        w: real,
    ) -> vec2:
        new = substep_corrected(load(x_src, c, i), u_pred, half_h2_acc, w)
        store(x_dst, c, i, new)
        return vec2(new[0], new[1])

    if COMP:
        position_api = (vec2, predicted_pair, predicted_pair_at, gap_pair, rounded_pair, exact_pair)
    else:
        position_api = (real, predict_position, predicted_position, gap_plain, rounded_plain, exact_plain)
    substep_api = (
        substep_pair_at if COMP else substep_position_at,
        substep_correct,
        substep_pair if COMP else substep_position,
        substep_corrected,
    )
    return Nordsieck(
        values_t,
        predict_position,
        corrected,
        load,
        store,
        predicted_position,
        correct,
        driver_values,
        driver_values_at,
        *position_api,
        *substep_api,
    )


@functools.cache
def substep_weight_function(method: str, precision: str):
    """``substep_weight(substep) -> real``: the weight w_k of substep k of a composed method (1 for the others).

    The compositions are symmetric with an odd count: each outer weight is the float64 constant rounded to the
    state's precision and the middle one, 1 − 2·(the outer weights of one half), is computed in that precision, so
    the substeps add up to one step in float32 too (rounding the middle weight on its own would leave a clock error
    of 1.2e-7 per step in float32)."""
    real = wp.float64 if precision == "float64" else wp.float32
    composed = method in SUBSTEP_WEIGHTS
    weights = SUBSTEP_WEIGHTS.get(method, (1.0,))
    half = len(weights) // 2
    assert not composed or (
        len(weights) % 2 == 1 and weights == weights[::-1] and weights[half] == 1.0 - 2.0 * sum(weights[:half])
    )

    @wp.func
    def substep_weight(substep: int) -> real:
        w = real(1)
        if wp.static(composed):
            outer = real(0)
            for k in range(wp.static(half)):
                outer += real(wp.static(weights[k]))
            w = real(1) - real(2) * outer
            for k in range(wp.static(half)):
                if substep == k or substep == wp.static(len(weights) - 1) - k:
                    w = real(wp.static(weights[k]))
        return w

    return substep_weight


def refuse_composed_extras(features) -> None:
    """A composed method (yoshida4) has no drive, damping or event steps in any kernel: ValueError if asked."""
    f = features
    if f.method in SUBSTEP_WEIGHTS and (f.surface == "driven" or f.damping != "none" or f.event_window > 0):
        raise ValueError(f"method {f.method!r} does not implement a drive, damping or event steps ({f})")
