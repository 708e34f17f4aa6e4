"""Zarr v3 stores (SPEC §6), readable by ``xarray.open_zarr``.

A run is a sweep with no axes: variables carry the sweep axes first (none for a run), then
``record``/``grain`` or ``sample``/``traced``. Each variable has ``dimension_names`` and the
group has consolidated metadata. Stores are written into a temporary directory and renamed
into place, so a failed write leaves nothing behind and never clobbers an existing store.
"""

from __future__ import annotations

import json
import platform
import shutil
import tempfile
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np
import zarr

from .runner import RunResult
from .status import status_attrs

SCHEMA_VERSION = 1
CHUNK_BYTES = 8 << 20
"""Target chunk size: about 8 MiB."""


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


def provenance(result: RunResult) -> dict[str, Any]:
    """What produced a result: versions, device, scheme, cost and error."""
    import warp as wp

    scene = result.scenes[0]
    return {
        "package": "hertzian",
        "package_version": package_version(),
        "warp_version": wp.config.version,
        "python_version": platform.python_version(),
        "device": result.device,
        "precision": scene.integrator.precision,
        "method": scene.integrator.method,
        "dt": scene.integrator.dt,
        "steps": result.steps,
        "chains": result.chain_count,
        "grains": result.grain_count,
        "wall_seconds": result.wall_seconds,
        "grain_steps_per_second": result.grain_steps_per_second,
        "energy_error_max": float(np.max(result.energy_error)) if result.energy_error.size else 0.0,
        "kernel_features": {k: getattr(result.features, k) for k in result.features.__dataclass_fields__},
        "kernel": getattr(result, "kernel", "step"),
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }


def chunks_for(shape: tuple[int, ...], itemsize: int, *, lead: int = 0) -> tuple[int, ...]:
    """Chunks of about CHUNK_BYTES: whole trailing dims, split along the first dims as needed."""
    chunks = list(shape)
    for axis in range(len(shape)):
        total = int(np.prod(chunks)) * itemsize
        if total <= CHUNK_BYTES or axis >= len(shape) - 1:
            break
        rest = int(np.prod(chunks[axis + 1:])) * itemsize
        chunks[axis] = max(1, min(chunks[axis], CHUNK_BYTES // max(rest, 1)))
    return tuple(max(1, c) for c in chunks)


def _array(group, name: str, data: np.ndarray, dims: tuple[str, ...], attrs: dict | None = None):
    data = np.asarray(data)
    arr = group.create_array(name, shape=data.shape, dtype=data.dtype,
                             chunks=chunks_for(data.shape, data.dtype.itemsize) if data.ndim else (),
                             dimension_names=list(dims), fill_value=0, attributes=attrs or {})
    arr[...] = data
    return arr


def write_result(path: str | Path, result: RunResult, *, axes: dict[str, np.ndarray] | None = None,
                 sweep: dict | None = None, overwrite: bool = False) -> Path:
    """Write a run (or an ensemble shaped by ``axes``: name → coordinate values) as a Zarr v3 store."""
    path = Path(path)
    axes = dict(axes or {})
    shape = tuple(len(v) for v in axes.values())
    if int(np.prod(shape)) != result.chain_count:
        raise ValueError(f"axes {shape} do not match {result.chain_count} chains")
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists (pass --overwrite to replace it)")
    axis_dims = tuple(axes)
    scene = result.scenes[0]

    def per_point(array: np.ndarray) -> np.ndarray:
        return array.reshape(shape + array.shape[1:])

    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", dir=path.parent if path.parent.exists() else None))
    try:
        root = zarr.open_group(store=str(tmp / "store.zarr"), mode="w", zarr_format=3)
        for name, values in axes.items():
            _array(root, name, np.asarray(values), (name,))
        _array(root, "t", result.t, ("record",), {"units": "program time (1.0102e-3 s)"})
        _array(root, "grain", np.arange(result.grain_count, dtype=np.int32), ("grain",),
               {"long_name": "grain index from the surface"})
        for name, data in result.fields.items():
            _array(root, name, per_point(data), axis_dims + ("record", "grain"),
                   {"coordinates": "t", "units": "program length (1e-5 m)" if name == "u" else
                    "program velocity (1e-5 m / 1.0102e-3 s)", "long_name": {"u": "displacement from static "
                    "equilibrium, positive toward the bottom", "v": "velocity, positive toward the bottom"}[name]})
        if scene.record.energy:
            _array(root, "energy", per_point(result.energy), axis_dims + ("record",),
                   {"coordinates": "t", "long_name": "total energy relative to the static state "
                    "(SPEC §5 E minus a constant)"})
            if result.work is not None:
                _array(root, "work", per_point(result.work), axis_dims + ("record",),
                       {"coordinates": "t", "long_name": "work done by the driver on the chain"})
        if result.trace_t is not None:
            _array(root, "trace_t", result.trace_t, ("sample",))
            _array(root, "traced_grain", np.asarray(scene.record.traces, dtype=np.int32), ("traced",))
            for name, data in result.traces.items():
                _array(root, f"trace_{name}", per_point(data), axis_dims + ("sample", "traced"),
                       {"coordinates": "trace_t traced_grain"})
        _array(root, "status", per_point(result.status.astype(np.int32)), axis_dims,
               {"flag_values": [int(k) for k in status_attrs()], "flag_meanings": status_attrs()})
        _array(root, "energy_error", per_point(result.energy_error), axis_dims,
               {"long_name": "max_t |E(t) - E(0) [- W(t)]| / E_inj (absolute when nothing is injected)"})
        _array(root, "max_overlap", per_point(result.max_overlap), axis_dims)
        wall = np.full(result.chain_count, result.wall_seconds / result.chain_count)
        _array(root, "wall_seconds", per_point(wall), axis_dims,
               {"long_name": "wall seconds of the ensemble, shared evenly among its chains"})
        root.attrs.update({
            "schema_version": SCHEMA_VERSION,
            "scene": json.dumps(scene.to_dict()) if not axes else json.dumps(scene.to_dict()),
            "scenes_differ_along": axis_dims,
            "sweep": json.dumps(sweep) if sweep is not None else "",
            "status_codes": status_attrs(),
            "provenance": provenance(result),
        })
        consolidate(tmp / "store.zarr")
        if path.exists():
            shutil.rmtree(path)
        (tmp / "store.zarr").rename(path)
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


def summary_records(path: str | Path) -> list[dict[str, Any]]:
    """One record per point: its axis values, status, energy error, wall seconds and throughput."""
    group = open_store(path)
    prov = dict(group.attrs["provenance"])
    axes = list(group.attrs.get("scenes_differ_along", []))
    status = np.asarray(group["status"][...])
    err = np.asarray(group["energy_error"][...])
    wall = np.asarray(group["wall_seconds"][...])
    overlap = np.asarray(group["max_overlap"][...])
    codes = group.attrs["status_codes"]
    # sweeps: every axis (zipped ones are coordinates along their group's dimension), per-point
    # throughput, and per-point scheme from the point's launch group; runs have none of these
    axis_dims = {name: axes.index(spec["dim"]) for name, spec in dict(group.attrs.get("sweep_axes", {})).items()}
    axis_dims = axis_dims or {a: k for k, a in enumerate(axes)}
    coords = {a: np.asarray(group[a][...]) for a in axis_dims}
    members = set(group.array_keys())
    rate = np.asarray(group["grain_steps_per_second"][...]) if "grain_steps_per_second" in members else None
    point_group = np.asarray(group["launch_group"][...]) if "launch_group" in members else None
    launch_groups = list(group.attrs.get("launch_groups", []))
    records = []
    for index in np.ndindex(status.shape):
        rec = {a: coords[a][index[k]].item() for a, k in axis_dims.items()}
        scheme = prov
        if point_group is not None and 0 <= int(point_group[index]) < len(launch_groups):
            scheme = launch_groups[int(point_group[index])]
        rec.update({
            "status": int(status[index]),
            "status_name": codes.get(str(int(status[index])), "?").split(":")[0],
            "energy_error": float(err[index]),
            "max_overlap": float(overlap[index]),
            "wall_seconds": float(wall[index]),
            "grain_steps_per_second": float(rate[index]) if rate is not None else prov["grain_steps_per_second"],
            "device": prov["device"],
            "method": scheme["method"],
            "precision": scheme["precision"],
            "dt": scheme["dt"],
            "steps": scheme["steps"],
            "grains": scheme["grains"],
        })
        records.append(rec)
    return records
