"""Chains that share everything but a few scalar parameters, held as arrays (no scene per chain).

A sweep over impact speed × precompression × impurity mass varies only per-chain *scalars*;
the grain count, boundaries, integrator, record layout and impurity positions are shared.
:class:`ChainSet` keeps one validated *template* scene and, for each varying key of
:data:`PER_CHAIN_KEYS`, one float64 array with a value per chain. ``hertzian.core.model`` builds a
model from it, ``hertzian.core.static`` and ``hertzian.core.startup`` compute the static state and the
exact Taylor start over the whole set with numpy, and ``chains[i]`` still gives the scene of
chain ``i`` (built on demand) where a scene is wanted.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from hertzian.core.radii import SWEEPABLE, RadiiSpec, radius_ratios, with_values
from hertzian.core.scene import Scene

CHAIN_KEYS = (
    "chain.mass",
    "chain.a",
    "chain.exponent",
    "chain.diameter",
    "chain.l0",
    "chain.load",
    "chain.gravity",
    "excitation.impact",
    "excitation.drive_amplitude",
    "excitation.drive_period",
    "damping.gamma",
)
RADII_KEYS = tuple(f"chain.radii.{name}" for name in SWEEPABLE)
"""Per-chain keys of a table form of ``chain.radii`` (taper, spread, seed)."""
CHAIN_KEYS += RADII_KEYS
IMPURITY_KEY = re.compile(r"^impurities\.(\d+)\.(mass|a)$")


def is_per_chain_key(key: str) -> bool:
    """Whether a dotted scene key is a per-chain scalar (may differ between chains of one launch
    and is held as an array): ``chain.*`` except ``grains``, ``excitation.*``, ``damping.gamma``, ``impurities.K.mass|a``,
    ``chain.radii.taper|spread|seed``."""
    return key in CHAIN_KEYS or IMPURITY_KEY.match(key) is not None


PER_CHAIN_KEYS = CHAIN_KEYS + ("impurities.K.mass", "impurities.K.a")
"""Scene keys held per chain (K: an impurity block index)."""


def template_value(scene: Scene, key: str) -> Any:
    """The value of a per-chain key in ``scene`` (None for an unset load or impurity value)."""
    match = IMPURITY_KEY.match(key)
    if match:
        return getattr(scene.impurities[int(match.group(1))], match.group(2))
    if key in RADII_KEYS:
        return None if scene.chain.radii is None else getattr(scene.chain.radii, key.rsplit(".", 1)[1])
    section, name = key.split(".")
    return getattr(getattr(scene, section), name)


@dataclass(frozen=True, eq=False)
class ChainSet(Sequence):
    """``count`` chains: a template scene and per-chain values of some :data:`PER_CHAIN_KEYS`."""

    template: Scene
    """Every key not in ``values`` is this scene's, for every chain."""
    values: dict[str, np.ndarray] = field(default_factory=dict)
    """Dotted per-chain key → value of each chain, shape (count,), float64."""
    count: int = 1

    def __post_init__(self):
        for key, column in self.values.items():
            if not is_per_chain_key(key):
                raise ValueError(f"{key} is not a per-chain key ({', '.join(PER_CHAIN_KEYS)})")
            if np.shape(column) != (self.count,):
                raise ValueError(f"{key}: {np.shape(column)} values for {self.count} chains")

    @classmethod
    def of(cls, template: Scene, values: dict[str, Any], count: int) -> "ChainSet":
        """A set with columns converted to float64 arrays."""
        return cls(
            template=template, values={k: np.asarray(v, dtype=np.float64) for k, v in values.items()}, count=count
        )

    def column(self, key: str) -> np.ndarray | None:
        """Value of ``key`` for every chain, shape (count,), float64; None where the template's value is unset."""
        if key in self.values:
            return self.values[key]
        value = template_value(self.template, key)
        return None if value is None else np.full(self.count, float(value))

    def varies(self, key: str) -> bool:
        return key in self.values

    def overrides(self, index: int) -> dict[str, float]:
        """Dotted keys → values that turn the template into chain ``index``'s scene."""
        return {k: float(v[index]) for k, v in self.values.items()}

    def __len__(self) -> int:
        return self.count

    def __getitem__(self, index):
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(self.count))]
        if not -self.count <= index < self.count:
            raise IndexError(index)
        index %= self.count
        return self.template.with_overrides(self.overrides(index)) if self.values else self.template

    def take(self, indices: np.ndarray) -> "ChainSet":
        """The chains at ``indices`` (in that order)."""
        indices = np.asarray(indices)
        return ChainSet(
            template=self.template, values={k: v[indices] for k, v in self.values.items()}, count=len(indices)
        )


