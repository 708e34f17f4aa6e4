"""Sweep files (docs/model.md §8): a base scene and the axes along which its keys vary.

A sweep is a grid: every axis is a store dimension, and the points are the product of the
axes in file order (the last axis varies fastest). Axes listed together in one ``[[zip]]``
group vary together instead: they share one dimension, which takes the name and the place
of the first axis the group lists; the group's other axes become coordinates along that
dimension (``ds.l0`` over ``v_imp``), so ``ds.u.sel(v_imp=…)`` selects on the first and
``ds.swap_dims(v_imp="l0")`` on another.

:func:`expand` turns a sweep into :class:`SweepPoints` without a scene per point: one
template scene per combination of the *structural* dimensions, the per-chain scalars of the
*parameter* dimensions as arrays (``hertzian.core.chains.ChainSet`` per batch). The grid is validated
before anything runs, by its corners and value ranges (:func:`validate_grid`); bad input raises
:class:`~hertzian.core.scene.SceneError` naming the key, the value, what is allowed and the point.
:func:`sweep_scenes` still builds every point's scene (the reference path of the tests).
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from hertzian.core.chains import ChainSet, is_per_chain_key
from hertzian.core.model import scene_path_key
from hertzian.core.scene import (
    Scene,
    SceneError,
    UnknownKeyError,
    apply_overrides,
    read_toml,
    refuse_other_kind,
    scene_from_dict,
)
from hertzian.core.shipped import shipped_file

AXIS_KEYS = ("name", "key", "values", "linspace", "logspace")
SPACINGS = ("values", "linspace", "logspace")
RESERVED_NAMES = frozenset(
    {
        "t",
        "record",
        "grain",
        "sample",
        "traced",
        "trace_t",
        "traced_grain",
        "u",
        "v",
        "energy",
        "work",
        "trace_u",
        "trace_v",
        "status",
        "energy_error",
        "max_overlap",
        "wall_seconds",
        "grain_steps_per_second",
        "batch",
        "batches",
        "dissipated",
        "response",
        "mode",
        "mode_energy",
        "mode_frequency",
        "spectral_entropy",
        "participation",
        "window_ke",
        "driver_open",
        "window_start",
        "window",
        "harmonic",
        "launch_group",
        "error_estimate",
    }
)
GRAIN_NAMES = frozenset({"radius", "mass", "material"})
"""Store variables of chains with radii or materials (hertzian.sweeping.grain_store): reserved in such sweeps."""
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
MAX_POINTS = 10**7
"""Sweeps with more points are refused unless asked for (``--allow-large``): counted from the axis
lengths before any axis is expanded."""


def _refuse_size(key: str, count: int, max_points: int | None) -> None:
    if max_points is not None and count > max_points:
        raise SceneError(key, count, f"more than {max_points} sweep points; pass --allow-large to insist")


@dataclass(frozen=True)
class Axis:
    """One swept scene key: ``name`` (store coordinate), dotted scene ``key`` and its values."""

    name: str
    key: str
    """Dotted scene key, e.g. ``excitation.impact`` or ``impurities.0.mass``."""
    values: tuple
    """Python scalars (float, int, str or bool), in sweep order."""

    def coordinate(self) -> np.ndarray:
        """The values as a 1-D coordinate array (float64, int64, bool or str)."""
        kinds = {type(v) for v in self.values}
        if kinds == {bool}:
            return np.array(self.values, dtype=bool)
        if kinds == {int}:
            return np.array(self.values, dtype=np.int64)
        if kinds <= {int, float}:
            return np.array(self.values, dtype=np.float64)
        return np.array(self.values, dtype=str)


@dataclass(frozen=True)
class Dimension:
    """A store dimension: one axis, or a ``[[zip]]`` group of axes that vary together."""

    axes: tuple[Axis, ...]

    @property
    def name(self) -> str:
        """Dimension name: the (first) axis's name."""
        return self.axes[0].name

    @property
    def size(self) -> int:
        return len(self.axes[0].values)


