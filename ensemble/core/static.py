"""Static state of a chain (SPEC §2): masses, contact constants, carried forces, static overlaps.

Contacts are stored *padded*, length N + 1: index ``k`` is the contact between grain
``k − 1`` and grain ``k``; ``k = 0`` is the surface wall and ``k = N`` the bottom wall.
(SPEC numbers the inner contact between grains i and i+1 as ``i``; here it is ``i + 1``.)
A padded slot without a contact (no wall at that end) has constant 0.

Contact ``k`` carries ``F0 + g Σ_{j<k} m_j`` — the paper's sum rule, eq. 4, plus a load —
and its static overlap is ``δ0 = (carried / (n a_c))^(1/(n−1))``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
from hertzian.core.scene import Scene

STATIC_KEYS = ("chain.mass", "chain.a", "chain.exponent", "chain.l0", "chain.load", "chain.gravity")
"""Per-chain keys the static state reads (with ``impurities.K.mass|a``)."""
IMPURITY_STATIC = re.compile(r"^impurities\.(\d+)\.(mass|a)$")


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
    return StaticState(
        mass=mass,
        self_constant=self_a,
        contact_constant=a_c,
        carried_force=carried,
        static_overlap=overlap,
        exponent=n,
        surface_force=f0,
    )


# ---- many chains at once -------------------------------------------------------------------


@dataclass(frozen=True)
class StaticArrays:
    """Static equilibrium of a :class:`~hertzian.core.chains.ChainSet`, one row per chain, float64.

    Row ``c`` equals, bit for bit, :func:`static_state` of the set's scene ``c`` (its leading
    columns when computed for the first grains only).
    """

    mass: np.ndarray
    """Grain masses, shape (chains, N)."""
    self_constant: np.ndarray
    """Self-constants, shape (chains, N)."""
    contact_constant: np.ndarray
    """a_c of each padded contact, shape (chains, N + 1)."""
    carried_force: np.ndarray
    """Static force of each padded contact, shape (chains, N + 1)."""
    static_overlap: np.ndarray
    """δ0 of each padded contact [length], shape (chains, N + 1)."""
    exponent: np.ndarray
    """n per chain, shape (chains,)."""
    surface_force: np.ndarray
    """F0 per chain [force], shape (chains,)."""


def _surface_force(load, l0, exponent, a) -> float:
    # ChainSpec.surface_force, on Python floats (load NaN = unset)
    if load == load:
        return float(load)
    if l0 == 0.0:
        return 0.0
    return exponent * a * l0 ** (exponent - 1.0)


def _power_by_exponent(base: np.ndarray, exponent: np.ndarray, power) -> np.ndarray:
    """``base ** power(n)`` row by row, with one numpy call per distinct n (a Python-float power, as the
    per-scene code computes it)."""
    out = np.empty_like(base)
    for n in np.unique(exponent).tolist():
        rows = exponent == n
        out[rows] = base[rows] ** power(n)
    return out


def _static_columns(chains) -> list[str]:
    """The varying per-chain keys that the static state depends on (not the impact, drive, damping or
    diameter, which vary in a sweep without changing it)."""
    return [k for k in chains.values if k in STATIC_KEYS or IMPURITY_STATIC.match(k)]


def distinct_static_rows(chains) -> tuple[np.ndarray, np.ndarray] | None:
    """(first index of each distinct static configuration, configuration of every chain), or None when
    every chain is its own configuration (nothing to share)."""
    from hertzian.core.chains import row_codes

    keys = _static_columns(chains)
    if not keys:
        first, inverse = np.zeros(1, dtype=np.int64), np.zeros(len(chains), dtype=np.int64)
    else:
        first, inverse = row_codes([chains.values[k] for k in keys])
    if len(first) == len(chains):
        return None
    return first, inverse


def static_arrays(chains, *, grains: int | None = None) -> StaticArrays:
    """:func:`static_state` of every chain of a ChainSet, vectorised over chains (same bits).

    ``grains`` < N computes only the first ``grains`` grains and contacts 0 … ``grains`` (the last one
    an inner contact, its constant from grains ``grains``−1 and ``grains``): the arrays are then the
    leading columns of the full ones, bit for bit (a prefix of the cumulative mass is the same sum).

    Chains that differ only in keys the static state does not read (an impact speed, say) share one
    computation: each distinct configuration is solved once and its rows copied (every operation is
    row by row, so the bits are those of solving every chain).
    """
    shared = distinct_static_rows(chains) if len(chains) > 1 else None
    if shared is None:
        return _static_arrays(chains, grains)
    first, inverse = shared
    one = _static_arrays(chains.take(first), grains)
    return StaticArrays(
        mass=one.mass[inverse],
        self_constant=one.self_constant[inverse],
        contact_constant=one.contact_constant[inverse],
        carried_force=one.carried_force[inverse],
        static_overlap=one.static_overlap[inverse],
        exponent=one.exponent[inverse],
        surface_force=one.surface_force[inverse],
    )


def _static_arrays(chains, grains: int | None) -> StaticArrays:
    from hertzian.core.chains import per_unique

    scene = chains.template
    count, n_total = len(chains), scene.chain.grains
    window = n_total if grains is None or grains >= n_total else int(grains)
    cut = window < n_total
    n_grains = window + 1 if cut else n_total  # one grain past the window gives the last contact's constant
    mass = np.repeat(chains.column("chain.mass")[:, None], n_grains, axis=1)
    self_a = np.repeat(chains.column("chain.a")[:, None], n_grains, axis=1)
    own = np.zeros(n_grains, dtype=bool)
    for k, imp in enumerate(scene.impurities):
        idx = np.asarray([g for g in imp.grains if g < n_grains], dtype=np.int64)
        imp_mass = chains.column(f"impurities.{k}.mass")
        if imp_mass is not None:
            mass[:, idx] = imp_mass[:, None]
        imp_a = chains.column(f"impurities.{k}.a")
        if imp_a is not None:
            self_a[:, idx] = imp_a[:, None]
        own[idx] = imp.contact == "own"

    left, right = self_a[:, :-1], self_a[:, 1:]
    inner = 2.0 * left * right / (left + right)
    own_left, own_right = own[:-1], own[1:]
    inner = np.where(own_left & ~own_right, left, inner)
    inner = np.where(own_right & ~own_left, right, inner)
    inner = np.where(left == right, left, inner)
    a_c = np.zeros((count, n_grains + 1))
    a_c[:, 1:n_grains] = inner
    if scene.boundary.surface == "wall":
        a_c[:, 0] = self_a[:, 0]
    if scene.boundary.bottom == "wall" and not cut:
        a_c[:, n_grains] = self_a[:, -1]
    if cut:
        mass, self_a, a_c = mass[:, :window], self_a[:, :window], a_c[:, : window + 1]

    exponent = chains.column("chain.exponent")
    load = chains.column("chain.load")
    f0 = per_unique(
        _surface_force,
        load if load is not None else np.full(count, np.nan),
        chains.column("chain.l0"),
        exponent,
        chains.column("chain.a"),
    )
    g = chains.column("chain.gravity")
    carried = np.zeros((count, window + 1))
    carried[:, 1:] = f0[:, None] + g[:, None] * np.cumsum(mass, axis=1)
    carried[:, 0] = f0
    carried[a_c == 0.0] = 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = carried / (exponent[:, None] * np.where(a_c > 0, a_c, 1.0))
        overlap = np.where(carried > 0, _power_by_exponent(ratio, exponent, lambda n: 1.0 / (n - 1.0)), 0.0)
    return StaticArrays(
        mass=mass,
        self_constant=self_a,
        contact_constant=a_c,
        carried_force=carried,
        static_overlap=overlap,
        exponent=exponent,
        surface_force=f0,
    )
