"""Echoes (Secs. IV, V): backscattering from impurity blocks, seen at a traced grain."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np
from hertzian.studies.analysis.pulses import head_positions, pulse_speed


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


def backscatter(
    t, signal, reference=None, *, after: float = 0.0, until: float = math.inf, fraction: float = 0.2
) -> Backscatter:
    """Arrival, amplitude and leading sign of the backscattered signal at one grain.

    ``signal`` and ``reference`` are one grain's velocity traces (sample,) in the chain with and
    without the impurity (docs/model.md's sign: + into the chain); without a reference the raw signal is used.
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
    return Backscatter(
        float(tw[first]), float(magnitude[peak]), float(tw[peak]), int(np.sign(ew[first])), int(np.sign(ew[peak]))
    )


def first_lobe(
    t, signal, reference=None, *, after: float = 0.0, until: float = math.inf, fraction: float = 0.05
) -> tuple[int, float]:
    """The echo's first lobe: its sign and its largest |echo| divided by the echo's largest, the lobe
    starting where |echo| first reaches ``fraction`` of the largest and ending at the next sign change."""
    t = np.asarray(t, dtype=float)
    echo = np.asarray(signal, dtype=float) - (0.0 if reference is None else np.asarray(reference, dtype=float))
    ew = echo[(t >= after) & (t <= until)]
    if ew.size == 0 or not np.any(ew != 0):
        return 0, math.nan
    largest = np.max(np.abs(ew))
    start = int(np.flatnonzero(np.abs(ew) >= fraction * largest)[0])
    sign = np.sign(ew[start])
    flips = np.flatnonzero(np.sign(ew[start:]) != sign)
    stop = start + (int(flips[0]) if flips.size else ew.size - start)
    return int(sign), float(np.max(np.abs(ew[start:stop])) / largest)


def impurity_points(ds):
    """Indices along impurity_mass of the light, heavy and clean chains (clean may be missing)."""
    masses = ds.impurity_mass.values
    light = int(np.flatnonzero(masses < 1.0)[0])
    heavy = int(np.flatnonzero(masses > 1.0)[0])
    clean = np.flatnonzero(masses == 1.0)
    return light, heavy, (int(clean[0]) if clean.size else None)


def impurity_grains(ds) -> list[int]:
    """Grains of the first impurity block of a store's scene (from its attributes)."""
    scene = json.loads(ds.attrs.get("scene", "{}"))
    blocks = scene.get("impurities", [])
    return list(blocks[0]["grains"]) if blocks else []


def echo_window(ds, traced_grain: int) -> tuple[float, float]:
    """Times (after, until) between which the echo from the impurity block reaches ``traced_grain``: from
    the clean chain's pulse reaching 10 grains short of the block and coming back, to the far wall's
    reflection arriving (clean chain's speed, from its snapshots)."""
    _, _, clean = impurity_points(ds)
    depth = float(np.mean(impurity_grains(ds)))
    clean_v = (
        ds.v.isel(impurity_mass=clean, contact=0).values
        if "contact" in ds.dims
        else ds.v.isel(impurity_mass=clean).values
    )
    speed = pulse_speed(ds.t.values, head_positions(clean_v), first_grain=20, last_grain=depth - 20).slope
    n = int(ds.sizes["grain"])
    after = (depth - 10 + (depth - 10 - traced_grain)) / speed if speed > 0 else 0.0
    until = (2 * n - 40 - traced_grain) / speed if speed > 0 else math.inf
    return after, until


def echo_table(
    ds, *, contact: str | None = None, traced: int | None = None, fraction: float = 0.2
) -> dict[str, Backscatter]:
    """Backscatter at a traced grain (default: the shallowest) for light and heavy impurities, against
    the clean chain of the same store; keys 'light/harmonic', 'heavy/own', … ``fraction``: the leading
    sign's threshold (see :func:`backscatter`)."""
    light, heavy, clean = impurity_points(ds)
    if clean is None:
        raise ValueError("the store has no clean reference chain (impurity_mass = 1)")
    t = ds.trace_t.values
    grains = ds.traced_grain.values
    column = 0 if traced is None else int(np.flatnonzero(grains == traced)[0])
    contacts = [contact] if contact else [str(c) for c in ds.contact.values]
    reference = ds.trace_v.isel(impurity_mass=clean, contact=0).values[:, column]
    after, until = echo_window(ds, int(grains[column]))
    table = {}
    for name, index in (("light", light), ("heavy", heavy)):
        for rule in contacts:
            signal = ds.trace_v.isel(impurity_mass=index).sel(contact=rule).values[:, column]
            table[f"{name}/{rule}"] = backscatter(t, signal, reference, after=after, until=until, fraction=fraction)
    return table


def echo_contrast(t, light, heavy, reference, *, after: float = 0.0, until: float = math.inf) -> float:
    """How different the light and heavy echoes are at one grain: ‖e_L − e_H‖ / (‖e_L‖ + ‖e_H‖) over
    ``after ≤ t ≤ until`` (e = signal − reference). 0: identical; 1: equal size, opposite sign; about
    0.7 for equal-size unrelated signals."""
    t = np.asarray(t, dtype=float)
    window = (t >= after) & (t <= until)
    ref = np.asarray(reference, dtype=float)[window]
    e_light = np.asarray(light, dtype=float)[window] - ref
    e_heavy = np.asarray(heavy, dtype=float)[window] - ref
    scale = np.linalg.norm(e_light) + np.linalg.norm(e_heavy)
    return float(np.linalg.norm(e_light - e_heavy) / scale) if scale > 0 else math.nan


def contrast_table(ds, *, traced: int | None = None) -> dict[str, float]:
    """:func:`echo_contrast` at a traced grain (default: the shallowest) per contact rule, over the
    echo's window (:func:`echo_window`)."""
    light, heavy, clean = impurity_points(ds)
    grains = ds.traced_grain.values
    column = 0 if traced is None else int(np.flatnonzero(grains == traced)[0])
    after, until = echo_window(ds, int(grains[column]))
    reference = ds.trace_v.isel(impurity_mass=clean, contact=0).values[:, column]
    out = {}
    for rule in [str(c) for c in ds.contact.values]:
        out[rule] = echo_contrast(
            ds.trace_t.values,
            ds.trace_v.isel(impurity_mass=light).sel(contact=rule).values[:, column],
            ds.trace_v.isel(impurity_mass=heavy).sel(contact=rule).values[:, column],
            reference,
            after=after,
            until=until,
        )
    return out


# ---- oscillations at the impurity site (Sec. IV) ------------------------------------------------


def power_spectrum(t, signal) -> tuple[np.ndarray, np.ndarray]:
    """One-sided power spectrum of a uniformly sampled signal (mean removed, Hann window):
    frequencies [cycles per time unit] and power (arbitrary units, same for every call with the same
    sampling and length)."""
    t = np.asarray(t, dtype=float)
    x = np.asarray(signal, dtype=float)
    x = (x - x.mean()) * np.hanning(x.size)
    freq = np.fft.rfftfreq(x.size, d=float(t[1] - t[0]))
    return freq, np.abs(np.fft.rfft(x)) ** 2


def linear_chain_modes(masses, stiffness) -> tuple[np.ndarray, np.ndarray]:
    """Normal modes of a linear chain between two rigid walls: ``masses`` (n,), ``stiffness`` (n + 1,)
    of the springs wall–0, 0–1, …, (n−1)–wall. Returns angular frequencies [rad per time unit],
    ascending, and the mass-weighted mode shapes (n, n), columns normalised to 1."""
    m = np.asarray(masses, dtype=float)
    k = np.asarray(stiffness, dtype=float)
    diagonal = (k[:-1] + k[1:]) / m
    off = -k[1:-1] / np.sqrt(m[:-1] * m[1:])
    matrix = np.diag(diagonal) + np.diag(off, 1) + np.diag(off, -1)
    eigenvalues, shapes = np.linalg.eigh(matrix)
    return np.sqrt(np.maximum(eigenvalues, 0.0)), shapes


def hertz_stiffness(a_contact, load: float):
    """Linearised stiffness K = (15/4) a δ^(1/2) of Hertz contacts F = (5/2) a δ^(3/2) carrying the static
    force ``load`` (program units)."""
    a_contact = np.asarray(a_contact, dtype=float)
    overlap = (load / (2.5 * a_contact)) ** (2.0 / 3.0)
    return 3.75 * a_contact * np.sqrt(overlap)