@dataclass(frozen=True)
class Sweep:
    """A validated sweep: base scene, dimensions (grid product), and where it came from."""

    base: Scene
    dimensions: tuple[Dimension, ...]
    zips: tuple[tuple[str, ...], ...] = ()
    """Axis names of each ``[[zip]]`` group, as written."""
    source: str = ""
    """The sweep file's path ('' for a sweep built in code)."""

    @property
    def shape(self) -> tuple[int, ...]:
        """Points along each dimension."""
        return tuple(d.size for d in self.dimensions)

    @property
    def dims(self) -> tuple[str, ...]:
        """Dimension names, in store order."""
        return tuple(d.name for d in self.dimensions)

    @property
    def axes(self) -> tuple[Axis, ...]:
        return tuple(a for d in self.dimensions for a in d.axes)

    @property
    def point_count(self) -> int:
        return math.prod(self.shape)

    def overrides(self, index: tuple[int, ...]) -> dict[str, Any]:
        """Dotted scene keys → values at grid index ``index`` (one entry per dimension)."""
        return {a.key: a.values[i] for d, i in zip(self.dimensions, index) for a in d.axes}

    def coordinates_at(self, index: tuple[int, ...]) -> dict[str, Any]:
        """Axis name → value at grid index ``index``."""
        return {a.name: a.values[i] for d, i in zip(self.dimensions, index) for a in d.axes}

    def scene_at(self, index: tuple[int, ...]) -> Scene:
        """The validated scene of one point."""
        try:
            return self.base.with_overrides(self.overrides(index))
        except UnknownKeyError:
            raise
        except SceneError as err:
            where = ", ".join(f"{k}={v!r}" for k, v in self.coordinates_at(index).items())
            raise SceneError(err.key, err.value, f"{err.allowed} (at sweep point {where})") from None

    def scenes(self) -> list[Scene]:
        """Every point's scene, in C order of the grid (last dimension fastest)."""
        return [self.scene_at(index) for index in np.ndindex(*self.shape)]

    def to_dict(self) -> dict:
        """Canonical plain data: the resolved base scene (every key filled), axes with explicit values, zips."""
        return {
            "scene": self.base.to_dict(),
            "axis": [{"name": a.name, "key": a.key, "values": list(a.values)} for a in self.axes],
            "zip": [{"axes": list(z)} for z in self.zips],
        }

    def fingerprint(self) -> str:
        """sha256 of the canonical JSON of :meth:`to_dict`: equal for sweeps that define the same points."""
        text = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()


# ---- parsing -----------------------------------------------------------------------


def _scalar_list(key: str, values: Any) -> tuple:
    if not isinstance(values, list) or not values:
        raise SceneError(key, values, "must be a non-empty list of numbers, strings or booleans")
    for v in values:
        if not isinstance(v, (bool, int, float, str)):
            raise SceneError(key, v, "axis values must be numbers, strings or booleans")
        if isinstance(v, float) and not math.isfinite(v):
            raise SceneError(key, v, "axis values must be finite")
    kinds = {bool if isinstance(v, bool) else str if isinstance(v, str) else float for v in values}
    if len(kinds) > 1:
        raise SceneError(key, values, "axis values must all be numbers, all strings or all booleans")
    if kinds == {float} and any(isinstance(v, float) for v in values):
        values = [float(v) for v in values]
    return tuple(values)


def _spacing(key: str, spec: Any, log: bool, max_points: int | None = MAX_POINTS) -> tuple:
    what = "[from_exponent, to_exponent, count]" if log else "[first, last, count]"
    if (
        not isinstance(spec, list)
        or len(spec) != 3
        or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in spec)
    ):
        raise SceneError(key, spec, f"must be {what}")
    start, stop, count = spec
    if not all(math.isfinite(x) for x in spec):
        raise SceneError(key, spec, f"must be {what} with finite numbers")
    if not (float(count).is_integer() and count >= 1):
        raise SceneError(key, spec, f"must be {what}; count must be an integer ≥ 1")
    count = int(count)
    _refuse_size(key, count, max_points)
    if count > 1 and start == stop:
        raise SceneError(key, spec, "first and last must differ when count > 1 (values must not repeat)")
    values = np.logspace(start, stop, count) if log else np.linspace(start, stop, count)
    return tuple(float(v) for v in values.tolist())


