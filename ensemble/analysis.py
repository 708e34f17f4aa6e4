"""Observables of Sen, Manciu & Wright (1998), computed from recorded snapshots and traces.

Pure NumPy: every function takes arrays (xarray DataArrays work too, through ``np.asarray``)
with the store's layout — snapshots ``(..., record, grain)``, traces ``(..., sample)`` — and
program units (length 1e-5 m, time 1.0102e-3 s, mass 2.36e-5 kg). Positions along the chain are
grain indices counted from the surface (grain 0), so speeds are in grains per time unit
(multiply by the diameter, 100 length units, for length per time).

Sign convention: SPEC §1's displacement ``u`` and velocity ``v`` are positive *into* the chain
(toward the bottom). The paper plots grain positions, so its displacements are ``−u``
(:func:`paper_displacement`), and a pulse moving into the chain compresses the "negative side
of the y axis".

What is here, by paper section:

* III A — :func:`pulse_head`, :func:`head_positions`, :func:`pulse_speed`, :func:`speed_history`
  (pulse position and speed c(t)); :func:`speed_exponent` (α in c ∝ v_imp^α);
  :func:`shock_width` (W(t)); :func:`plateau_tilt` (flat vs sloping top, Fig. 4).
* III B — :func:`tail_decay` (exponential tail P(z, t) ∝ exp(−z/λ), compared with c·t).
* IV, V — :func:`backscatter` (arrival, amplitude and leading sign of the echo at a grain).
* V — :func:`depth_law` (c ∝ z^β, the paper's β = 1/6), :func:`column_sound_speed` (closed form),
  :func:`count_bumps` (tail bumps, Fig. 6).
* VI — :func:`window_average`, :func:`standing_wave_measure`.
* Nesterenko's long-wave soliton — :func:`nesterenko_speed`, :data:`NESTERENKO_SUPPORT`,
  :data:`NESTERENKO_FWHM`, :func:`full_width_half_maximum`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# ---- fits ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class LineFit:
    """Least-squares line ``y = slope·x + intercept`` with standard errors (from the residuals)."""

    slope: float
    slope_error: float
    intercept: float
    intercept_error: float
    r_squared: float
    points: int


def fit_line(x, y) -> LineFit:
    """Ordinary least squares of ``y`` on ``x`` (NaNs dropped); errors are 1σ standard errors."""
    x, y = np.asarray(x, dtype=float).ravel(), np.asarray(y, dtype=float).ravel()
    keep = np.isfinite(x) & np.isfinite(y)
    x, y = x[keep], y[keep]
    n = x.size
    if n < 2 or np.ptp(x) == 0:
        return LineFit(math.nan, math.nan, math.nan, math.nan, math.nan, n)
    xm, ym = x.mean(), y.mean()
    sxx = np.sum((x - xm) ** 2)
    slope = float(np.sum((x - xm) * (y - ym)) / sxx)
    intercept = float(ym - slope * xm)
    residual = y - (slope * x + intercept)
    ss_res, ss_tot = float(np.sum(residual**2)), float(np.sum((y - ym) ** 2))
    if n > 2:
        sigma2 = ss_res / (n - 2)
        slope_error = math.sqrt(sigma2 / sxx)
        intercept_error = math.sqrt(sigma2 * (1.0 / n + xm**2 / sxx))
    else:
        slope_error = intercept_error = math.nan
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else 1.0
    return LineFit(slope, slope_error, intercept, intercept_error, r2, n)


@dataclass(frozen=True)
class PowerLawFit:
    """``y = prefactor · x^exponent``, fitted as a line in (ln x, ln y); errors are 1σ."""

    exponent: float
    exponent_error: float
    prefactor: float
    prefactor_relative_error: float
    r_squared: float
    points: int

    def __call__(self, x):
        return self.prefactor * np.asarray(x, dtype=float) ** self.exponent


def fit_power_law(x, y) -> PowerLawFit:
    """Fit ``y = C x^β`` by least squares on logarithms (points with x ≤ 0 or y ≤ 0 are dropped)."""
    x, y = np.asarray(x, dtype=float).ravel(), np.asarray(y, dtype=float).ravel()
    keep = (x > 0) & (y > 0) & np.isfinite(x) & np.isfinite(y)
    line = fit_line(np.log(x[keep]), np.log(y[keep]))
    return PowerLawFit(line.slope, line.slope_error, math.exp(line.intercept) if math.isfinite(line.intercept)
                       else math.nan, line.intercept_error, line.r_squared, line.points)


# ---- conventions --------------------------------------------------------------------------


def paper_displacement(u):
    """The paper's displacement (change of grain *position*, its y axes): ``−u`` [length]."""
    return -np.asarray(u)


