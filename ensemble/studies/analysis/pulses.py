"""Pulses (Sec. III): head position and speed c(t), speed exponent α, shock width, plateau tilt,
exponential tails, and Nesterenko's long-wave soliton for comparison."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from hertzian.studies.analysis.common import LineFit, PowerLawFit, fit_line, fit_power_law


def _parabolic_peak(profile: np.ndarray, k: int) -> float:
    """Sub-grain position of a maximum at index k from a parabola through k-1, k, k+1."""
    if k <= 0 or k >= profile.size - 1:
        return float(k)
    left, mid, right = profile[k - 1], profile[k], profile[k + 1]
    curvature = left - 2.0 * mid + right
    if curvature >= 0:
        return float(k)
    return float(k + 0.5 * (left - right) / curvature)


def pulse_head(profile, *, fraction: float = 0.5) -> float:
    """Position [grains] of the pulse's head in one snapshot: the deepest local maximum of
    ``profile`` (usually the velocity ``v``) among grains where it reaches ``fraction`` of its
    largest value, refined to sub-grain precision by a parabola. NaN when nothing moves forward.

    Taking the deepest strong maximum (not the largest one) follows the leading soliton even where
    a tail or a second hit of the surface grain carries a comparable velocity.
    """
    p = np.asarray(profile, dtype=float)
    top = np.nanmax(p) if p.size else math.nan
    if not np.isfinite(top) or top <= 0:
        return math.nan
    strong = np.flatnonzero(p >= fraction * top)
    k = int(strong[-1])
    while k + 1 < p.size and p[k + 1] > p[k]:
        k += 1
    while k > 0 and p[k - 1] > p[k]:
        k -= 1
    return _parabolic_peak(p, k)


def head_positions(field, *, fraction: float = 0.5) -> np.ndarray:
    """:func:`pulse_head` of every snapshot: ``field`` (..., record, grain) → (..., record) [grains]."""
    f = np.asarray(field, dtype=float)
    flat = f.reshape(-1, f.shape[-1])
    heads = np.array([pulse_head(row, fraction=fraction) for row in flat])
    return heads.reshape(f.shape[:-1])


def front_position(u, *, fraction: float = 0.5) -> float:
    """Deepest grain (linearly interpolated) where the displacement ``u`` reaches ``fraction`` of its
    largest value [grains]: the leading edge of the displaced region (NaN when nothing moved)."""
    p = np.asarray(u, dtype=float)
    top = np.nanmax(p) if p.size else math.nan
    if not np.isfinite(top) or top <= 0:
        return math.nan
    level = fraction * top
    k = int(np.flatnonzero(p >= level)[-1])
    if k + 1 >= p.size:
        return float(k)
    return float(k + (p[k] - level) / (p[k] - p[k + 1]))


def pulse_speed(t, head, *, first_grain: float = 0.0, last_grain: float = math.inf) -> LineFit:
    """Pulse speed c [grains/time] as the slope of a line through the head positions ``head(t)``
    that lie in [first_grain, last_grain], up to the first time the head passes ``last_grain``
    (so a reflection never enters the fit). ``slope_error`` is the 1σ error of c."""
    t, h = np.asarray(t, dtype=float), np.asarray(head, dtype=float)
    beyond = np.flatnonzero(h > last_grain)
    stop = beyond[0] if beyond.size else h.size
    t, h = t[:stop], h[:stop]
    keep = np.isfinite(h) & (h >= first_grain)
    return fit_line(t[keep], h[keep])


def speed_history(t, head, *, window: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """c(t) [grains/time]: slopes of lines through ``window`` consecutive head positions.
    Returns (window-centre times, speeds); NaN where a window holds a missing head."""
    t, h = np.asarray(t, dtype=float), np.asarray(head, dtype=float)
    count = t.size - window + 1
    if count < 1:
        return np.empty(0), np.empty(0)
    centres = np.array([t[k : k + window].mean() for k in range(count)])
    speeds = np.array(
        [
            fit_line(t[k : k + window], h[k : k + window]).slope if np.all(np.isfinite(h[k : k + window])) else math.nan
            for k in range(count)
        ]
    )
    return centres, speeds


def speed_exponent(v_imp, speed) -> PowerLawFit:
    """α and its 1σ error from ln c = α ln v_imp + const (paper Fig. 1(d): α ≈ 0.2)."""
    return fit_power_law(v_imp, speed)


def shock_width(u, *, fraction: float = 0.5) -> float:
    """W: length [grains] of the displaced region in one snapshot, from the shallowest to the
    deepest grain whose displacement reaches ``fraction`` of the largest (the front end
    interpolated); the paper's "expanding rectangular object" of Sec. III A. NaN when nothing moved."""
    p = np.asarray(u, dtype=float)
    top = np.nanmax(p) if p.size else math.nan
    if not np.isfinite(top) or top <= 0:
        return math.nan
    first = int(np.flatnonzero(p >= fraction * top)[0])
    return front_position(p, fraction=fraction) - first + 1.0


