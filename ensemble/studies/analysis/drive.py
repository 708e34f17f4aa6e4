"""Driven columns (Sec. VI): window averages and the standing-wave measure at the paper's times."""

from __future__ import annotations

import json
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
        left = p[(lo[-1] if lo.size else 0) : k].max(initial=0.0)
        right = p[k + 1 : (hi[0] if hi.size else p.size)].max(initial=0.0)
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


def standing_wave_measure(
    profiles, *, smooth: int = 5, depth: float = 0.3, grains: slice | None = None
) -> StandingWave:
    """Compare time-averaged profiles ``profiles`` (window, grain) — e.g. kinetic energy averaged over
    consecutive windows — with the first one: shape correlation and node displacement. A standing
    wave keeps correlation near 1 and its nodes in place; a travelling or disordered pattern
    decorrelates and its nodes wander."""
    p = np.asarray(profiles, dtype=float)
    if grains is not None:
        p = p[:, grains]
    nodes = tuple(profile_nodes(row, smooth=smooth, depth=depth) for row in p)
    corr = profile_correlation(p, smooth=smooth)
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
        persistence = [[standing_wave_measure(ke_all[i, block == block[k]]) for k in starts] for i in range(len(taus))]
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


# ---- response maps (docs/drive.md): per-point numbers from response windows -------------------------

MAP_METRICS = (
    "swr",
    "node_count",
    "node_drift",
    "bottom_ke_fraction",
    "work_growth",
    "late_power",
    "driver_open",
    "label",
)
"""Per-point numbers of :func:`response_map`, in the order of the table."""

LABELS = ("periodic", "quasi-periodic", "chaotic", "unknown")
"""Codes 0 … 3 of the stroboscopic label (:func:`strobe_label`)."""


def standing_wave_ratio(amplitude, *, interior: slice = slice(1, -1)) -> float:
    """max |V_1| / min |V_1| over the interior grains (the driven grain and a held bottom grain left out):
    1 for a pure travelling wave, ∞ for a pure standing wave with an exact node."""
    a = np.abs(np.asarray(amplitude))[interior]
    low = float(a.min()) if a.size else math.nan
    return float(a.max()) / low if low > 0 else math.inf


def node_drift(amplitudes, *, smooth: int = 1, depth: float = 0.3) -> tuple[np.ndarray, np.ndarray]:
    """Nodes of |V_1| (:func:`profile_nodes`) in each window and the drift between successive windows:
    (node counts per window, median |shift| of each node to the nearest node of the next window [grains])."""
    nodes = [profile_nodes(np.abs(row)[1:-1], smooth=smooth, depth=depth) + 1 for row in np.asarray(amplitudes)]
    counts = np.array([n.size for n in nodes])
    drift = np.array(
        [
            float(np.median(np.abs(a[:, None] - b[None, :]).min(axis=1))) if a.size and b.size else math.nan
            for a, b in zip(nodes[:-1], nodes[1:])
        ]
    )
    return counts, drift


def strobe_samples(trace_t, trace, period: float, *, since: float = 0.0) -> np.ndarray:
    """Trace samples (sample, traced) at t = nτ (within 1e-9 of a whole number of periods), t ≥ since."""
    t = np.asarray(trace_t, dtype=float)
    phase = t / period
    at = (np.abs(phase - np.rint(phase)) <= 1e-9 * np.maximum(phase, 1.0)) & (t >= since - 1e-12)
    return np.asarray(trace)[at]