def _parse_axis(k: int, raw: Any, max_points: int | None = MAX_POINTS) -> Axis:
    where = f"axis[{k}]"
    if not isinstance(raw, dict):
        raise SceneError(where, raw, "must be a table ([[axis]] with name, key and values/linspace/logspace)")
    for key in raw:
        if key not in AXIS_KEYS:
            raise UnknownKeyError(f"{where}.{key}", AXIS_KEYS)
    name = raw.get("name")
    if not isinstance(name, str) or not _NAME.match(name):
        raise SceneError(
            f"{where}.name",
            name,
            'is required: a name of letters, digits and _ (not starting with a digit), e.g. "v_imp"',
        )
    if name in RESERVED_NAMES:
        raise SceneError(
            f"{where}.name",
            name,
            f"is a store variable name; choose another (reserved: {', '.join(sorted(RESERVED_NAMES))})",
        )
    key = raw.get("key")
    if not isinstance(key, str) or not key:
        raise SceneError(f"{where}.key", key, 'is required: a dotted scene key, e.g. "excitation.impact"')
    given = [s for s in SPACINGS if s in raw]
    if len(given) != 1:
        raise SceneError(
            where,
            name,
            "give exactly one of values, linspace = [first, last, count] or "
            "logspace = [from_exponent, to_exponent, count]",
        )
    spacing = given[0]
    if spacing == "values":
        values = _scalar_list(f"{where}.values", raw["values"])
    else:
        values = _spacing(f"{where}.{spacing}", raw[spacing], log=spacing == "logspace", max_points=max_points)
    return Axis(name=name, key=key, values=values)


def _check_key(k: int, axis: Axis, base_data: dict) -> None:
    """The key must name a scene key; checked by applying the axis's first value to the base scene."""
    try:
        data = apply_overrides(base_data, {axis.key: axis.values[0]})
    except SceneError as err:
        raise SceneError(f"axis[{k}].key", axis.key, f"not a scene key ({err})") from None
    try:
        scene_from_dict(data)
    except UnknownKeyError as err:
        raise SceneError(f"axis[{k}].key", axis.key, f"not a scene key ({err})") from None
    except SceneError:
        pass  # a value the scene rejects is reported per point, with the point named


def _parse_zips(raw: Any, names: list[str]) -> list[tuple[str, ...]]:
    if raw is None:
        return []
    if isinstance(raw, dict):
        raw = [raw]
    if not isinstance(raw, list):
        raise SceneError("zip", raw, 'must be an array of tables: [[zip]] axes = ["v_imp", "l0"]')
    groups, seen = [], {}
    for z, table in enumerate(raw):
        where = f"zip[{z}]"
        if not isinstance(table, dict):
            raise SceneError(where, table, "must be a table with axes = [names]")
        for key in table:
            if key != "axes":
                raise UnknownKeyError(f"{where}.{key}", ("axes",))
        axes = table.get("axes")
        if not isinstance(axes, list) or len(axes) < 2 or not all(isinstance(a, str) for a in axes):
            raise SceneError(f"{where}.axes", axes, "must list at least two axis names")
        for a in axes:
            if a not in names:
                raise SceneError(f"{where}.axes", a, f"no such axis; axes: {', '.join(names)}")
            if a in seen:
                raise SceneError(
                    f"{where}.axes", a, f"axis already in zip[{seen[a]}] (an axis may be in one zip group)"
                )
            seen[a] = z
        if len(set(axes)) != len(axes):
            raise SceneError(f"{where}.axes", axes, "axis names must not repeat")
        groups.append(tuple(axes))
    return groups


SWEEP_TOLERANCE = (
    "a sweep takes integrator.dt, not a tolerance (hertzian run takes one); set dt and add --error-estimate"
)
"""Why a sweep refuses ``integrator.tolerance``."""


