"""Static state of a chain (docs/model.md §2): masses, contact constants, carried forces, static overlaps.

Contacts are stored *padded*, length N + 1: index ``k`` is the contact between grain
``k − 1`` and grain ``k``; ``k = 0`` is the surface wall and ``k = N`` the bottom wall.
(docs/model.md numbers the inner contact between grains i and i+1 as ``i``; here it is ``i + 1``.)
A padded slot without a contact (no wall at that end) has constant 0.

Contact ``k`` carries ``F0 + g Σ_{j<k} m_j`` — the paper's sum rule, eq. 4, plus a load —
and its static overlap is ``δ0 = (carried / (n a_c))^(1/(n−1))``.

Grains of radius R_i = r_i·R0 (``chain.radii``, docs/heterogeneous.md) have mass m·r_i³, wall constant a·√r_i and
contact constant a·√(2 r_i r_j / (r_i + r_j)); an impurity's own mass or ``a`` overrides its grain's.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
from hertzian.core.chains import RADII_KEYS, per_unique, radius_rows, row_codes
from hertzian.core.materials import scene_constants
from hertzian.core.scene import Scene

STATIC_KEYS = ("chain.mass", "chain.a", "chain.exponent", "chain.l0", "chain.load", "chain.gravity") + RADII_KEYS
"""Per-chain keys the static state reads (with ``impurities.K.mass|a``, and ``chain.diameter`` for a list of radii)."""
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
    radius_ratio: np.ndarray | None = None
    """R_i/R0 of each grain, shape (N,); None for equal grains."""

    @property
    def grain_count(self) -> int:
        return self.mass.shape[0]


def radius_constants(mass, a, ratios: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(masses m·r³, self-constants a·√r, inner contact constants a·√(2 r_i r_j / (r_i + r_j))) of grains
    with radius ratios ``ratios`` (shape (..., N)); ``mass``, ``a``: scalars or per-chain columns (chains, 1)."""
    left, right = ratios[..., :-1], ratios[..., 1:]
    return mass * ratios * ratios * ratios, a * np.sqrt(ratios), a * np.sqrt(2.0 * left * right / (left + right))


def validity_scale(ratios: np.ndarray) -> np.ndarray:
    """R0 / min(R_i, R_j) of each padded contact of grains with radius ratios ``ratios`` (shape (..., N)), shape
    (..., N + 1): contact k joins grains k − 1 and k, a wall contact (k = 0, N) takes its grain's own radius. A
    contact's overlap times its scale is the overlap two R0 grains would have at the same strain of the smaller
    grain, so every contact's validity limit VALIDITY_FRACTION·2·min(R_i, R_j) becomes the one VALIDITY_FRACTION·2·R0."""
    above = np.concatenate([ratios[..., :1], ratios], axis=-1)
    below = np.concatenate([ratios, ratios[..., -1:]], axis=-1)
    return 1.0 / np.minimum(above, below)


def _inner_contacts(self_a, own, hertz_inner=None, overridden=None) -> np.ndarray:
    """Inner contact constants (..., N − 1): the harmonic mean of the self-constants, an ``own`` impurity's
    constant, or (radii) ``hertz_inner`` wherever neither grain has an impurity's ``a``."""
    left, right = self_a[..., :-1], self_a[..., 1:]
    inner = 2.0 * left * right / (left + right)
    own_left, own_right = own[:-1], own[1:]
    inner = np.where(own_left & ~own_right, left, inner)
    inner = np.where(own_right & ~own_left, right, inner)
    # Equal grains must get exactly a (the harmonic mean rounds otherwise).
    inner = np.where(left == right, left, inner)
    if hertz_inner is not None:
        inner = np.where(overridden[:-1] | overridden[1:], inner, hertz_inner)
    return inner


