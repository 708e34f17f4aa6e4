"""Zarr v3 stores (SPEC §6), readable by ``xarray.open_zarr``.

One writer (``hertzian.sweeping.sweep_store``): a run is a sweep with no axes. Variables carry the sweep
axes first (none for a run), then ``record``/``grain`` or ``sample``/``traced``. Each variable
has ``dimension_names`` and the group has consolidated metadata. :func:`write_result` writes
into a temporary directory and renames it into place, so a failed write leaves nothing behind
and never clobbers an existing store. :func:`summary_columns` reads the per-point variables.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
import zarr
from hertzian.core.chains import ChainSet
from hertzian.core.runner import RunResult

SCHEMA_VERSION = 1


def consolidate(path: str | Path) -> None:
    """Consolidated metadata (zarr warns that v3 has no spec for it yet; xarray uses it)."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", category=UserWarning)
        zarr.consolidate_metadata(str(path))


def package_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("hertzian")
    except PackageNotFoundError:
        return "0+unknown"


def _flat_scene(scene) -> dict[str, Any]:
    """A scene as dotted keys (``chain.l0``, ``impurities.0.mass``; lists as JSON-ready lists)."""
    data = scene.to_dict()
    out = {}
    for section, values in data.items():
        if section == "impurities":
            out["impurities"] = len(values)
            for k, block in enumerate(values):
                out.update({f"impurities.{k}.{key}": value for key, value in block.items()})
            continue
        out.update({f"{section}.{key}": value for key, value in values.items()})
    return out


def scene_differences(scenes) -> dict[str, list]:
    """Dotted scene keys whose values differ between ``scenes`` → every scene's value, in order."""
    flats = [_flat_scene(s) for s in scenes]
    keys = sorted(set().union(*flats))
    return {k: [f.get(k) for f in flats] for k in keys if any(f.get(k) != flats[0].get(k) for f in flats)}


def _axis_key(name: str, values: np.ndarray, dim: int, shape: tuple[int, ...], differences: dict) -> str:
    """The scene key that varies exactly like axis ``name`` (its values along dimension ``dim``), or ''."""
    for key, per_point in differences.items():
        grid = np.array(per_point, dtype=object).reshape(shape)
        along = np.moveaxis(grid, dim, 0).reshape(shape[dim], -1)
        if all(len(set(map(repr, row))) == 1 for row in along) and [row[0] for row in along] == list(values):
            return key
    return ""


def write_result(
    path: str | Path,
    result: RunResult,
    *,
    axes: dict[str, np.ndarray] | None = None,
    sweep: dict | None = None,
    overwrite: bool = False,
) -> Path:
    """Write a run (or an ensemble shaped by ``axes``: name → coordinate values, C order) as a Zarr v3
    store, through the sweep store's writer: a run is a sweep with no axes, one batch.

    Scenes that differ between points are kept: the ``scene`` attribute holds the first point's,
    ``scene_overrides`` (JSON) every differing dotted key's value at every point, and an axis whose
    values are exactly one differing key's gets that key as its ``scene_key``. ``sweep`` (plain
    data) is stored as the ``sweep`` attribute when given.
    """
    from hertzian.sweeping.planner import single_batch_plan
    from hertzian.sweeping.spec import RESERVED_NAMES, Axis, Dimension, Sweep
    from hertzian.sweeping.sweep_store import create_sweep_store, finalize, write_batch

    path = Path(path)
    axes = {name: np.asarray(values) for name, values in (axes or {}).items()}
    shape = tuple(len(v) for v in axes.values())
    if int(np.prod(shape)) != result.chain_count:
        raise ValueError(f"axes {shape} do not match {result.chain_count} chains")
    clash = sorted(set(axes) & RESERVED_NAMES)
    if clash:
        raise ValueError(f"axis names {clash} are store variable names; choose others")
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists (pass --overwrite to replace it)")
    scenes = result.scenes
    scene = scenes[0]
    if isinstance(scenes, ChainSet):  # differences straight from the per-chain arrays
        differences = {k: v.tolist() for k, v in scenes.values.items() if np.any(v != v[0])}
    else:
        differences = scene_differences(list(scenes)) if len(scenes) > 1 else {}
    dimensions = tuple(
        Dimension(
            axes=(
                Axis(
                    name=name,
                    key=_axis_key(name, values.tolist(), d, shape, differences),
                    values=tuple(values.tolist()),
                ),
            )
        )
        for d, (name, values) in enumerate(axes.items())
    )
    definition = Sweep(base=scene, dimensions=dimensions)
    plan = single_batch_plan(shape, scene, result.features, result.device)
    attributes = {"scene_overrides": json.dumps(differences)}
    if sweep is not None:
        attributes["sweep"] = json.dumps(sweep)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", dir=path.parent if path.parent.exists() else None))
    try:
        target = tmp / "store.zarr"
        create_sweep_store(target, definition, scene, plan, device=result.device, attributes=attributes)
        write_batch(target, plan.batches[0], result, grain_steps=result.grain_count * result.steps * result.chain_count)
        finalize(target)
        if path.exists():
            shutil.rmtree(path)
        target.rename(path)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return path


