"""Reading Zarr v3 stores (docs/model.md §6), as ``xarray.open_zarr`` does: open one, and summarize its points.

The writer is ``hertzian.sweeping.sweep_store`` (``write_result`` writes a run: a sweep with no axes).
Variables carry the sweep axes first (none for a run), then ``record``/``grain`` or ``sample``/``traced``; each
has ``dimension_names`` and the group has consolidated metadata. Every chunk ends with a CRC-32C of its bytes
(``hertzian.sweeping.store_format``), which zarr checks on every read: a damaged chunk raises
:class:`StoreDamagedError` here, never a wrong value.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import zarr
from hertzian.sweeping.store_format import (
    DAMAGE_ERRORS,
    SCHEMA_VERSION,
    StoreDamagedError,
    consolidate,
    has_checksums,
    package_version,
)

__all__ = [
    "SCHEMA_VERSION",
    "StoreDamagedError",
    "consolidate",
    "open_store",
    "package_version",
    "summary_columns",
    "summary_records",
    "unchecked_note",
]


def check_intact(path: str | Path) -> None:
    """Raise :class:`StoreDamagedError` (one line) if the store's metadata or coordinates differ from its manifest,
    or a chunk file of a finished batch is missing (what would read back as fill values, silently). Chunk bytes are
    not read here: zarr checks each chunk's CRC-32C as it reads it."""
    from hertzian.sweeping.integrity import damage_lines, verify_store

    verification = verify_store(path, read=False)
    if verification.damage:
        from hertzian.sweeping.storage import lock_holder

        holder = lock_holder(path)
        if holder is not None:  # a writer between two of its files (its finish rewrites metadata, then the manifest)
            raise StoreDamagedError(f"{path} is being written by {holder}; read it once that has finished")
        first = damage_lines(path, verification)[0]
        more = f" (and {len(verification.damage) - 1} more)" if len(verification.damage) > 1 else ""
        raise StoreDamagedError(f"{path} is damaged: {first}{more}; run hertzian verify {path}")


def open_store(path: str | Path, *, check: bool = True):
    """Open a store's root group read-only: FileNotFoundError or ValueError (one line) if it is not a hertzian
    store; with ``check``, :class:`StoreDamagedError` (one line) if it is damaged (:func:`check_intact`)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such store")
    if not (path / "zarr.json").is_file():
        raise ValueError(f"{path}: not a hertzian store (no zarr.json)")
    if check:
        check_intact(path)
    try:
        group = zarr.open_group(store=str(path), mode="r")
    except Exception as err:  # noqa: BLE001 - whatever zarr raises for unreadable metadata
        raise ValueError(f"{path}: not a readable Zarr store ({type(err).__name__})") from None
    if "schema_version" not in group.attrs:
        raise ValueError(f"{path}: not a hertzian store (no schema_version attribute)")
    return group


def open_dataset(path: str | Path):
    """A store written by ``hertzian run``, ``hertzian sweep`` or :func:`hertzian.sweep` as a lazy
    ``xarray.Dataset`` (FileNotFoundError or ValueError, one line, if it is not a hertzian store;
    :class:`StoreDamagedError` if it is damaged)."""
    import xarray as xr  # about 0.3 s to import, and writing a store (hertzian run) never reads one back

    open_store(path)
    return xr.open_zarr(str(path))


def open_any_dataset(path: str | Path):
    """:func:`open_dataset` for a hertzian store; any other Zarr store (a figure group's analysis store, written by
    xarray) opened as it is."""
    from hertzian.sweeping.manifest import is_project_store

    path = Path(path)
    if is_project_store(path):
        return open_dataset(path)
    import xarray as xr

    return xr.open_zarr(str(path))


SUMMARY_SCHEME = ("method", "precision", "dt", "steps", "grains")


def unchecked_note(path: str | Path) -> str | None:
    """A note when the store's chunks carry no checksums (a store written before them), else None."""
    group = open_store(path, check=False)
    if "status" in group and not has_checksums(group["status"]):
        return f"note: {path} has no chunk checksums (written by an older version): damaged chunks may read silently"
    return None


def summary_columns(path: str | Path) -> dict[str, np.ndarray]:
    """Per point, as columns over the points in C order (vectorised; reads only the per-point
    variables, never u/v/traces): every axis value, status, status name, energy error, the error estimate (where
    the store has one), max overlap,
    wall seconds, grain-steps per second, device and the scheme (method, precision, dt, steps, grains).

    Raises :class:`StoreDamagedError` (one line) if a chunk it reads is damaged."""
    try:
        return _summary_columns(path)
    except DAMAGE_ERRORS as err:
        if isinstance(err, (StoreDamagedError, KeyError)) or "not a hertzian store" in str(err):
            raise
        raise StoreDamagedError(
            f"{path}: a chunk of its per-point variables is damaged ({type(err).__name__}: "
            f"{str(err).split('. Stored')[0][:80]}); run hertzian verify {path}"
        ) from None


def _summary_columns(path: str | Path) -> dict[str, np.ndarray]:
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
    for name in ("energy_error", "error_estimate", "max_overlap", "wall_seconds"):
        if name in members or name != "error_estimate":  # the error estimate only where the run asked for it
            columns[name] = np.asarray(group[name][...], dtype=np.float64).reshape(-1)
    for name, column in (("spectral_entropy", "final_entropy"), ("participation", "final_participation")):
        if name in members:  # record.modes: the last record's
            columns[column] = np.asarray(group[name][..., -1], dtype=np.float64).reshape(-1)
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