def sweep_from_dict(
    data: dict,
    *,
    base_dir: str | Path = ".",
    overrides: dict[str, Any] | None = None,
    source: str = "",
    max_points: int | None = MAX_POINTS,
) -> Sweep:
    """Build a sweep from parsed TOML: ``scene`` (path relative to ``base_dir``, or a table), ``[[axis]]``,
    ``[[zip]]``. ``overrides`` (``--set``) apply to the base scene before the axes. More than ``max_points``
    points (None: no limit) are refused before the grid is expanded."""
    if not isinstance(data, dict):
        raise SceneError("sweep", data, "must be a table")
    for key in data:
        if key not in ("scene", "axis", "zip"):
            raise UnknownKeyError(key, ("scene", "axis", "zip"))
    if "scene" not in data:
        raise SceneError(
            "scene", None, "is required: a scene file path (relative to the sweep file) or an inline [scene] table"
        )
    raw_scene = data["scene"]
    if isinstance(raw_scene, str):
        scene_path = Path(base_dir) / raw_scene
        if not scene_path.is_file():
            raise SceneError("scene", raw_scene, f"no such scene file ({scene_path})")
        base_data = read_toml(scene_path)
    elif isinstance(raw_scene, dict):
        base_data = raw_scene
    else:
        raise SceneError("scene", raw_scene, "must be a path (string) or an inline [scene] table")
    base_data = apply_overrides(base_data, overrides or {}, replacing=True)
    base = scene_from_dict(base_data)
    if base.integrator.tolerance is not None:
        raise SceneError("integrator.tolerance", base.integrator.tolerance, SWEEP_TOLERANCE)
    base_data = base.to_dict()

    raw_axes = data.get("axis", [])
    if isinstance(raw_axes, dict):
        raw_axes = [raw_axes]
    if not isinstance(raw_axes, list):
        raise SceneError("axis", raw_axes, "must be an array of tables ([[axis]])")
    axes = [_parse_axis(k, raw, max_points) for k, raw in enumerate(raw_axes)]
    for axis in axes:
        if axis.key == "integrator.tolerance":
            raise SceneError(f"axis {axis.name!r} key", axis.key, SWEEP_TOLERANCE)
    names, keys = {}, {}
    for k, axis in enumerate(axes):
        if axis.name in names:
            raise SceneError(f"axis[{k}].name", axis.name, f"already used by axis[{names[axis.name]}]")
        if axis.key in keys:
            raise SceneError(f"axis[{k}].key", axis.key, f"already swept by axis[{keys[axis.key]}]")
        names[axis.name], keys[axis.key] = k, k
        _check_key(k, axis, base_data)
    grains = base.chain.radii is not None or base.chain.material is not None
    grains = grains or any(a.key.startswith("chain.radii") or a.key == "chain.material" for a in axes)
    for k, axis in enumerate(axes):
        if grains and axis.name in GRAIN_NAMES:
            raise SceneError(
                f"axis[{k}].name", axis.name, "is a store variable of chains with radii or materials; choose another"
            )

    zips = _parse_zips(data.get("zip"), list(names))
    by_name = {a.name: a for a in axes}
    zipped = {name: group for group in zips for name in group}
    dimensions = []
    for axis in axes:
        group = zipped.get(axis.name)
        if group is None:
            dimensions.append(Dimension(axes=(axis,)))
        elif axis.name == group[0]:
            members = tuple(by_name[n] for n in group)
            for n, member in zip(group, members):
                if len(member.values) != len(members[0].values):
                    raise SceneError(
                        f"zip[{zips.index(group)}].axes",
                        n,
                        f"has {len(member.values)} values but {group[0]} has "
                        f"{len(members[0].values)}: zipped axes need equal lengths",
                    )
            dimensions.append(Dimension(axes=members))
    for dimension in dimensions:
        # the leading axis labels the store dimension; the other axes of a zip are coordinates
        # along it and may repeat values
        lead = dimension.axes[0]
        if len(set(lead.values)) != len(lead.values):
            raise SceneError(
                f"axis[{names[lead.name]}].values",
                list(lead.values),
                "values must not repeat: they label a store dimension (in a [[zip]] group "
                "only the first axis labels it)",
            )
    _refuse_size("sweep points", math.prod(d.size for d in dimensions), max_points)
    return Sweep(base=base, dimensions=tuple(dimensions), zips=tuple(zips), source=source)