class ChainStack(Sequence):
    """ChainSets one after another, run as one ensemble: chains whose scenes differ in more than per-chain
    scalars (a detection library: an impurity at each depth) but need the same kernel. ``stack[i]`` is chain
    ``i``'s scene; ``template`` is the first set's (what every set shares: grains, integrator, record)."""

    def __init__(self, parts: Sequence[ChainSet]):
        if not parts:
            raise ValueError("a ChainStack needs at least one ChainSet")
        self.parts = tuple(parts)
        self.offsets = np.cumsum([0] + [len(p) for p in self.parts])

    @property
    def template(self) -> Scene:
        return self.parts[0].template

    def __len__(self) -> int:
        return int(self.offsets[-1])

    def __getitem__(self, index):
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        if not -len(self) <= index < len(self):
            raise IndexError(index)
        index %= len(self)
        part = int(np.searchsorted(self.offsets, index, side="right")) - 1
        return self.parts[part][index - int(self.offsets[part])]


def has_radii(chains: ChainSet) -> bool:
    """Whether some chain of the set may have radii (a ``chain.radii`` form in the template or an axis)."""
    return chains.template.chain.radii is not None or any(chains.varies(k) for k in RADII_KEYS)


def radius_rows(chains: ChainSet) -> np.ndarray | None:
    """R_i/R0 of every grain of every chain, shape (chains, N), float64 (rows of 1 for equal grains), computed
    once per distinct (taper, spread, seed, diameter) with the per-scene function (same bits); None when every
    chain's grains are equal."""
    if not has_radii(chains):
        return None
    template = chains.template.chain
    varying = {name: chains.values[key] for name, key in zip(SWEEPABLE, RADII_KEYS) if chains.varies(key)}
    diameter = chains.column("chain.diameter")
    first, inverse = row_codes([*varying.values(), diameter])
    rows = []
    for index in first.tolist():
        spec = with_values(template.radii or RadiiSpec(), **{k: v[index] for k, v in varying.items()})
        rows.append(radius_ratios(spec, template.grains, float(diameter[index])))
    if all(r is None for r in rows):
        return None
    table = np.stack([np.ones(template.grains) if r is None else r for r in rows])
    return table[inverse]


def row_codes(columns: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(index of the first row of each distinct row, distinct-row number of every row) of equal-length
    float64 columns, rows compared bit for bit (0.0 and -0.0 differ; one 1-D unique per column, not a
    sort of rows)."""
    columns = [np.ascontiguousarray(c, dtype=np.float64).view(np.int64) for c in columns]
    count = len(columns[0])
    code = np.zeros(count, dtype=np.int64)
    for column in columns:
        values, inverse = np.unique(column, return_inverse=True)
        # renumber after each column so the combined code stays below the row count (no overflow)
        code = np.unique(code * len(values) + inverse.reshape(-1), return_inverse=True)[1].reshape(-1)
    _, first, inverse = np.unique(code, return_index=True, return_inverse=True)
    return first, inverse.reshape(-1)


def per_unique(function, *columns: np.ndarray) -> np.ndarray:
    """``function(*row)`` (Python floats in, a float out) for every row of ``columns``, evaluated once
    per distinct row: scalar formulas keep exactly the arithmetic (and bits) of the per-scene code."""
    columns = [np.asarray(c, dtype=np.float64) for c in columns]
    count = len(columns[0])
    if count == 0:
        return np.zeros(0)
    # distinct rows by integer codes (one 1-D unique per column, NaN equal to NaN), not a sort of rows
    code = np.zeros(count, dtype=np.int64)
    for column in columns:
        values, inverse = np.unique(column, return_inverse=True)
        # renumber after each column so the combined code stays below the row count (no overflow)
        code = np.unique(code * len(values) + inverse.reshape(-1), return_inverse=True)[1].reshape(-1)
    _, first, inverse = np.unique(code, return_index=True, return_inverse=True)
    rows = np.stack([c[first] for c in columns], axis=1).tolist()
    values = np.array([float(function(*row)) for row in rows])
    return values[inverse.reshape(-1)]