def open_store(path: str | Path):
    """Open a store's root group read-only (clear error if it is not a hertzian store)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such store")
    group = zarr.open_group(store=str(path), mode="r")
    if "schema_version" not in group.attrs:
        raise ValueError(f"{path}: not a hertzian store (no schema_version attribute)")
    return group


def open_dataset(path: str | Path):
    """A store written by ``hertzian run``, ``hertzian sweep`` or :func:`hertzian.sweep` as a lazy
    ``xarray.Dataset`` (FileNotFoundError or ValueError, one line, if it is not a hertzian store)."""
    open_store(path)
    return xr.open_zarr(str(path))


def result_dataset(result: RunResult, axes: dict[str, np.ndarray] | None = None):
    """``result`` as the ``xarray.Dataset`` (in memory) that ``hertzian run --out`` stores: the same variables,
    dimensions and attributes, written and read back through :func:`write_result`. ``axes`` as there; an ensemble
    without them gets one axis ``chain`` (0, 1, …)."""
    if axes is None and result.chain_count > 1:
        axes = {"chain": np.arange(result.chain_count)}
    with tempfile.TemporaryDirectory(prefix="hertzian-result-") as tmp:
        with open_dataset(write_result(Path(tmp) / "run.zarr", result, axes=axes)) as dataset:
            return dataset.load()


SUMMARY_SCHEME = ("method", "precision", "dt", "steps", "grains")


def summary_columns(path: str | Path) -> dict[str, np.ndarray]:
    """Per point, as columns over the points in C order (vectorised; reads only the per-point
    variables, never u/v/traces): every axis value, status, status name, energy error, max overlap,
    wall seconds, grain-steps per second, device and the scheme (method, precision, dt, steps, grains)."""
    group = open_store(path)
    attrs = group.attrs.asdict() if hasattr(group.attrs, "asdict") else dict(group.attrs)
    prov = dict(attrs["provenance"])
    dims = list(attrs.get("scenes_differ_along", []))
    status = np.asarray(group["status"][...])
    shape = status.shape
    count = status.size
    axis_dims = {name: dims.index(spec["dim"]) for name, spec in dict(attrs.get("sweep_axes", {})).items()}
    axis_dims = axis_dims or {a: k for k, a in enumerate(dims)}
    index = np.unravel_index(np.arange(count), shape) if shape else ()
    columns: dict[str, np.ndarray] = {}
    for name, d in axis_dims.items():
        columns[name] = np.asarray(group[name][...])[index[d]]
    codes = attrs["status_codes"]
    flat_status = status.reshape(-1).astype(np.int64)
    names = {int(k): v.split(":")[0] for k, v in codes.items()}
    columns["status"] = flat_status
    unique, inverse = np.unique(flat_status, return_inverse=True)
    columns["status_name"] = np.array([names.get(c, "?") for c in unique.tolist()] or ["?"])[inverse.reshape(-1)]
    members = set(group.array_keys())
    for name in ("energy_error", "max_overlap", "wall_seconds"):
        columns[name] = np.asarray(group[name][...], dtype=np.float64).reshape(-1)
    if "grain_steps_per_second" in members:
        columns["grain_steps_per_second"] = np.asarray(group["grain_steps_per_second"][...], dtype=np.float64).reshape(
            -1
        )
    else:
        columns["grain_steps_per_second"] = np.full(count, float(prov["grain_steps_per_second"]))
    columns["device"] = np.full(count, str(prov["device"]))
    launch_groups = list(attrs.get("launch_groups", []))
    # the scheme of every point from its launch group: plain numpy (numbers, fixed-width strings)
    if "launch_group" in members and launch_groups:
        point_group = np.asarray(group["launch_group"][...]).reshape(-1).astype(np.int64)
        point_group = np.where((point_group >= 0) & (point_group < len(launch_groups)), point_group, len(launch_groups))
    else:
        point_group = np.full(count, len(launch_groups), dtype=np.int64)
    for key in SUMMARY_SCHEME:
        columns[key] = np.array([g[key] for g in launch_groups] + [prov[key]])[point_group]
    return columns


def summary_records(path: str | Path) -> list[dict[str, Any]]:
    """One record per point: its axis values, status, energy error, wall seconds and throughput."""
    columns = summary_columns(path)
    names = list(columns)
    values = [columns[n].tolist() for n in names]
    return [dict(zip(names, row)) for row in zip(*values)]