def load_sweep(
    path: str | Path, overrides: dict[str, Any] | None = None, *, max_points: int | None = MAX_POINTS
) -> Sweep:
    """Read and validate a sweep file, or the shipped sweep of that name (the points' scenes are checked by
    :func:`sweep_scenes`)."""
    if not isinstance(path, (str, Path)):
        raise SceneError("sweep file", type(path).__name__, "a path or a shipped sweep's name")
    path = shipped_file(path)
    data = read_toml(path, "sweep file")
    refuse_other_kind(data, path, "sweep")
    return sweep_from_dict(data, base_dir=path.parent, overrides=overrides, source=str(path), max_points=max_points)


# ---- what every point must share ------------------------------------------------------

LAYOUT_KEYS = (
    ("chain.grains", lambda s: s.chain.grains),
    ("record count", lambda s: s.record_count),
    ("record.fields", lambda s: s.record.fields),
    ("record.traces", lambda s: s.record.traces),
    ("trace samples", lambda s: s.trace_sample_count),
    ("record.energy", lambda s: s.record.energy),
    ("record.modes", lambda s: s.record.modes),
    ("boundary.surface (driven or not)", lambda s: s.boundary.surface == "driven"),
)
"""Scene properties that shape the store's record/grain dimensions: every point must share them."""


def record_times(scene: Scene) -> np.ndarray:
    """Snapshot times, computed exactly as the runner does (Scene.record_times)."""
    return scene.record_times


def trace_times(scene: Scene) -> np.ndarray | None:
    """Trace sample times, as the runner computes them (None without traces)."""
    if not scene.record.traces:
        return None
    return np.arange(scene.trace_sample_count) * scene.trace_stride * scene.integrator.dt


def sweep_scenes(sweep: Sweep) -> list[Scene]:
    """Build and validate every point's scene; check that all points share the store layout (the
    per-point reference path; ``expand`` does the same without a scene per point)."""
    scenes = sweep.scenes()
    _check_layout(scenes)
    return scenes


# ---- expansion without one scene per point --------------------------------------------------

STATIC_KEYS = ("chain.mass", "chain.a", "chain.exponent", "chain.l0", "chain.load", "chain.gravity")
"""Per-chain keys that the static state depends on (with impurities.K.mass|a)."""
CHUNK_ELEMENTS = 1 << 22
"""Chains × grains computed at once when the planner scans static states (memory bound)."""


FEATURE_KEYS = STATIC_KEYS + ("excitation.impact",)
"""Per-chain keys that decide the kernel variant: the static state's, and the impact speed (whether a
contact can open, hence event-aware steps, depends on the injected energy: hertzian.core.model.contact_can_open)."""


def _is_static_key(key: str) -> bool:
    return key in FEATURE_KEYS or key.startswith(("impurities.", "chain.radii."))


