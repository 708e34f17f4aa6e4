"""Per-point, per-grain variables of a sweep store for chains of unequal grains (docs/heterogeneous.md): ``radius`` and
``mass`` of every grain, and with ``chain.material`` each grain's ``material``, so that any point can be rerun alone
from its store."""

from __future__ import annotations

from typing import Any

import numpy as np
from hertzian.core.chains import ChainSet
from hertzian.core.static import static_arrays, static_state

GRAIN_ATTRS = {
    "radius": {"long_name": "grain radius R_i", "units": "1e-5 m"},
    "mass": {"long_name": "grain mass m (R_i/R0)^3 (an impurity's own where set)", "units": "2.36e-5 kg"},
}


MATERIAL_ATTRS = {"long_name": "grain material (index into flag_meanings)"}


def records_grains(scene) -> bool:
    """Whether a store records ``radius`` and ``mass``: its first point (``scene``) has a ``chain.radii`` form or
    ``chain.material`` (every point of a sweep then has one: an axis of either sets it everywhere)."""
    return scene.chain.radii is not None or scene.chain.material is not None


def material_names(scene) -> list[str]:
    """The names a store's ``material`` indexes: the shipped materials, then the scene's own."""
    from hertzian.core.materials import MATERIALS

    return [*MATERIALS, *(m.name for m in scene.materials)]


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
    ] + _material_variable(sweep, scene, attrs)


def _material_variable(sweep, scene, attrs: dict) -> list[dict[str, Any]]:
    """The ``material`` variable (dims …axes, grain; int16, -1 unset) of a scene with ``chain.material``."""
    if scene.chain.material is None:
        return []
    names = material_names(scene)
    meaning = {"flag_values": list(range(len(names))), "flag_meanings": " ".join(names)}
    return [
        dict(
            name="material",
            dims=sweep.dims + ("grain",),
            trailing=(scene.chain.grains,),
            dtype=np.dtype(np.int16),
            fill=-1,
            attrs={**MATERIAL_ATTRS, **meaning, **attrs},
        )
    ]


def grain_arrays(scenes) -> dict[str, np.ndarray]:
    """``radius`` and ``mass`` of every grain of every chain, shape (chains, N): from the per-chain arrays of a
    ChainSet (no scene per chain), else scene by scene."""
    if isinstance(scenes, ChainSet):
        st = static_arrays(scenes)
        half = 0.5 * scenes.column("chain.diameter")[:, None]
        ratio = 1.0 if st.radius_ratio is None else st.radius_ratio
        out = {"radius": np.broadcast_to(ratio * half, st.mass.shape), "mass": st.mass}
        if scenes.template.chain.material is not None:
            row = _material_row(scenes.template, scenes.template)
            out["material"] = np.broadcast_to(row, st.mass.shape)
        return out
    radius, mass, material = [], [], []
    for scene in scenes:
        ratios = scene.chain.radius_ratios
        half = 0.5 * scene.chain.diameter
        radius.append(np.full(scene.chain.grains, half) if ratios is None else ratios * half)
        mass.append(static_state(scene).mass)
        if scene.chain.material is not None:
            material.append(_material_row(scene, scenes[0]))
    out = {"radius": np.stack(radius), "mass": np.stack(mass)}
    if material:
        out["material"] = np.stack(material)
    return out


def _material_row(scene, first) -> np.ndarray:
    """Each grain's material of ``scene`` as an index into :func:`material_names` of the store's ``first`` scene."""
    from hertzian.core.materials import pattern_index

    names, index = pattern_index(scene.chain.material, scene.chain.grains)
    known = material_names(first)
    return np.array([known.index(name) for name in names], dtype=np.int16)[index]