def contact_constants(scene: Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(masses (N,), self-constants (N,), padded contact constants (N+1,)) for a scene."""
    n_grains = scene.chain.grains
    ratios = scene.chain.radius_ratios
    if scene.chain.material is not None:
        rows = None if ratios is None else ratios[None, :]
        mass, self_a, inner, walls = (
            a[0] for a in scene_constants(scene, np.array([scene.chain.diameter]), rows, n_grains)
        )
        padded = np.zeros(n_grains + 1)
        padded[1:n_grains] = inner
        if scene.boundary.surface == "wall":
            padded[0] = walls[0]
        if scene.boundary.bottom == "wall":
            padded[n_grains] = walls[1]
        return mass, self_a, padded
    if ratios is None:
        mass, self_a, hertz_inner = np.full(n_grains, scene.chain.mass), np.full(n_grains, scene.chain.a), None
    else:
        mass, self_a, hertz_inner = radius_constants(scene.chain.mass, scene.chain.a, ratios)
    own = np.zeros(n_grains, dtype=bool)
    overridden = np.zeros(n_grains, dtype=bool)
    for imp in scene.impurities:
        idx = np.asarray(imp.grains)
        if imp.mass is not None:
            mass[idx] = imp.mass
        if imp.a is not None:
            self_a[idx] = imp.a
            overridden[idx] = True
        own[idx] = imp.contact == "own"

    padded = np.zeros(n_grains + 1)
    padded[1:n_grains] = _inner_contacts(self_a, own, hertz_inner, overridden)
    if scene.boundary.surface == "wall":
        padded[0] = self_a[0]
    if scene.boundary.bottom == "wall":
        padded[n_grains] = self_a[-1]
    if scene.boundary.surface == "periodic":  # a ring: grain N − 1 touches grain 0, in both end slots
        closing = _inner_contacts(self_a[[-1, 0]], own[[-1, 0]])
        padded[0] = padded[n_grains] = closing[0]
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
    if scene.chain.potential != "hertz":
        overlap = _lattice_overlap(scene, carried, a_c)
    else:
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
        radius_ratio=scene.chain.radius_ratios,
    )


def _lattice_overlap(scene: Scene, carried: np.ndarray, a_c: np.ndarray) -> np.ndarray:
    """δ0 of each contact of a lattice law, F(δ0) = carried force; SceneError where the law cannot carry it."""
    from hertzian.core.errors import SceneError
    from hertzian.core.potentials import law_of

    law = law_of(scene.chain)
    overlap = law.static_overlap(carried, np.where(a_c > 0, a_c, 1.0))
    if np.any(np.isnan(overlap)):
        k = int(np.argmax(np.isnan(overlap)))
        key = "chain.load" if scene.chain.load is not None else "chain.l0" if scene.chain.l0 else "chain.gravity"
        value = getattr(scene.chain, key.split(".")[1])
        limit = float(law.force(law.rising_limit(), a_c[k]))
        raise SceneError(
            key,
            value,
            f"contact {k} would carry {carried[k]:.6g}, beyond the {law.name} law's largest force {limit:.6g}",
        )
    return overlap


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
    radius_ratio: np.ndarray | None = None
    """R_i/R0 of each grain, shape (chains, N) (1 in chains of equal grains); None when every chain's are equal."""

    @property
    def configurations(self) -> "StaticArrays":
        """The rows that differ (here every chain's; :class:`SharedStatic` has one per configuration)."""
        return self

    def per_chain(self, rows: np.ndarray | None) -> np.ndarray | None:
        """``rows`` computed on :attr:`configurations`, per chain (here already)."""
        return rows

    def leading(self, grains: int) -> "StaticArrays":
        """The first ``grains`` grains and contacts 0 … ``grains`` (views)."""
        ratio = None if self.radius_ratio is None else self.radius_ratio[:, :grains]
        per_grain = {"mass": self.mass[:, :grains], "self_constant": self.self_constant[:, :grains]}
        per_contact = {name: getattr(self, name)[:, : grains + 1] for name in CONTACT_FIELDS}
        return replace(self, **per_grain, **per_contact, radius_ratio=ratio)


FIELDS = tuple(StaticArrays.__dataclass_fields__)
"""The fields of StaticArrays."""
CONTACT_FIELDS = ("contact_constant", "carried_force", "static_overlap")


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
    radii_listed = chains.template.chain.radii is not None and chains.template.chain.radii.values is not None
    sized = radii_listed or chains.template.chain.material is not None  # the diameter sets radii or masses
    return [
        k for k in chains.values if k in STATIC_KEYS or IMPURITY_STATIC.match(k) or (sized and k == "chain.diameter")
    ]


def distinct_static_rows(chains) -> tuple[np.ndarray, np.ndarray] | None:
    """(first index of each distinct static configuration, configuration of every chain), or None when
    every chain is its own configuration (nothing to share)."""
    keys = _static_columns(chains)
    if not keys:
        first, inverse = np.zeros(1, dtype=np.int64), np.zeros(len(chains), dtype=np.int64)
    else:
        first, inverse = row_codes([chains.values[k] for k in keys])
    if len(first) == len(chains):
        return None
    return first, inverse


def static_arrays(chains, *, grains: int | None = None) -> "StaticArrays | SharedStatic":
    """:func:`static_state` of every chain of a ChainSet, vectorised over chains (same bits).

    ``grains`` < N computes only the first ``grains`` grains and contacts 0 … ``grains`` (the last one
    an inner contact, its constant from grains ``grains``−1 and ``grains``): the arrays are then the
    leading columns of the full ones, bit for bit (a prefix of the cumulative mass is the same sum).

    Chains that differ only in keys the static state does not read (an impact speed, say) share one
    computation: each distinct configuration is solved once (a :class:`SharedStatic`, whose per-chain
    fields are gathered from those rows when first read; every operation is row by row, so the bits are
    those of solving every chain).
    """
    shared = distinct_static_rows(chains) if len(chains) > 1 else None
    if shared is None:
        return _static_arrays(chains, grains)
    first, inverse = shared
    return SharedStatic(_static_arrays(chains.take(first), grains), inverse)


def _per_chain_field(name: str) -> cached_property:
    """A SharedStatic field: its configurations' rows gathered per chain, on first access."""
    return cached_property(lambda self: self.per_chain(getattr(self.configurations, name)))


class SharedStatic:
    """:class:`StaticArrays` of chains that share static configurations, read as StaticArrays (the same
    fields, shapes and bits): ``configurations`` holds one solved row per configuration, ``inverse`` each
    chain's configuration. A field is gathered per chain only when read, so a consumer that needs a
    derived per-chain array (1/m, one column) computes it on the configurations and gathers that."""

    def __init__(self, configurations: StaticArrays, inverse: np.ndarray):
        self.configurations = configurations
        """StaticArrays of the distinct configurations, one row each."""
        self.inverse = inverse
        """Configuration of every chain, shape (chains,), int64."""

    def per_chain(self, rows: np.ndarray | None) -> np.ndarray | None:
        """``rows`` (one per configuration, along axis 0) gathered for every chain."""
        return None if rows is None else np.take(rows, self.inverse, axis=0)

    def leading(self, grains: int) -> StaticArrays:
        """StaticArrays of the first ``grains`` grains and contacts 0 … ``grains`` of every chain."""
        part = self.configurations.leading(grains)
        return StaticArrays(**{name: self.per_chain(getattr(part, name)) for name in FIELDS})

    mass = _per_chain_field("mass")
    self_constant = _per_chain_field("self_constant")
    contact_constant = _per_chain_field("contact_constant")
    carried_force = _per_chain_field("carried_force")
    static_overlap = _per_chain_field("static_overlap")
    exponent = _per_chain_field("exponent")
    surface_force = _per_chain_field("surface_force")
    radius_ratio = _per_chain_field("radius_ratio")


def _grain_arrays(chains, n_grains: int, ratios):
    """(masses, self-constants, inner contact constants) of the first ``n_grains`` grains of every chain."""
    scene = chains.template
    m, a = chains.column("chain.mass")[:, None], chains.column("chain.a")[:, None]
    if ratios is None:
        mass, self_a, hertz_inner = np.repeat(m, n_grains, axis=1), np.repeat(a, n_grains, axis=1), None
    else:
        mass, self_a, hertz_inner = radius_constants(m, a, ratios[:, :n_grains])
    own = np.zeros(n_grains, dtype=bool)
    overridden = np.zeros(n_grains, dtype=bool)
    for k, imp in enumerate(scene.impurities):
        idx = np.asarray([g for g in imp.grains if g < n_grains], dtype=np.int64)
        imp_mass = chains.column(f"impurities.{k}.mass")
        if imp_mass is not None:
            mass[:, idx] = imp_mass[:, None]
        imp_a = chains.column(f"impurities.{k}.a")
        if imp_a is not None:
            self_a[:, idx] = imp_a[:, None]
            overridden[idx] = True
        own[idx] = imp.contact == "own"
    return mass, self_a, _inner_contacts(self_a, own, hertz_inner, overridden)


def _static_arrays(chains, grains: int | None) -> StaticArrays:
    scene = chains.template
    count, n_total = len(chains), scene.chain.grains
    window = n_total if grains is None or grains >= n_total else int(grains)
    cut = window < n_total
    n_grains = window + 1 if cut else n_total  # one grain past the window gives the last contact's constant
    ratios = radius_rows(chains)
    if scene.chain.material is not None:
        mass, self_a, inner, walls = scene_constants(scene, chains.column("chain.diameter"), ratios, n_grains)
    else:
        mass, self_a, inner = _grain_arrays(chains, n_grains, ratios)
        walls = self_a[:, [0, -1]]
    a_c = np.zeros((count, n_grains + 1))
    a_c[:, 1:n_grains] = inner
    if scene.boundary.surface == "wall":
        a_c[:, 0] = walls[:, 0]
    if scene.boundary.bottom == "wall" and not cut:
        a_c[:, n_grains] = walls[:, 1]
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
        radius_ratio=None if ratios is None else ratios[:, :window],
    )