@dataclass(frozen=True, eq=False)
class SweepPoints:
    """Every point of a sweep without a Scene per point.

    Dimensions whose axes are all per-chain scalars (``hertzian.core.chains.PER_CHAIN_KEYS``) are
    *parameter* dimensions: their values become per-chain arrays. The others are *structural*
    (grain count, boundaries, integrator, record, impurity contact rule): one validated
    *template* scene per combination of their values. Point ``p``'s scene is its template with
    its parameter values; ``chains(points)`` gives a batch as a ChainSet.
    """

    sweep: Sweep
    structural: tuple[int, ...]
    """Indices (into sweep.dimensions) of structural dimensions."""
    parameter: tuple[int, ...]
    """Indices of parameter dimensions."""
    templates: tuple[Scene, ...]
    """One scene per combination of structural values (C order over the structural dimensions),
    taken at index 0 of every parameter dimension."""

    @property
    def point_count(self) -> int:
        return self.sweep.point_count

    def grid_index(self, points: np.ndarray) -> tuple[np.ndarray, ...]:
        """Per-dimension indices of flat (C-order) point indices."""
        points = np.asarray(points, dtype=np.int64)
        if not self.sweep.shape:
            return ()
        return np.unravel_index(points, self.sweep.shape)

    def template_index(self, points: np.ndarray) -> np.ndarray:
        """Template of each flat point index."""
        points = np.asarray(points, dtype=np.int64)
        if not self.structural:
            return np.zeros(points.shape, dtype=np.int64)
        index = self.grid_index(points)
        shape = self.sweep.shape
        return np.ravel_multi_index(
            tuple(index[d] for d in self.structural), tuple(shape[d] for d in self.structural)
        ).astype(np.int64)

    def chains(self, points: np.ndarray) -> "ChainSet | list[Scene]":
        """The points (flat indices) as a ChainSet in the given order (a list of scenes when they span templates)."""
        points = np.asarray(points, dtype=np.int64)
        templates = np.unique(self.template_index(points))
        if len(templates) != 1 or scene_path_key(self.templates[int(templates[0])]) is not None:
            # a launch group may join templates that differ only in a key that changes no kernel
            # (an impurity's contact rule): such a batch runs as one scene per point, as before; so do the points
            # of a lattice law, a modal or thermal start or mode records, which chain sets do not build
            return [self.scene(int(p)) for p in points]
        index = self.grid_index(points)
        values = {}
        for d in self.parameter:
            for axis in self.sweep.dimensions[d].axes:
                values[axis.key] = np.asarray(axis.values, dtype=np.float64)[index[d]]
        return ChainSet.of(self.templates[int(templates[0])], values, len(points))

    def scene(self, point: int) -> Scene:
        """The validated scene of one flat point index (as ``Sweep.scene_at``; a sweep without parameter dimensions
        has a template per point: that one)."""
        if not self.parameter:
            return self.templates[int(self.template_index(np.asarray([point]))[0])]
        index = np.unravel_index(int(point), self.sweep.shape) if self.sweep.shape else ()
        return self.sweep.scene_at(tuple(int(i) for i in index))


def _extreme_indices(dimension: Dimension) -> list[int]:
    """Indices along a parameter dimension whose points bound every scene rule.

    One numeric axis: its smallest and largest value. A zip group of numeric axes: its values pair
    up, so for each pattern of signs (−, 0, +) the group's points take, the smallest and largest
    value of each axis among them (at most 3^axes patterns, however long the zip). Non-numeric values:
    every index.
    """
    coordinates = [a.coordinate() for a in dimension.axes]
    if any(c.dtype.kind not in "fiu" for c in coordinates):
        return list(range(dimension.size))
    if len(coordinates) == 1:
        return sorted({int(np.argmin(coordinates[0])), int(np.argmax(coordinates[0]))})
    values = np.stack([c.astype(np.float64) for c in coordinates], axis=1)
    code = ((np.sign(values) + 1).astype(np.int64) * 3 ** np.arange(values.shape[1])).sum(axis=1)
    chosen = set()
    for pattern in np.unique(code):
        members = np.flatnonzero(code == pattern)
        for column in values[members].T:
            chosen.update((int(members[np.argmin(column)]), int(members[np.argmax(column)])))
    return sorted(chosen)


def corner_points(expanded: SweepPoints) -> list[tuple[int, ...]]:
    """Grid indices that validate the whole grid: every structural combination × the extreme indices
    of every parameter dimension (see :func:`validate_grid`)."""
    import itertools

    sweep = expanded.sweep
    choices = []
    for d, dimension in enumerate(sweep.dimensions):
        choices.append(range(dimension.size) if d in expanded.structural else _extreme_indices(dimension))
    return list(itertools.product(*choices))


def validate_grid(expanded: SweepPoints) -> int:
    """Validate the grid by its corners and value ranges; return how many scenes were built.

    Scene rules on per-chain scalars are ranges (> 0, ≥ 0, > 1, finite) or conditions on a value
    being nonzero (a load and l0 together, an impact on a driven surface), so a grid whose every
    structural combination passes at the smallest and largest value of each parameter axis passes
    everywhere; zipped axes pair up, so they are checked per sign pattern (:func:`_extreme_indices`).
    tests/sweeping/test_vectorised_expansion.py checks this against validating every point on generated grids.
    """
    if not expanded.parameter:
        return 0  # every point is a template, built and validated by expand
    points = corner_points(expanded)
    for index in points:
        expanded.sweep.scene_at(index)
    return len(points)