def shock_widths(u, *, fraction: float = 0.5) -> np.ndarray:
    """:func:`shock_width` of every snapshot: (..., record, grain) → (..., record) [grains]."""
    f = np.asarray(u, dtype=float)
    flat = f.reshape(-1, f.shape[-1])
    return np.array([shock_width(row, fraction=fraction) for row in flat]).reshape(f.shape[:-1])


def plateau_tilt(profile, *, fraction: float = 0.8) -> float:
    """Tilt of a pulse's top (Fig. 4's "flat top" vs "sloping top"): over the contiguous grains around the
    largest value of ``profile`` that reach ``fraction`` of it, the change of a fitted line from the
    deep end to the shallow end, divided by the largest value (0 for a flat top; dimensionless).
    Pass the paper's displacement (−u) for a reflected pulse, u for an in-going one."""
    p = np.asarray(profile, dtype=float)
    k = int(np.argmax(p))
    top = p[k]
    if not top > 0:
        return math.nan
    lo, hi = k, k
    while lo > 0 and p[lo - 1] >= fraction * top:
        lo -= 1
    while hi < p.size - 1 and p[hi + 1] >= fraction * top:
        hi += 1
    if hi - lo < 2:
        return math.nan
    grains = np.arange(lo, hi + 1)
    line = fit_line(grains, p[lo : hi + 1])
    return float(-line.slope * (hi - lo) / top)


def overlaps(u, l0: float = 0.0):
    """Overlap of every contact between neighbouring grains, l0 + u_i − u_(i+1) [length] (docs/model.md's sign:
    u + into the chain), (..., grain) → (..., grain − 1); the surface and bottom walls' contacts are left out."""
    u = np.asarray(u, dtype=float)
    return l0 + u[..., :-1] - u[..., 1:]


def overlap_behind_head(u, head: float, *, l0: float = 0.0, near: int = 5, behind: int = 10) -> float:
    """Fig. 2(a)'s "regions of even higher overlap" behind the shock front: the largest dynamic overlap
    (overlap − l0) at contacts more than ``behind`` grains behind the head, divided by the largest one
    within ``near`` grains of the head (> 1: behind the front some grains overlap more than at it).
    NaN when the head is not inside the chain."""
    if not np.isfinite(head):
        return math.nan
    dynamic = overlaps(u, l0) - l0
    k = int(round(head))
    at_head = dynamic[max(k - near, 0) : min(k + near + 1, dynamic.size)]
    rear = dynamic[: max(k - behind, 0)]
    if at_head.size == 0 or rear.size == 0 or not np.max(at_head) > 0:
        return math.nan
    return float(np.max(rear) / np.max(at_head))


PAPER_TAIL_TIMES = {1e-4: (5.0, 15.0, 25.0, 35.0), 1e-3: (5.0, 15.0, 25.0, 30.0)}
"""Fig. 3: times [time units] of the tail fits per l0 (the head is short of 0.8 of a 1000-grain chain)."""


@dataclass(frozen=True)
class TailFit:
    """Exponential fit of the compressive tail behind the head: ``u ≈ A exp(−z/decay_length)``,
    z = grains behind the head."""

    decay_length: float
    """λ [grains]."""
    decay_length_error: float
    amplitude: float
    """A [length]."""
    r_squared: float
    """Of the fit of ln u against z."""
    points: int
    head: float
    """Head position used [grains]."""


def running_max(profile, grains: int):
    """Largest value within ``grains`` neighbouring grains (centred), the upper envelope of an
    oscillating profile."""
    p = np.asarray(profile, dtype=float)
    half = grains // 2
    if half == 0:
        return p.copy()
    padded = np.pad(p, half, mode="constant", constant_values=-np.inf)
    windows = np.lib.stride_tricks.sliding_window_view(padded, 2 * half + 1)
    return windows.max(axis=-1)


def tail_decay(
    u, head: float, *, skip: int = 10, span: float | None = None, envelope: int = 11, baseline: float = 0.0
) -> TailFit:
    """Fit ln u = ln A − z/λ over the grains behind the head where the displacement is along the
    compression (u > 0 in docs/model.md's sign; the paper's negative side of the y axis).

    ``z = head − grain``; the first ``skip`` grains behind the head (the head itself) are left out;
    ``span`` limits z (default: back to the surface). The tail oscillates in sign from grain to
    grain, so the fit is to its upper envelope, the running maximum over ``envelope`` grains
    (1: the raw displacements). The paper's claim, P(z, t) ∝ exp(−z/ct), says λ grows like c·t,
    i.e. like the head's depth. ``baseline``: the displacement the chain behind the pulse settles at,
    subtracted first (0 with a surface wall; a uniform shift with a constant-force surface, see
    :func:`rear_level`).
    """
    p = running_max(np.asarray(u, dtype=float) - baseline, envelope)
    if not np.isfinite(head):
        return TailFit(math.nan, math.nan, math.nan, math.nan, 0, head)
    grains = np.arange(p.size)
    z = head - grains
    keep = (z >= skip) & (p > 0)
    if span is not None:
        keep &= z <= span
    line = fit_line(z[keep], np.log(p[keep]))
    if not (line.slope < 0):
        return TailFit(math.nan, math.nan, math.nan, line.r_squared, line.points, head)
    decay = -1.0 / line.slope
    return TailFit(decay, line.slope_error / line.slope**2, math.exp(line.intercept), line.r_squared, line.points, head)