def paper_label(grain, grain_count: int):
    """The paper's grain label in Figs. 1, 2 and 4 (surface grain = N, last grain = 1): ``N − i``."""
    return grain_count - np.asarray(grain)


# ---- pulse position and speed (Sec. III A) -------------------------------------------------


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
    centres = np.array([t[k:k + window].mean() for k in range(count)])
    speeds = np.array([fit_line(t[k:k + window], h[k:k + window]).slope if np.all(np.isfinite(h[k:k + window]))
                       else math.nan for k in range(count)])
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
    line = fit_line(grains, p[lo:hi + 1])
    return float(-line.slope * (hi - lo) / top)


def count_bumps(profile, head: float, *, fraction: float = 0.1) -> int:
    """Bumps of a pulse (Fig. 6): local maxima of ``profile`` (velocity, + into the chain) at or behind
    the head that reach ``fraction`` of the head's value; the head itself counts as one."""
    p = np.asarray(profile, dtype=float)
    if not np.isfinite(head):
        return 0
    k = int(round(head))
    level = fraction * p[k]
    interior = np.arange(1, min(k + 2, p.size - 1))
    peaks = interior[(p[interior] > p[interior - 1]) & (p[interior] >= p[interior + 1]) & (p[interior] >= level)]
    return int(peaks.size)


# ---- tails (Sec. III B) -------------------------------------------------------------------


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


def tail_decay(u, head: float, *, skip: int = 10, span: float | None = None, envelope: int = 11) -> TailFit:
    """Fit ln u = ln A − z/λ over the grains behind the head where the displacement is along the
    compression (u > 0 in SPEC's sign; the paper's negative side of the y axis).

    ``z = head − grain``; the first ``skip`` grains behind the head (the head itself) are left out;
    ``span`` limits z (default: back to the surface). The tail oscillates in sign from grain to
    grain, so the fit is to its upper envelope, the running maximum over ``envelope`` grains
    (1: the raw displacements). The paper's claim, P(z, t) ∝ exp(−z/ct), says λ grows like c·t,
    i.e. like the head's depth.
    """
    p = running_max(u, envelope)
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
    return TailFit(decay, line.slope_error / line.slope**2, math.exp(line.intercept), line.r_squared,
                   line.points, head)


# ---- backscattering (Secs. IV, V) ----------------------------------------------------------


@dataclass(frozen=True)
class Backscatter:
    """The echo seen at one grain: signal minus the same grain's signal in the clean chain."""

    arrival_time: float
    """First time the echo's |v| reaches ``fraction`` of its largest value [time]; NaN if none."""
    amplitude: float
    """Largest |echo| [velocity]."""
    peak_time: float
    """When the largest |echo| occurs [time]."""
    leading_sign: int
    """Sign of the echo's first strong lobe: +1 into the chain (the original pulse's direction),
    −1 toward the surface; 0 if there is no echo."""
    peak_sign: int
    """Sign of the largest lobe."""