def _check_layout(templates: list[Scene]) -> None:
    first = templates[0]
    for key, get in LAYOUT_KEYS:
        values = {get(s) for s in templates}
        if len(values) > 1:
            raise SceneError(
                key,
                sorted(map(str, values)),
                "every point of a sweep shares the store's record/grain layout; sweep this key in separate sweeps",
            )
    t0, tt0 = record_times(first), trace_times(first)
    for s in templates:
        t = record_times(s)
        if not np.allclose(t, t0, rtol=1e-9, atol=0):
            raise SceneError(
                "record times",
                f"{t[1]:g} vs {t0[1]:g}",
                "every point must record at the same times (record.every a whole number of steps of each dt)",
            )
        tt = trace_times(s)
        if tt is not None and not np.allclose(tt, tt0, rtol=1e-9, atol=0):
            raise SceneError(
                "trace times", f"{tt[1]:g} vs {tt0[1]:g}", "every point must sample traces at the same times"
            )


def expand(sweep: Sweep, *, validate: bool = True) -> SweepPoints:
    """Templates for the structural combinations, parameter dimensions as arrays; validates the grid by
    its corners (:func:`validate_grid`) and checks that every point shares the store layout."""
    structural, parameter = [], []
    for d, dimension in enumerate(sweep.dimensions):
        (parameter if all(is_per_chain_key(a.key) for a in dimension.axes) else structural).append(d)
    shape = sweep.shape
    templates = []
    for combo in np.ndindex(*[shape[d] for d in structural]):
        index = [0] * len(shape)
        for d, i in zip(structural, combo):
            index[d] = i
        templates.append(sweep.scene_at(tuple(index)))
    expanded = SweepPoints(
        sweep=sweep, structural=tuple(structural), parameter=tuple(parameter), templates=tuple(templates)
    )
    if validate:
        validate_grid(expanded)
    _check_layout(templates)
    return expanded


def static_subgrid(expanded: SweepPoints, template: int) -> ChainSet:
    """The distinct configurations of one template's points that decide its kernel variant: the product
    of the parameter dimensions that hold a FEATURE_KEYS key (others at index 0), as a ChainSet.

    A dimension whose axes are all ``excitation.impact`` is taken at its largest |v_imp| only: the impact
    speed enters the kernel variant only through ``contact_can_open``, whose answer can only turn true as
    the injected energy ½·m_0·v_imp² grows, so the fastest impact of each static configuration decides it."""
    sweep = expanded.sweep
    shape = sweep.shape
    impact_only = {d for d in expanded.parameter if all(a.key == "excitation.impact" for a in sweep.dimensions[d].axes)}
    dims = [
        d
        for d in expanded.parameter
        if d not in impact_only and any(_is_static_key(a.key) for a in sweep.dimensions[d].axes)
    ]
    base = [0] * len(shape)
    if expanded.structural:
        combo = np.unravel_index(template, tuple(shape[d] for d in expanded.structural))
        for d, i in zip(expanded.structural, combo):
            base[d] = int(i)
    for d in impact_only:
        speeds = np.abs(np.asarray([a.values for a in sweep.dimensions[d].axes], dtype=np.float64))
        base[d] = int(np.argmax(speeds.max(axis=0)))
    grids = np.meshgrid(*[np.arange(shape[d]) for d in dims], indexing="ij") if dims else []
    count = int(np.prod([shape[d] for d in dims])) if dims else 1
    index = [np.full(count, b, dtype=np.int64) for b in base]
    for d, grid in zip(dims, grids):
        index[d] = grid.reshape(-1)
    points = np.ravel_multi_index(tuple(index), shape) if shape else np.zeros(1, dtype=np.int64)
    return expanded.chains(points)