def rear_level(u, *, grains: int = 10) -> float:
    """Mean displacement of the ``grains`` grains nearest the surface: the level the chain behind a
    pulse settles at (0 with a surface wall; with a constant-force surface the impact shifts the
    whole rear of the chain by this much)."""
    return float(np.mean(np.asarray(u, dtype=float)[..., :grains]))


NESTERENKO_SUPPORT = math.pi * math.sqrt(2.5)
"""Full width [grains] of Nesterenko's solitary wave, ψ ∝ cos⁴(√(2/5)·s) on |√(2/5)·s| ≤ π/2: π√(5/2) ≈ 4.97."""


NESTERENKO_FWHM = 2.0 * math.acos(2.0**-0.25) / math.sqrt(0.4)
"""Full width at half maximum [grains] of the cos⁴ profile (overlap or grain velocity): ≈ 1.81."""


def nesterenko_speed(peak_velocity, *, a: float = 5657.0, mass: float = 1.0):
    """Speed [grains/time] of Nesterenko's long-wave solitary wave in a Hertz chain with no
    precompression, for a largest grain velocity v_m [length/time]:

        c = (2a/m)^(2/5) · v_m^(1/5).

    Derivation (program units, s = grain index): with F = (5/2) a δ^(3/2) the overlaps obey
    m ψ̈ = (5/2) a Δ² ψ^(3/2); Nesterenko's long-wave equation has the travelling solution
    ψ = ψ_m cos⁴(√(2/5)(s − ct)) with m c² = (4/5)(5/2) a ψ_m^(1/2) = 2a ψ_m^(1/2). In the wave a grain
    moves with v = c ψ, so v_m = c ψ_m and c^(5/2) = (2a/m) v_m^(1/2). For a = 5657, m = 1 the
    prefactor is 11314^(2/5) ≈ 41.8 grains/time (4.18e3 length units per time unit).
    """
    return (2.0 * a / mass) ** 0.4 * np.asarray(peak_velocity, dtype=float) ** 0.2


def full_width_half_maximum(x, y) -> float:
    """FWHM of a single-peaked sampled signal y(x) (linear interpolation at both half-maximum crossings)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    k = int(np.argmax(y))
    half = 0.5 * y[k]
    left = k
    while left > 0 and y[left - 1] > half:
        left -= 1
    right = k
    while right < y.size - 1 and y[right + 1] > half:
        right += 1
    if left == 0 or right == y.size - 1:
        return math.nan
    xl = x[left - 1] + (half - y[left - 1]) * (x[left] - x[left - 1]) / (y[left] - y[left - 1])
    xr = x[right] + (y[right] - half) * (x[right + 1] - x[right]) / (y[right] - y[right + 1])
    return float(xr - xl)


def times_in_flight(t: np.ndarray, heads: np.ndarray, grain_count: int, count: int, *, reach: float = 0.9) -> list[int]:
    """Record indices of ``count`` snapshots evenly spread while the head goes from 10 % to
    ``reach`` of the chain (before it meets the far end)."""
    beyond = np.flatnonzero(heads > reach * grain_count)
    stop = beyond[0] if beyond.size else len(t) - 1
    start = np.flatnonzero(heads > 0.1 * grain_count)
    start = start[0] if start.size and start[0] < stop else 1
    return sorted(set(np.linspace(start, stop, count).round().astype(int).tolist()))


def speeds_table(ds, *, first_grain: float = 100.0, last_grain: float = 800.0) -> np.ndarray:
    """Pulse speed c [grains/time] at every (l0, v_imp) point of a Fig. 1(d) store, shape (l0, v_imp),
    with its 1σ fit error as a second array: returns (c, error)."""
    t = ds.t.values
    v = ds.v.transpose("l0", "v_imp", "record", "grain").values
    c = np.full(v.shape[:2], math.nan)
    err = np.full(v.shape[:2], math.nan)
    for i in range(v.shape[0]):
        for j in range(v.shape[1]):
            fit = pulse_speed(t, head_positions(v[i, j]), first_grain=first_grain, last_grain=last_grain)
            c[i, j], err[i, j] = fit.slope, fit.slope_error
    return c, err