def backscatter(t, signal, reference=None, *, after: float = 0.0, until: float = math.inf,
                fraction: float = 0.2) -> Backscatter:
    """Arrival, amplitude and leading sign of the backscattered signal at one grain.

    ``signal`` and ``reference`` are one grain's velocity traces (sample,) in the chain with and
    without the impurity (SPEC sign: + into the chain); without a reference the raw signal is used.
    Only samples with ``after ≤ t ≤ until`` count (skip the incident pulse, stop before the far
    wall's reflection arrives). The leading sign is that of the first sample where |echo| reaches
    ``fraction`` of the echo's largest value.
    """
    t = np.asarray(t, dtype=float)
    echo = np.asarray(signal, dtype=float) - (0.0 if reference is None else np.asarray(reference, dtype=float))
    window = (t >= after) & (t <= until)
    tw, ew = t[window], echo[window]
    if ew.size == 0 or not np.any(ew != 0):
        return Backscatter(math.nan, 0.0, math.nan, 0, 0)
    magnitude = np.abs(ew)
    peak = int(np.argmax(magnitude))
    first = int(np.flatnonzero(magnitude >= fraction * magnitude[peak])[0])
    return Backscatter(float(tw[first]), float(magnitude[peak]), float(tw[peak]), int(np.sign(ew[first])),
                       int(np.sign(ew[peak])))


# ---- columns under gravity (Sec. V) --------------------------------------------------------


def column_sound_speed(depth, *, gravity: float, a: float = 5657.0, mass: float = 1.0,
                       exponent: float = 2.5):
    """Long-wave sound speed [grains/time] at contact ``depth`` (grains above it: depth + 1) of a
    column compacted by gravity alone (paper eq. 4): the contact carries F = g m (depth + 1), its
    static overlap is δ0 = (F/(n a))^(1/(n−1)), its stiffness K = n (n−1) a δ0^(n−2), and c = √(K/m).
    For Hertz (n = 5/2) c ∝ (depth + 1)^(1/6)."""
    n = exponent
    force = gravity * mass * (np.asarray(depth, dtype=float) + 1.0)
    overlap = (force / (n * a)) ** (1.0 / (n - 1.0))
    stiffness = n * (n - 1.0) * a * overlap ** (n - 2.0)
    return np.sqrt(stiffness / mass)


def depth_law(t, head, *, first_grain: float, last_grain: float, step: int = 4) -> PowerLawFit:
    """c(z) = C z^β fitted to the pulse speed against depth in a column (the paper: β = 1/6).

    Speeds are finite differences of the head positions ``head(t)`` over ``step`` records,
    attributed to the mid depth; only heads in [first_grain, last_grain] before the head first
    passes ``last_grain`` are used.
    """
    t, h = np.asarray(t, dtype=float), np.asarray(head, dtype=float)
    beyond = np.flatnonzero(h > last_grain)
    stop = beyond[0] if beyond.size else h.size
    t, h = t[:stop], h[:stop]
    speed = (h[step:] - h[:-step]) / (t[step:] - t[:-step])
    depth = 0.5 * (h[step:] + h[:-step])
    keep = np.isfinite(speed) & (depth >= first_grain) & (h[:-step] >= first_grain)
    return fit_power_law(depth[keep], speed[keep])


# ---- driven columns (Sec. VI) --------------------------------------------------------------


def kinetic_energy(v, mass=1.0):
    """½ m v² per grain [energy]."""
    return 0.5 * np.asarray(mass) * np.asarray(v, dtype=float) ** 2


def window_average(t, field, centres, width: float) -> np.ndarray:
    """Mean of snapshots ``field`` (..., record, grain) over records with |t − centre| ≤ width/2, for
    each centre → (..., len(centres), grain). NaN where a window holds no record."""
    t, f = np.asarray(t, dtype=float), np.asarray(field, dtype=float)
    out = []
    for centre in np.atleast_1d(centres):
        sel = np.abs(t - centre) <= 0.5 * width + 1e-9
        out.append(f[..., sel, :].mean(axis=-2) if np.any(sel) else np.full(f.shape[:-2] + f.shape[-1:], math.nan))
    return np.stack(out, axis=-2)


