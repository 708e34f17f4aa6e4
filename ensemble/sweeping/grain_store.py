"""Per-point, per-grain variables of a sweep store for chains of unequal grains (docs/heterogeneous.md): ``radius`` and
``mass`` of every grain, so that any point can be rerun alone from its store."""

from __future__ import annotations

from typing import Any

import numpy as np
from hertzian.core.chains import ChainSet
from hertzian.core.static import static_arrays, static_state

GRAIN_ATTRS = {
    "radius": {"long_name": "grain radius R_i", "units": "1e-5 m"},
    "mass": {"long_name": "grain mass m (R_i/R0)^3 (an impurity's own where set)", "units": "2.36e-5 kg"},
}


def records_grains(scene) -> bool:
    """Whether a store records ``radius`` and ``mass``: its first point (``scene``) has a ``chain.radii`` form
    (every point of a sweep then has one: a radii axis sets it everywhere)."""
    return scene.chain.radii is not None


def grain_variables(sweep, scene, attrs: dict) -> list[dict[str, Any]]:
    """The ``radius`` and ``mass`` variables (dims …axes, grain; float64) where :func:`records_grains`;
    ``attrs``: the coordinates attribute every point variable carries."""
    if not records_grains(scene):
        return []
    return [
        dict(
            name=name,
            dims=sweep.dims + ("grain",),
            trailing=(scene.chain.grains,),
            dtype=np.dtype(np.float64),
            fill=np.nan,
            attrs={**GRAIN_ATTRS[name], **attrs},
        )
        for name in GRAIN_ATTRS
    ]


def grain_arrays(scenes) -> dict[str, np.ndarray]:
    """``radius`` and ``mass`` of every grain of every chain, shape (chains, N): from the per-chain arrays of a
    ChainSet (no scene per chain), else scene by scene."""
    if isinstance(scenes, ChainSet):
        st = static_arrays(scenes)
        half = 0.5 * scenes.column("chain.diameter")[:, None]
        ratio = 1.0 if st.radius_ratio is None else st.radius_ratio
        return {"radius": np.broadcast_to(ratio * half, st.mass.shape), "mass": st.mass}
    radius, mass = [], []
    for scene in scenes:
        ratios = scene.chain.radius_ratios
        half = 0.5 * scene.chain.diameter
        radius.append(np.full(scene.chain.grains, half) if ratios is None else ratios * half)
        mass.append(static_state(scene).mass)
    return {"radius": np.stack(radius), "mass": np.stack(mass)}
