"""Static state of a chain (SPEC §2): masses, contact constants, carried forces, static overlaps.

Contacts are stored *padded*, length N + 1: index ``k`` is the contact between grain
``k − 1`` and grain ``k``; ``k = 0`` is the surface wall and ``k = N`` the bottom wall.
(SPEC numbers the inner contact between grains i and i+1 as ``i``; here it is ``i + 1``.)
A padded slot without a contact (no wall at that end) has constant 0.

Contact ``k`` carries ``F0 + g Σ_{j<k} m_j`` — the paper's sum rule, eq. 4, plus a load —
and its static overlap is ``δ0 = (carried / (n a_c))^(1/(n−1))``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .scene import Scene


@dataclass(frozen=True)
class StaticState:
    """Static equilibrium of one chain, float64 numpy arrays."""

    mass: np.ndarray
    """Grain masses, shape (N,)."""
    self_constant: np.ndarray
    """Self-constant a_i of each grain, shape (N,)."""
    contact_constant: np.ndarray
    """a_c of each padded contact, shape (N + 1,); 0 where there is no contact."""
    carried_force: np.ndarray
    """Static force each padded contact carries, shape (N + 1,)."""
    static_overlap: np.ndarray
    """δ0 of each padded contact [length], shape (N + 1,)."""
    exponent: float
    surface_force: float
    """F0 [force]."""

    @property
    def grain_count(self) -> int:
        return self.mass.shape[0]


def contact_constants(scene: Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(masses (N,), self-constants (N,), padded contact constants (N+1,)) for a scene."""
    n_grains = scene.chain.grains
    mass = np.full(n_grains, scene.chain.mass)
    self_a = np.full(n_grains, scene.chain.a)
    own = np.zeros(n_grains, dtype=bool)
    for imp in scene.impurities:
        idx = np.asarray(imp.grains)
        if imp.mass is not None:
            mass[idx] = imp.mass
        if imp.a is not None:
            self_a[idx] = imp.a
        own[idx] = imp.contact == "own"

    left, right = self_a[:-1], self_a[1:]
    inner = 2.0 * left * right / (left + right)
    own_left, own_right = own[:-1], own[1:]
    inner = np.where(own_left & ~own_right, left, inner)
    inner = np.where(own_right & ~own_left, right, inner)
    # Equal grains must get exactly a (the harmonic mean rounds otherwise).
    inner = np.where(left == right, left, inner)

    padded = np.zeros(n_grains + 1)
    padded[1:n_grains] = inner
    if scene.boundary.surface == "wall":
        padded[0] = self_a[0]
    if scene.boundary.bottom == "wall":
        padded[n_grains] = self_a[-1]
    return mass, self_a, padded


def static_state(scene: Scene) -> StaticState:
    """Solve the static state of ``scene`` (exact; no relaxation needed)."""
    mass, self_a, a_c = contact_constants(scene)
    n = scene.chain.exponent
    f0 = scene.chain.surface_force
    g = scene.chain.gravity
    n_grains = mass.shape[0]
    carried = np.zeros(n_grains + 1)
    carried[1:] = f0 + g * np.cumsum(mass)
    carried[0] = f0
    carried[a_c == 0.0] = 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        overlap = np.where(carried > 0, (carried / (n * np.where(a_c > 0, a_c, 1.0))) ** (1.0 / (n - 1.0)), 0.0)
    return StaticState(mass=mass, self_constant=self_a, contact_constant=a_c, carried_force=carried,
                       static_overlap=overlap, exponent=n, surface_force=f0)
