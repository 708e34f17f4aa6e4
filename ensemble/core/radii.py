"""Per-grain radii of a heterogeneous chain (docs/heterogeneous.md): the forms of ``chain.radii`` and what they give.

A chain's reference radius is R0 = diameter/2; ``mass`` and ``a`` are those of a grain of radius R0.
Grain i of radius R_i = r_i·R0 has mass m·r_i³ and wall constant a·√r_i; grains i and j touch with
a·√(2 r_i r_j / (r_i + r_j)) (Hertz: the constant scales with √R_eff, R_eff = R_i R_j / (R_i + R_j)).

Forms (TOML): ``{ taper = q }`` (r_i = (1 − q)^i, or ``kind = "linear"``: 1 − q·i), ``{ pattern = [r…] }``
(repeated ratios), ``{ spread = s, seed = k, distribution = … }`` (random, reproducible from the seed with
``numpy.random.default_rng(k)``), a list of N radii [length] or the path of a ``.npy`` file holding them.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from hertzian.core.errors import SceneError

TAPER_KINDS = ("exponential", "linear")
DISTRIBUTIONS = ("uniform", "normal", "lognormal")
NORMAL_CUT = 3.0
"""Normal spreads draw Z from the standard normal cut at |Z| ≤ NORMAL_CUT (values beyond are redrawn)."""
SPREAD_LIMIT = {"uniform": 1.0, "normal": 1.0 / NORMAL_CUT, "lognormal": 1.0}
"""Largest spread s (exclusive for uniform and normal: every radius stays > 0; inclusive for lognormal)."""
SWEEPABLE = ("taper", "spread", "seed")
"""``chain.radii.<key>`` that may vary per chain (sweep axes)."""
_TABLE_KEYS = ("taper", "kind", "pattern", "spread", "seed", "distribution")


@dataclass(frozen=True)
class RadiiSpec:
    """One of the ``chain.radii`` forms (exactly one of taper, pattern, spread, values is set)."""

    taper: float | None = None
    """q: r_i = (1 − q)^i (``kind = "exponential"``) or 1 − q·i (``"linear"``); q < 0 grows downward."""
    kind: str = "exponential"
    pattern: tuple[float, ...] | None = None
    """Ratios R_i/R0 repeated along the chain."""
    spread: float | None = None
    """s: uniform r = 1 + s·U(−1, 1); normal r = 1 + s·Z (|Z| ≤ 3); lognormal r = exp(s·Z)."""
    seed: int = 0
    distribution: str = "uniform"
    values: tuple[float, ...] | None = None
    """Radius of every grain [length] (a list or a .npy file)."""

    def to_plain(self) -> Any:
        """The TOML form: a list of radii, or a table of the keys that are set."""
        if self.values is not None:
            return list(self.values)
        data = {k: v for k, v in asdict(self).items() if v is not None and k != "values"}
        if self.pattern is not None:
            data["pattern"] = list(self.pattern)
        if self.taper is None:
            data.pop("kind")
        if self.spread is None:
            data.pop("seed"), data.pop("distribution")
        return data


def _number(key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SceneError(key, value, "must be a finite number")
    return float(value)


def _integer(key: str, value: Any) -> int:
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise SceneError(key, value, "must be an integer ≥ 0")
    return value


def _numbers(key: str, values: Any) -> tuple[float, ...]:
    if not isinstance(values, (list, tuple)) or not values:
        raise SceneError(key, values, "must be a non-empty list of numbers")
    return tuple(_number(key, v) for v in values)


def _from_file(key: str, value: str) -> tuple[float, ...]:
    path = Path(value)
    if path.suffix != ".npy":
        raise SceneError(key, value, "a file of radii must be a .npy file (or give a list or a table)")
    if not path.is_file():
        raise SceneError(key, value, "no such file")
    try:
        data = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as err:
        raise SceneError(key, value, f"not a readable .npy array ({err})") from None
    if data.ndim != 1 or data.dtype.kind not in "fiu":
        raise SceneError(key, value, f"must hold a 1-D numeric array (has shape {data.shape}, dtype {data.dtype})")
    return _numbers(key, data.astype(np.float64).tolist())


def _from_table(key: str, value: dict) -> RadiiSpec:
    for name in value:
        if name not in _TABLE_KEYS:
            raise SceneError(f"{key}.{name}", value[name], f"unknown key; allowed: {', '.join(_TABLE_KEYS)}")
    value = {k: v for k, v in value.items() if v is not None}
    forms = [k for k in ("taper", "pattern", "spread") if k in value]
    if len(forms) != 1:
        raise SceneError(key, value, "give exactly one of taper, pattern, spread (or a list of radii)")
    if "kind" in value and forms[0] != "taper":
        raise SceneError(f"{key}.kind", value["kind"], "goes with taper only")
    kind = value.get("kind", "exponential")
    if kind not in TAPER_KINDS:
        raise SceneError(f"{key}.kind", kind, f"must be one of {', '.join(TAPER_KINDS)}")
    for name in ("seed", "distribution"):
        if name in value and forms[0] != "spread":
            raise SceneError(f"{key}.{name}", value[name], "goes with spread only")
    distribution = value.get("distribution", "uniform")
    if distribution not in DISTRIBUTIONS:
        raise SceneError(f"{key}.distribution", distribution, f"must be one of {', '.join(DISTRIBUTIONS)}")
    return RadiiSpec(
        taper=_number(f"{key}.taper", value["taper"]) if "taper" in value else None,
        kind=kind,
        pattern=_numbers(f"{key}.pattern", value["pattern"]) if "pattern" in value else None,
        spread=_number(f"{key}.spread", value["spread"]) if "spread" in value else None,
        seed=_integer(f"{key}.seed", value.get("seed", 0)),
        distribution=distribution,
    )


def parse_radii(key: str, value: Any) -> RadiiSpec | None:
    """``chain.radii`` from TOML data: a table, a list of radii [length] or a ``.npy`` path (None: uniform)."""
    if value is None or isinstance(value, RadiiSpec):
        return value
    if isinstance(value, dict):
        return _from_table(key, value)
    if isinstance(value, (list, tuple)):
        return RadiiSpec(values=_numbers(key, value))
    if isinstance(value, str):
        return RadiiSpec(values=_from_file(key, value))
    raise SceneError(key, value, "must be a table (taper, pattern or spread), a list of radii or a .npy path")


def _random(spec: RadiiSpec, grains: int) -> np.ndarray:
    rng = np.random.default_rng(spec.seed)
    if spec.distribution == "uniform":
        return 1.0 + spec.spread * rng.uniform(-1.0, 1.0, grains)
    z = rng.standard_normal(grains)
    far = np.abs(z) > NORMAL_CUT
    while far.any():
        z[far] = rng.standard_normal(int(far.sum()))
        far = np.abs(z) > NORMAL_CUT
    return 1.0 + spec.spread * z if spec.distribution == "normal" else np.exp(spec.spread * z)


def _check_spread(key: str, spec: RadiiSpec) -> None:
    limit = SPREAD_LIMIT[spec.distribution]
    inside = spec.spread <= limit if spec.distribution == "lognormal" else spec.spread < limit
    if not (spec.spread >= 0 and inside):
        bound = "≤" if spec.distribution == "lognormal" else "<"
        raise SceneError(
            f"{key}.spread", spec.spread, f"a {spec.distribution} spread must be 0 ≤ s {bound} {limit:.6g}"
        )


def radius_ratios(spec: RadiiSpec | None, grains: int, diameter: float, key: str = "chain.radii") -> np.ndarray | None:
    """r_i = R_i/R0 of every grain, float64 shape (grains,); None for a uniform chain (no radii, or all r_i = 1).
    Raises SceneError for a form that gives a radius ≤ 0 or not finite, or a list of the wrong length."""
    if spec is None:
        return None
    if spec.taper is not None:
        i = np.arange(grains, dtype=np.float64)
        if spec.kind == "linear":
            if not 1.0 - spec.taper * (grains - 1) > 0:
                raise SceneError(
                    f"{key}.taper", spec.taper, f"a linear taper needs q < 1/(N − 1) = {1 / (grains - 1):.6g}"
                )
            ratios = 1.0 - spec.taper * i
        else:
            if not spec.taper < 1:
                raise SceneError(f"{key}.taper", spec.taper, "must be < 1 (R_i = R0 (1 − q)^i)")
            ratios = (1.0 - spec.taper) ** i
    elif spec.pattern is not None:
        if min(spec.pattern) <= 0:
            raise SceneError(f"{key}.pattern", list(spec.pattern), "ratios must be > 0")
        ratios = np.resize(np.asarray(spec.pattern, dtype=np.float64), grains)
    elif spec.spread is not None:
        _check_spread(key, spec)
        ratios = _random(spec, grains)
    else:
        if len(spec.values) != grains:
            raise SceneError(
                key, f"{len(spec.values)} radii", f"must list one radius per grain (chain.grains = {grains})"
            )
        if min(spec.values) <= 0:
            raise SceneError(key, min(spec.values), "radii must be > 0")
        ratios = np.asarray(spec.values, dtype=np.float64) / (0.5 * diameter)
    masses = ratios * ratios * ratios
    if not np.all(np.isfinite(masses)):
        raise SceneError(
            key, spec.to_plain() if spec.values is None else "…", "gives radii whose masses overflow float64"
        )
    if not np.all(masses >= np.finfo(np.float64).tiny):
        raise SceneError(
            key,
            spec.to_plain() if spec.values is None else float(np.min(ratios) * 0.5 * diameter),
            f"gives a radius of {np.min(ratios):.3g} R0, whose mass (R/R0)³ underflows float64: "
            "radii must be above about 1e-102 R0",
        )
    return None if np.all(ratios == 1.0) else ratios


def with_values(spec: RadiiSpec, **values: float) -> RadiiSpec:
    """``spec`` with some of the SWEEPABLE keys replaced (a seed as an integer)."""
    changes = {k: (int(v) if k == "seed" else float(v)) for k, v in values.items()}
    return RadiiSpec(**{**asdict(spec), **changes})
