"""Driven columns (Sec. VI): window averages and the standing-wave measure at the paper's times."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


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


PAPER_DRIVE_TIMES = (60.0, 132.0, 204.0, 276.0, 492.0)
"""Times of Figs. 9(a)-(e) and 10(a)-(e) for the 10 000-grain column."""


PAPER_WINDOW = 1.5
"""Fig. 9's caption: snapshots averaged over 1.5 time units."""


def drive_times(grain_count: int) -> np.ndarray:
    """The paper's snapshot times, scaled for a shorter column by its travel time ∝ N^(5/6)."""
    return np.asarray(PAPER_DRIVE_TIMES) * (grain_count / 10000.0) ** (5.0 / 6.0)


PERSISTENCE_LAGS = 1.5 * np.arange(8)
"""Lags [time units] of the consecutive windows compared with a snapshot window (standing-wave measure)."""


def driven_windows(ds) -> dict:
    """Window-averaged profiles of a driven-column store at the paper's times (scaled to the column's
    length): ``taus``, ``centres``, ``ke`` and ``v`` (tau, centre, grain), and ``persistence``
    [tau][centre] — :func:`analysis.standing_wave_measure` of the kinetic-energy windows at
    centre + PERSISTENCE_LAGS. Reads a ``hertzian reproduce`` store (ke_window, v_window, window_lag) or
    averages velocity snapshots of a sweep store."""
    n = int(ds.sizes["grain"])
    taus = ds.tau.values
    if "ke_window" in ds.variables:
        lag = ds.window_lag.values
        block = ds.window_block.values
        starts = np.flatnonzero(lag == 0)
        centres = ds.window_t.values[starts]
        ke_all, v_all = ds.ke_window.values, ds.v_window.values
        ke, vel = ke_all[:, starts], v_all[:, starts]
        persistence = [[standing_wave_measure(ke_all[i, block == block[k]]) for k in starts]
                       for i in range(len(taus))]
    else:
        t = ds.t.values
        centres = drive_times(n)
        centres = centres[centres + 0.5 * PAPER_WINDOW <= t[-1] + 1e-9]
        v = ds.v.transpose("tau", "record", "grain").values
        energy = kinetic_energy(v)
        ke = window_average(t, energy, centres, PAPER_WINDOW)
        vel = window_average(t, v, centres, PAPER_WINDOW)
        persistence = []
        for i in range(len(taus)):
            rows = []
            for centre in centres:
                lagged = [c for c in centre + PERSISTENCE_LAGS if c + 0.5 * PAPER_WINDOW <= t[-1] + 1e-9]
                rows.append(standing_wave_measure(window_average(t, energy[i], lagged, PAPER_WINDOW)))
            persistence.append(rows)
    return {"taus": taus, "centres": centres, "ke": ke, "v": vel, "persistence": persistence}