def _smooth(profile: np.ndarray, grains: int) -> np.ndarray:
    if grains <= 1:
        return profile
    kernel = np.ones(grains) / grains
    return np.convolve(profile, kernel, mode="same")


def profile_nodes(profile, *, smooth: int = 5, depth: float = 0.3) -> np.ndarray:
    """Nodes of a (time-averaged kinetic-energy) profile [grains]: local minima of the profile
    smoothed over ``smooth`` grains that lie below ``depth`` × the mean of the maxima on either
    side (so ripples are not counted)."""
    p = _smooth(np.asarray(profile, dtype=float), smooth)
    interior = np.arange(1, p.size - 1)
    minima = interior[(p[interior] < p[interior - 1]) & (p[interior] <= p[interior + 1])]
    nodes = []
    for k in minima:
        # the highest points between this minimum and its neighbouring minima bound its lobes
        lo = minima[minima < k]
        hi = minima[minima > k]
        left = p[(lo[-1] if lo.size else 0):k].max(initial=0.0)
        right = p[k + 1:(hi[0] if hi.size else p.size)].max(initial=0.0)
        if left > 0 and right > 0 and p[k] < depth * 0.5 * (left + right):
            nodes.append(k)
    return np.asarray(nodes, dtype=float)


@dataclass(frozen=True)
class StandingWave:
    """How long a pattern of time-averaged profiles stays put (Sec. VI), relative to the first profile."""

    correlation: np.ndarray
    """Pearson correlation of each smoothed profile with the first one, shape (windows,); 1 = the same
    shape (amplitude does not count), ~0 = unrelated."""
    nodes: tuple[np.ndarray, ...]
    """Node positions [grains] of each profile (:func:`profile_nodes`)."""
    node_spacing: float
    """Median distance between neighbouring nodes of the first profile [grains] (NaN with < 2 nodes)."""
    node_shift: np.ndarray
    """Median distance from each node of the first profile to the nearest node of each profile, in units
    of ``node_spacing``, shape (windows,): 0 = the nodes stay put; about 0.25 for unrelated nodes."""


def standing_wave_measure(profiles, *, smooth: int = 5, depth: float = 0.3,
                          grains: slice | None = None) -> StandingWave:
    """Compare time-averaged profiles ``profiles`` (window, grain) — e.g. kinetic energy averaged over
    consecutive windows — with the first one: shape correlation and node displacement. A standing
    wave keeps correlation near 1 and its nodes in place; a travelling or disordered pattern
    decorrelates and its nodes wander."""
    p = np.asarray(profiles, dtype=float)
    if grains is not None:
        p = p[:, grains]
    smoothed = np.array([_smooth(row, smooth) for row in p])
    nodes = tuple(profile_nodes(row, smooth=smooth, depth=depth) for row in p)
    first = smoothed[0]
    corr = np.array([float(np.corrcoef(first, row)[0, 1]) if np.std(first) > 0 and np.std(row) > 0 else math.nan
                     for row in smoothed])
    spacing = float(np.median(np.diff(nodes[0]))) if nodes[0].size >= 2 else math.nan
    shift = np.full(len(p), math.nan)
    for k, other in enumerate(nodes):
        if nodes[0].size and other.size and np.isfinite(spacing):
            shift[k] = float(np.median(np.abs(nodes[0][:, None] - other[None, :]).min(axis=1))) / spacing
    return StandingWave(corr, nodes, spacing, shift)


# ---- Nesterenko's long-wave soliton --------------------------------------------------------

NESTERENKO_SUPPORT = math.pi * math.sqrt(2.5)
"""Full width [grains] of Nesterenko's solitary wave, ψ ∝ cos⁴(√(2/5)·s) on |√(2/5)·s| ≤ π/2: π√(5/2) ≈ 4.97."""

NESTERENKO_FWHM = 2.0 * math.acos(2.0 ** -0.25) / math.sqrt(0.4)
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
