"""Bead materials: Young's modulus E, Poisson's ratio ν and density ρ (SI) turned into a chain's masses and Hertz
contact constants in program units (docs/heterogeneous.md, "Materials").

A chain with ``chain.material`` (one name, or a pattern of names repeated along the chain) takes every grain's mass
and every contact's constant from its materials instead of ``chain.mass`` and ``chain.a``. Grain i of radius
R_i = r_i·R0 (R0 = diameter/2, ``chain.radii`` for r_i) and material (E_i, ν_i, ρ_i) has

* mass m_i = ρ_i (4/3) π R_i³;
* with grain j, Hertz's law F = (4/3) E* √R* δ^{3/2}, i.e. V = a δ^{5/2} with a = (8/15) E* √R*, where
  1/E* = (1 − ν_i²)/E_i + (1 − ν_j²)/E_j and R* = R_i R_j/(R_i + R_j);
* with a flat wall of material w (``boundary.wall_material``, default: the touching grain's own), the same law with
  R* = R_i and E* from grain i and the wall.

Program units: length 1e-5 m, mass 2.36e-5 kg, time 1.0102e-3 s, so a pressure unit is
2.36e-5 kg / (1e-5 m · (1.0102e-3 s)²) ≈ 2.313e6 Pa and a density unit 2.36e-5 kg / (1e-5 m)³ = 2.36e10 kg/m³.
A chain without ``chain.material`` is the paper's (``chain.mass``, ``chain.a``) and is computed as before.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

LENGTH_M = 1e-5
"""The program's length unit [m]."""
MASS_KG = 2.36e-5
"""The program's mass unit [kg]."""
TIME_S = 1.0102e-3
"""The program's time unit [s]."""
PRESSURE_PA = MASS_KG / (LENGTH_M * TIME_S**2)
"""The program's pressure (and Young's modulus) unit [Pa]."""
DENSITY_KG_M3 = MASS_KG / LENGTH_M**3
"""The program's density unit [kg/m³]."""


@dataclass(frozen=True)
class Material:
    """A bead or wall material in SI units."""

    youngs_modulus: float
    """E [Pa]."""
    poisson_ratio: float
    """ν (dimensionless, −1 < ν < 0.5)."""
    density: float
    """ρ [kg/m³]."""
    source: str = ""
    """Where the values come from."""

    @property
    def compliance(self) -> float:
        """(1 − ν²)/E in program units [1/pressure]: 1/E* of two materials is the sum of theirs."""
        return (1.0 - self.poisson_ratio**2) / (self.youngs_modulus / PRESSURE_PA)

    @property
    def program_density(self) -> float:
        """ρ in program units [mass/length³]."""
        return self.density / DENSITY_KG_M3


MATERIALS = {
    "stainless_steel": Material(
        193e9,
        0.30,
        8000.0,
        "stainless steel (AISI 316): C. Daraio, V. F. Nesterenko, E. B. Herbold and S. Jin, "
        "Phys. Rev. Lett. 96, 058002 (2006)",
    ),
    "ptfe": Material(
        1.46e9,
        0.46,
        2200.0,
        "PTFE (Teflon), E measured from solitary-wave speeds in bead chains (the dynamic modulus; static handbook "
        "values are 0.4-0.6 GPa): C. Daraio, V. F. Nesterenko, E. B. Herbold and S. Jin, Phys. Rev. E 72, 016603 "
        "(2005)",
    ),
    "aluminium": Material(
        69e9,
        0.33,
        2700.0,
        "aluminium alloy 6061-T6: FreeCAD standard material library (FreeCAD 0.20), card Aluminum-6061-T6.FCMat",
    ),
    "glass": Material(
        72e9,
        0.22,
        2520.0,
        "soda-lime glass: FreeCAD standard material library (FreeCAD 0.20), card Glass-Generic.FCMat",
    ),
}
"""Materials shipped with the package, by name; a scene adds its own in a ``[materials.NAME]`` table."""


def reference_masses(materials: list[Material], diameter: np.ndarray) -> np.ndarray:
    """Mass of a grain of radius R0 = diameter/2 of each material, shape (chains, materials) [mass]."""
    radius = 0.5 * np.asarray(diameter, dtype=np.float64)[:, None]
    density = np.array([m.program_density for m in materials])[None, :]
    return density * (4.0 / 3.0 * math.pi) * radius**3


def chain_constants(
    index: np.ndarray,
    materials: list[Material],
    wall: Material | None,
    diameter: np.ndarray,
    ratios: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(masses, self-constants, inner contact constants, wall constants) of chains of ``len(index)`` grains whose
    grain i is of material ``materials[index[i]]``, one row per entry of ``diameter`` [length] (radius ratios
    ``ratios`` (chains, N), None for equal grains), shapes (chains, N), (chains, N), (chains, N − 1) and
    (chains, 2) (the surface wall's and the bottom wall's, a ``wall`` of None being each grain's own material).

    The self-constant of grain i is the constant of two grains like it: (8/15) √(R_i/2)/(2 c_i), c = (1 − ν²)/E."""
    diameter = np.asarray(diameter, dtype=np.float64)
    half = 0.5 * diameter[:, None]  # R0
    r = np.ones((len(diameter), len(index))) if ratios is None else np.asarray(ratios, dtype=np.float64)
    compliance = np.array([m.compliance for m in materials])[index][None, :]
    mass = reference_masses(materials, diameter)[:, index] * r**3
    radius = half * r
    self_a = (8.0 / 15.0) * np.sqrt(0.5 * radius) / (2.0 * compliance)
    left, right = radius[:, :-1], radius[:, 1:]
    reduced = left * right / (left + right)
    inner = (8.0 / 15.0) * np.sqrt(reduced) / (compliance[:, :-1] + compliance[:, 1:])
    ends = np.stack([radius[:, 0], radius[:, -1]], axis=1)
    end_compliance = compliance[:, [0, -1]]
    wall_compliance = end_compliance if wall is None else np.full_like(end_compliance, wall.compliance)
    walls = (8.0 / 15.0) * np.sqrt(ends) / (end_compliance + wall_compliance)
    return mass, self_a, inner, walls


def pattern_index(pattern: tuple[str, ...], grains: int) -> tuple[list[str], np.ndarray]:
    """(distinct names in first-use order, index of each grain's name) of ``pattern`` repeated along ``grains``."""
    names = list(dict.fromkeys(pattern))
    per_grain = np.array([names.index(name) for name in pattern], dtype=np.int64)
    return names, np.resize(per_grain, grains)


def scene_material(scene, name: str) -> Material:
    """The material ``name`` of a scene: its own ``[materials]`` table's, else the shipped one."""
    own = {m.name: m for m in scene.materials}
    return own[name].material() if name in own else MATERIALS[name]


def scene_constants(scene, diameter: np.ndarray, ratios: np.ndarray | None, grains: int):
    """:func:`chain_constants` of the first ``grains`` grains of chains of ``scene``'s ``chain.material`` and
    ``boundary.wall_material``, one row per entry of ``diameter`` (radius ratios ``ratios``, rows of N or None)."""
    names, index = pattern_index(scene.chain.material, scene.chain.grains)
    wall = scene.boundary.wall_material
    return chain_constants(
        index[:grains],
        [scene_material(scene, name) for name in names],
        None if wall is None else scene_material(scene, wall),
        diameter,
        None if ratios is None else ratios[:, :grains],
    )
