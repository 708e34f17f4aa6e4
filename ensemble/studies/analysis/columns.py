"""Columns under gravity (Sec. V): the depth law c ∝ z^β, its closed form, tail bumps."""

from __future__ import annotations

import numpy as np
from hertzian.studies.analysis.common import PowerLawFit, fit_power_law


def column_sound_speed(depth, *, gravity: float, a: float = 5657.0, mass: float = 1.0, exponent: float = 2.5):
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


def speed_against_depth(t, heads, *, last_grain: float, step: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """(depth, speed): finite-difference pulse speed over ``step`` records against the head's mean depth,
    up to the record where the head passes ``last_grain``."""
    t = np.asarray(t, dtype=float)
    heads = np.asarray(heads, dtype=float)
    beyond = np.flatnonzero(heads > last_grain)
    stop = beyond[0] if beyond.size else len(t)
    h = heads[:stop]
    speed = (h[step:] - h[:-step]) / (t[step:stop] - t[: stop - step])
    return 0.5 * (h[step:] + h[:-step]), speed