def strobe_label(samples, *, periodic_tol: float = 1e-3, max_period: int = 8, peak_fraction: float = 0.9) -> int:
    """Stroboscopic label of a drive's response (an index into :data:`LABELS`) from samples (n, traced)
    of a few grains at t = nτ after the transient:

    * periodic — the sequence repeats with some period p ≤ ``max_period``: max |x_{n+p} − x_n| ≤
      ``periodic_tol`` × the samples' range (period-p orbits count as periodic);
    * quasi-periodic — not periodic, but the power spectrum of the (mean-removed) sequence has
      ``peak_fraction`` of its power in its 2·traced largest lines (a discrete spectrum);
    * chaotic — a broadband spectrum;
    * unknown — fewer than 16 samples.
    """
    x = np.asarray(samples, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    if x.shape[0] < 16:
        return 3
    scale = float(np.ptp(x)) or 1.0
    for p in range(1, max_period + 1):
        if float(np.max(np.abs(x[p:] - x[:-p]))) <= periodic_tol * scale:
            return 0
    y = x - x.mean(axis=0)
    power = (np.abs(np.fft.rfft(y * np.hanning(len(y))[:, None], axis=0)) ** 2).sum(axis=1)[1:]
    total = float(power.sum())
    if total == 0:
        return 0
    lines = 2 * x.shape[1]
    # a line spreads over ~3 bins under the Hann window
    top = np.sort(power)[::-1][: 3 * lines].sum()
    return 1 if top / total >= peak_fraction else 2


def point_scene_value(point, key: str) -> float:
    """A scene key's value at one point of a store: the sweep axis with that ``scene_key``, else the
    store's base scene."""
    for name, coord in point.coords.items():
        if coord.attrs.get("scene_key") == key and coord.size == 1:
            return float(coord.values)
    section, name = key.split(".")
    return float(json.loads(point.attrs["scene"])[section][name])


def point_response_numbers(point, *, bottom_fraction: float = 0.1) -> dict:
    """The map's numbers for one point of a store with response windows (an xarray Dataset of one point):
    standing-wave ratio of |V_1| in the last window, node count and drift between successive windows,
    the bottom ``bottom_fraction`` of the column's share of the last window's kinetic energy, the growth
    of W (mean driver power over the second half of the run divided by that over the first half; 1 =
    steady, ≫ 1 = growing; < 0: W fell in the second half) and that late mean power, the driver-open fraction of the last window, and the stroboscopic label
    (traced grains at t = nτ after the first window's start; needs ``record.traces`` with
    ``trace_every`` dividing τ)."""
    v1 = point.response.sel(harmonic=1).values  # (window, grain)
    counts, drift = node_drift(v1)
    ke = point.window_ke.values[-1]
    n = ke.size
    bottom = float(ke[n - max(1, int(round(bottom_fraction * n))) :].sum() / ke.sum()) if ke.sum() > 0 else math.nan
    t, work = point.t.values, point.work.values
    half = len(t) // 2
    growth = second = math.nan
    if half >= 1 and len(t) - 1 > half:
        first = (work[half] - work[0]) / (t[half] - t[0])
        second = float((work[-1] - work[half]) / (t[-1] - t[half]))
        growth = float(second / first) if first != 0 else math.nan
    label = 3
    if "trace_v" in point.variables:
        period = point_scene_value(point, "excitation.drive_period")
        if period is not None:
            since = float(point.window_start.values[0])
            samples = strobe_samples(
                point.trace_t.values,
                np.concatenate([point.trace_u.values, point.trace_v.values], axis=-1),
                period,
                since=since,
            )
            label = strobe_label(samples)
    return {
        "swr": standing_wave_ratio(v1[-1]),
        "node_count": int(counts[-1]),
        "node_drift": float(np.nanmax(drift)) if drift.size and np.any(np.isfinite(drift)) else math.nan,
        "bottom_ke_fraction": bottom,
        "work_growth": growth,
        "late_power": second,
        "driver_open": float(point.driver_open.values[-1]),
        "label": int(label),
    }


def response_map(ds) -> dict:
    """:func:`point_response_numbers` at every point of a sweep store with response windows:
    {"dims": sweep dims, "coords": {dim: values}, metric: array over the dims}."""
    dims = [str(d) for d in ds.status.dims]
    shape = tuple(int(ds.sizes[d]) for d in dims)
    out = {m: np.full(shape, math.nan) for m in MAP_METRICS}
    for index in np.ndindex(*shape):
        point = ds.isel(dict(zip(dims, index)))
        if int(point.status) < 0:
            continue
        for key, value in point_response_numbers(point).items():
            out[key][index] = value
    return {"dims": dims, "coords": {d: ds[d].values for d in dims}, **out}


# ---- Sec. VI at the paper's own timescale: lag correlation and the standing fraction ----------------


def profile_correlation(profiles, *, smooth: int = 5) -> np.ndarray:
    """Pearson correlation of each profile of ``profiles`` (lag, grain) with the first, after smoothing
    each over ``smooth`` grains, shape (lag,): 1 = the same shape (amplitude does not count), ~0 =
    unrelated. NaN where a profile is constant."""
    smoothed = np.array([_smooth(np.asarray(row, dtype=float), smooth) for row in profiles])
    first = smoothed[0]
    return np.array(
        [
            float(np.corrcoef(first, row)[0, 1]) if np.std(first) > 0 and np.std(row) > 0 else math.nan
            for row in smoothed
        ]
    )


def column_wave_phase(omega: float, grains: int, *, gravity: float, a: float = 5657.0, mass: float = 1.0):
    """Accumulated phase φ(z) = Σ_{j<z} k_j [radians] of a linear wave of angular frequency ``omega``
    [1/time] from the surface to grain z of a column compacted by gravity, with the local wavenumber of
    the discrete chain's dispersion ω = 2 c sin(k/2), c = √(K/m) of the contact below the grain
    (:func:`column_sound_speed`). NaN where ω exceeds the band edge 2c (only a top layer can: the
    column is softest at the surface)."""
    from hertzian.studies.analysis.columns import column_sound_speed

    c = column_sound_speed(np.arange(grains), gravity=gravity, a=a, mass=mass)
    ratio = omega / (2.0 * c)
    k = np.where(ratio < 1.0, 2.0 * np.arcsin(np.minimum(ratio, 1.0)), math.nan)
    phase = np.cumsum(np.nan_to_num(k))
    return np.where(np.isnan(k), math.nan, phase - phase[0])


@dataclass(frozen=True)
class TwoWaves:
    """Forward and backward waves at one frequency, fitted per stretch of one local wavelength."""

    centre: np.ndarray
    """Mean grain of each stretch [grains]."""
    forward: np.ndarray
    """|F|: amplitude of the wave moving into the column (away from the driver) [velocity]."""
    backward: np.ndarray
    """|B|: amplitude of the wave moving toward the surface [velocity]."""
    residual: np.ndarray
    """‖V − fit‖ / ‖V‖ per stretch: 0 = two waves describe the stretch exactly."""

    @property
    def standing_fraction(self) -> np.ndarray:
        """s = 2 min(|F|, |B|) / (|F| + |B|) = 1 − 1/SWR: 1 = a pure standing wave, 0 = a pure travelling
        wave, 2r/(1 + r) for a reflection of amplitude ratio r ≤ 1."""
        total = self.forward + self.backward
        return np.where(
            total > 0, 2.0 * np.minimum(self.forward, self.backward) / np.where(total > 0, total, 1.0), math.nan
        )


def fit_two_waves(amplitude, phase, *, first_grain: int = 1) -> TwoWaves:
    """Fit V(z) = F e^{−iφ(z)} + B e^{iφ(z)} by least squares on each stretch of grains over which the
    phase ``phase`` (:func:`column_wave_phase`) advances by 2π, from ``first_grain`` on (a last, shorter
    stretch only if it spans at least π).

    ``amplitude`` is the complex velocity amplitude at the drive frequency per grain (a response window's
    ``response`` at harmonic 1, v = Re(V e^{iωt})), so e^{−iφ} travels toward larger z. F and B may vary
    from stretch to stretch (a WKB description of a column whose sound speed grows with depth)."""
    v = np.asarray(amplitude, dtype=complex)
    phi = np.asarray(phase, dtype=float)
    usable = np.flatnonzero(np.isfinite(phi))
    usable = usable[usable >= first_grain]
    if usable.size == 0:
        empty = np.zeros(0)
        return TwoWaves(empty, empty, empty, empty)
    turn = np.floor((phi[usable] - phi[usable[0]]) / (2.0 * math.pi)).astype(int)
    last = usable[turn == turn[-1]]
    rows = []
    # the last, partial stretch counts if it spans half a wavelength (else F and B are ill-determined)
    for n in range(turn[-1] + (1 if phi[last[-1]] - phi[last[0]] >= math.pi else 0)):
        z = usable[turn == n]
        basis = np.stack([np.exp(-1j * phi[z]), np.exp(1j * phi[z])], axis=1)
        (f, b), *_ = np.linalg.lstsq(basis, v[z], rcond=None)
        norm = np.linalg.norm(v[z])
        rows.append((z.mean(), abs(f), abs(b), np.linalg.norm(v[z] - basis @ (f, b)) / norm if norm else math.nan))
    centre, forward, backward, residual = (np.array(col) for col in zip(*rows)) if rows else [np.zeros(0)] * 4
    return TwoWaves(centre, forward, backward, residual)


def point_standing_fraction(point) -> dict:
    """The two-wave fit (:func:`fit_two_waves`) of every response window of one point (an xarray Dataset of
    one point with ``response``): per window the median standing fraction over the column's stretches and
    the median fit residual; the depth profile (stretch centres, median standing fraction over the second
    half of the windows, after the drive has filled the column); and that median over depth."""
    tau = point_scene_value(point, "excitation.drive_period")
    gravity = point_scene_value(point, "chain.gravity")
    v1 = point.response.sel(harmonic=1).values  # (window, grain)
    phase = column_wave_phase(2.0 * math.pi / tau, v1.shape[-1], gravity=gravity)
    fits = [fit_two_waves(row, phase) for row in v1]
    fraction = np.array([f.standing_fraction for f in fits])  # (window, stretch)
    if fraction.shape[1] == 0:
        return {"window_start": point.window_start.values.tolist(), "fraction": math.nan, "note": "under π of phase"}
    late = fraction[len(fits) // 2 :]
    observed = float(np.nanmedian(late))
    null = surrogate_fractions(v1[len(fits) // 2 :], phase)
    band = np.nanpercentile(null, [2.5, 97.5]).tolist()
    return {
        "window_start": point.window_start.values.tolist(),
        "window_fraction": np.nanmedian(fraction, axis=1).tolist(),
        "window_residual": [float(np.nanmedian(f.residual)) for f in fits],
        "depth": fits[0].centre.tolist(),
        "depth_fraction": np.nanmedian(late, axis=0).tolist(),
        "fraction": observed,
        "fraction_quartiles": np.nanpercentile(late, [25, 75]).tolist(),
        "residual": float(np.nanmedian([f.residual for f in fits[len(fits) // 2 :]])),
        "null_median": float(np.nanmedian(null)),
        "null_band": band,
        "verdict": standing_verdict(observed, band),
        **kinetic_energy_shares(point, len(fits) // 2),
    }


NULL_SURROGATES = 200
"""Phase-randomised surrogates per point for the standing fraction's null distribution."""
NULL_SEED = 20261129
"""Seed of the surrogates' phases (a point's null is reproducible)."""


def surrogate_fractions(v1, phase, *, count: int = NULL_SURROGATES, seed: int = NULL_SEED) -> np.ndarray:
    """The standing fraction's null distribution for the windows ``v1`` (window, grain) of one point: each surrogate
    keeps every grain's |V₁| and draws its phase uniformly and independently, which keeps the amplitude profile and
    destroys any wave (forward, backward or standing); its statistic is the median s over windows and stretches, as
    for the data. Returns ``count`` such medians."""
    rng = np.random.default_rng(seed)
    rows = np.asarray(v1, dtype=complex)
    out = np.empty(count)
    for n in range(count):
        shuffled = np.abs(rows) * np.exp(2j * math.pi * rng.random(rows.shape))
        fractions = [fit_two_waves(row, phase).standing_fraction for row in shuffled]
        out[n] = np.nanmedian(np.concatenate(fractions)) if any(f.size for f in fractions) else math.nan
    return out


def standing_verdict(observed: float, band: list[float]) -> str:
    """'standing' above the null's 95 % band, 'travelling' below it, else 'not distinguished from the null'."""
    low, high = band
    if not math.isfinite(observed) or not (math.isfinite(low) and math.isfinite(high)):
        return "undetermined"
    if observed > high:
        return "standing"
    if observed < low:
        return "travelling"
    return "not distinguished from the null"


def kinetic_energy_shares(point, first_window: int) -> dict:
    """Share of the window-averaged kinetic energy at each harmonic of the drive, summed over the column, median over
    the windows from ``first_window`` on: ½ m |V₀|² at k = 0 and ½ m |V_k|²/2 at k ≥ 1 (v = V₀ + Σ Re(V_k e^{ikωt}))
    over ``window_ke``. ``ke_share_other`` is the rest: the energy at frequencies that are not harmonics of the
    drive (and the harmonics above the highest stored). ``ke_share_null``: :func:`shuffled_share_bound`, and
    ``ke_share_verdict`` whether the share at ω lies above it."""
    mass = np.asarray(point["mass"].values, dtype=float) if "mass" in point else point_scene_value(point, "chain.mass")
    response = np.asarray(point.response.values, dtype=complex)[first_window:]  # (window, harmonic, grain)
    ke = np.asarray(point.window_ke.values, dtype=float)[first_window:].sum(axis=-1)  # (window,)
    weight = np.where(np.arange(response.shape[1]) == 0, 1.0, 0.5)[None, :, None]
    per_harmonic = (0.5 * mass * weight * np.abs(response) ** 2).sum(axis=-1) / ke[:, None]  # (window, harmonic)
    shares = np.nanmedian(per_harmonic, axis=0)
    other = np.nanmedian(1.0 - per_harmonic.sum(axis=1))
    null = shuffled_share_bound(point)
    return {
        "ke_share_harmonics": shares.tolist(),
        "ke_share_drive": float(shares[1]),
        "ke_share_other": float(other),
        "ke_share_null": null,
        "ke_share_verdict": "above the null" if shares[1] > null else "not above the null",
    }


def shuffled_share_bound(point) -> float:
    """The null of the share of kinetic energy at ω: what a grain's motion keeps at ω once its S samples in a window
    are shuffled in time (which keeps its values and destroys any frequency). For S samples of mean μ and variance
    σ², the shuffled V₁ = (2/S) Σ v_s e^(−iωt_s) has E|V₁|² = 4σ²/S, so its share ½ m E|V₁|²/2 over ½ m (μ² + σ²)
    is 2σ²/(S (μ² + σ²)) ≤ 2/S, summed over the grains as well; this returns 2/S (S: the response samples of one
    window, ``record.response_periods`` periods at ``response_stride_of``'s stride)."""
    from hertzian.core.scene import response_stride_of

    period_steps = round(
        point_scene_value(point, "excitation.drive_period") / point_scene_value(point, "integrator.dt")
    )
    samples = (
        int(point_scene_value(point, "record.response_periods")) * period_steps // response_stride_of([period_steps])
    )
    return 2.0 / samples


def store_provenance(ds, store) -> dict:
    """What a record of numbers reduced from a store names about it: the store, its device, step, scene's grains
    and duration, the package version, and the date of the reduction."""
    from datetime import date

    prov = dict(ds.attrs.get("provenance", {}))
    scene = json.loads(ds.attrs["scene"]) if "scene" in ds.attrs else {}
    return {
        "store": str(store),
        "device": prov.get("device"),
        "dt": prov.get("dt"),
        "grains": prov.get("grains"),
        "duration": scene.get("integrator", {}).get("duration"),
        "package_version": prov.get("package_version"),
        "date": date.today().isoformat(),
    }


def standing_fractions(ds) -> list[dict]:
    """:func:`point_standing_fraction` at every point of a sweep store with response windows, each with its
    sweep coordinates."""
    dims = [str(d) for d in ds.status.dims]
    rows = []
    for index in np.ndindex(*(int(ds.sizes[d]) for d in dims)):
        point = ds.isel(dict(zip(dims, index)))
        coords = {d: float(ds[d].values[i]) for d, i in zip(dims, index)}
        rows.append({**coords, **(point_standing_fraction(point) if int(point.status) >= 0 else {})})
    return rows
