"""Echoes (Secs. IV, V): backscattering from impurity blocks, seen at a traced grain."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np

from .pulses import head_positions, pulse_speed


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


def echo_table(ds, *, contact: str | None = None, traced: int | None = None) -> dict[str, Backscatter]:
    """Backscatter at a traced grain (default: the shallowest) for light and heavy impurities, against
    the clean chain of the same store; keys 'light/harmonic', 'heavy/own', …"""
    light, heavy, clean = impurity_points(ds)
    if clean is None:
        raise ValueError("the store has no clean reference chain (impurity_mass = 1)")
    t = ds.trace_t.values
    grains = ds.traced_grain.values
    column = 0 if traced is None else int(np.flatnonzero(grains == traced)[0])
    depth = float(np.mean(impurity_grains(ds)))
    contacts = [contact] if contact else [str(c) for c in ds.contact.values]
    reference = ds.trace_v.isel(impurity_mass=clean, contact=0).values[:, column]
    clean_v = ds.v.isel(impurity_mass=clean, contact=0).values
    speed = pulse_speed(ds.t.values, head_positions(clean_v), first_grain=20, last_grain=depth - 20).slope
    n = int(ds.sizes["grain"])
    grain = int(grains[column])
    after = (depth - 10 + (depth - 10 - grain)) / speed if speed > 0 else 0.0
    until = (2 * n - 40 - grain) / speed if speed > 0 else math.inf
    table = {}
    for name, index in (("light", light), ("heavy", heavy)):
        for rule in contacts:
            signal = ds.trace_v.isel(impurity_mass=index).sel(contact=rule).values[:, column]
            table[f"{name}/{rule}"] = backscatter(t, signal, reference, after=after, until=until)
    return table
