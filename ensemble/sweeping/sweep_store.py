"""A sweep's Zarr v3 store (docs/model.md §6): one group, sweep dimensions first, filled batch by batch.

Layout, as ``hertzian.sweeping.store.write_result`` writes a run, with the sweep dimensions in front:
``u``/``v`` (*dims, record, grain), ``energy`` (*dims, record), ``trace_u``/``trace_v``
(*dims, sample, traced), per point ``status``, ``energy_error``, ``max_overlap``,
``wall_seconds``, ``grain_steps_per_second`` and ``launch_group``; coordinates for every axis
(zipped axes are coordinates along their group's dimension), ``t``, ``grain``, ``trace_t``,
``traced_grain``.

Crash safety:

1. :func:`create_sweep_store` writes every array's metadata, the coordinates and the
   attributes into a temporary directory and renames it into place: a store at the path is
   always complete, and its data arrays read as fill values (NaN, status −1 = not run) until
   filled.
2. A batch is one hyper-rectangular block of the sweep grid, and the store chunks the sweep
   dimensions by exactly that block (big variables are sharded: one shard = one batch, inner
   chunks of about 1 MiB, a few points each). So a batch writes whole chunks only, no two batches (or workers) ever
   write one file, and zarr's LocalStore writes each file atomically (temporary file + rename).
3. :func:`write_batch` writes the batch's data, then its completion record: one row of the
   small arrays in the ``batches`` group — ``batches/record`` (float64: wall seconds,
   grain-steps, throughput, energy error, finish time, …), ``batches/where`` (device, host,
   worker, kernel) — and last its flag in ``batches/done`` (int8, 1 = finished). Every array
   there is chunked one batch per chunk, so workers never write one file, and a store of 10⁶
   points has a few hundred bytes of metadata for them however many batches it has. Resuming
   skips batches whose flag is set and reruns the others, which rewrites the same chunks with
   the same bits.
4. :func:`finalize` sums the records into the ``provenance`` attribute and re-consolidates.
"""

from __future__ import annotations

import contextlib
import json
import math
import platform
import shutil
import tempfile
import time
import warnings
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import zarr
import zarr.errors
from hertzian.core.chains import ChainSet
from hertzian.core.error_estimate import ERROR_ESTIMATE_MEANING
from hertzian.core.scene import Scene
from hertzian.core.status import status_attrs
from hertzian.sweeping.grain_store import grain_arrays, grain_variables, records_grains
from hertzian.sweeping.integrity import BATCHES, Verification, finished_batches, verify_store
from hertzian.sweeping.manifest import ManifestError, covered_files, fixed_array_names, read_manifest, write_manifest
from hertzian.sweeping.planner import Batch, Plan, single_batch_plan
from hertzian.sweeping.spec import RESERVED_NAMES, Axis, Dimension, Sweep, record_times, trace_times
from hertzian.sweeping.storage import (
    MANIFEST,
    PROJECT,
    StorageError,
    check_free_space,
    check_replaceable,
    check_store_present,
    resolved_link,
    storage_faults,
    store_lock,
)
from hertzian.sweeping.store_format import SCHEMA_VERSION, chunk_codecs, consolidate, package_version

if TYPE_CHECKING:  # annotations only: the runner imports this module to write its result
    from hertzian.core.runner import RunResult

NOT_RUN = -1
"""``status`` of a point whose batch has not finished."""
RECORD_COLUMNS = (
    "points",
    "wall_seconds",
    "grain_steps",
    "grain_steps_per_second",
    "energy_error_max",
    "finished",
    "build_seconds",
    "write_seconds",
)
"""Columns of ``batches/record`` (float64; ``finished`` in seconds since 1970-01-01 UTC)."""
WHERE_COLUMNS = ("device", "host", "worker", "kernel")
"""Columns of ``batches/where`` (strings)."""
INNER_CHUNK_BYTES = 1 << 20
"""Target size of an inner chunk (what reading one point costs at least): about 1 MiB."""
TIMING_VARIABLES = ("wall_seconds", "grain_steps_per_second")
POINT_COORDINATES = ("launch_group", "grain_steps_per_second")
"""Per-point arrays that xarray opens as coordinates (named in ``status``'s ``coordinates`` attribute)."""
"""Per-point variables that measure the machine, not the physics (they differ between runs)."""

TIME_UNITS = "program time (1.0102e-3 s)"
ENERGY_UNITS = "program energy (2.36e-5 kg · (1e-5 m / 1.0102e-3 s)²)"
DIMENSIONLESS = "1"
FIELD_ATTRS = {
    "u": {
        "coordinates": "t",
        "units": "program length (1e-5 m)",
        "long_name": "displacement from static equilibrium, positive toward the bottom",
    },
    "v": {
        "coordinates": "t",
        "units": "program velocity (1e-5 m / 1.0102e-3 s)",
        "long_name": "velocity, positive toward the bottom",
    },
}


class SweepStoreError(ValueError):
    """A store that cannot take this sweep (different sweep, package version, layout)."""


def warp_version() -> str:
    import warp as wp

    return wp.config.version


def status_codes() -> dict[str, str]:
    """Status codes of a run plus ``-1: NOT_RUN``."""
    return {
        str(NOT_RUN): "NOT_RUN: the point's batch has not finished (interrupted sweep; use --resume)",
        **status_attrs(),
    }


# ---- variables ---------------------------------------------------------------------------

ROW_SHARD_BYTES = 8 << 20
"""A batch's snapshots (and traces) are sharded along the record dim in groups of records of at least about this
many bytes: one record each for gpu_10k.toml (20 MB a record), 53 (rounded up to whole inner chunks: 65) for the
driven 10 000-grain columns of paper_fig9_10.toml (160 kB a record), whose 2001 one-record shards cost the store thread
≈ 2 ms each, 4 s in all."""


def records_per_shard(block_points: int, record_bytes_per_point: int) -> int:
    """Records per shard of a batch block of ``block_points`` points: enough for ROW_SHARD_BYTES."""
    return max(1, -(-ROW_SHARD_BYTES // max(1, block_points * record_bytes_per_point)))


def trace_rows_per_record(scene: Scene) -> int | None:
    """Trace samples between two records when every record interval holds the same whole number of them
    (the traces' shards are then cut there, so they can be written record by record), else None."""
    steps = np.diff(scene.record_steps)
    stride = scene.trace_stride
    if len(steps) < 2 or np.any(steps[:-1] != steps[0]) or steps[0] % stride:
        return None
    return int(steps[0] // stride)


def _store_real(plan: Plan) -> np.dtype:
    precisions = {g.key.precision for g in plan.groups}
    return np.dtype(np.float64 if "float64" in precisions else np.float32)


def _variable(name: str, dims: tuple[str, ...], trailing: tuple[int, ...], dtype, fill, attrs: dict, **extra) -> dict:
    return dict(name=name, dims=dims, trailing=trailing, dtype=np.dtype(dtype), fill=fill, attrs=attrs, **extra)


def _record_variables(scene: Scene, dims: tuple[str, ...], coords, real: np.dtype, block_points: int) -> list[dict]:
    """Snapshots (``u``, ``v``) and the per-record energies (``energy``, ``work``, ``dissipated``)."""
    records, n = scene.record_count, scene.chain.grains
    out = [
        _variable(
            name,
            dims + ("record", "grain"),
            (records, n),
            real,
            np.nan,
            {**FIELD_ATTRS[name], **coords("t")},
            rows_per_shard=records_per_shard(block_points, n * real.itemsize),
        )
        for name in scene.record.fields
    ]
    per_record = []
    if scene.record.energy:
        per_record.append(("energy", "total energy relative to the static state (model.md: E minus a constant)"))
        if scene.boundary.surface == "driven":
            per_record.append(("work", "work done by the driver on the chain"))
        if scene.damping.model != "none":
            per_record.append(("dissipated", "energy dissipated by damping up to the record"))
    for name, long_name in per_record:
        out.append(
            _variable(
                name,
                dims + ("record",),
                (records,),
                np.float64,
                np.nan,
                {**coords("t"), "units": ENERGY_UNITS, "long_name": long_name},
            )
        )
    return out


def _spectrum_variables(scene: Scene, dims: tuple[str, ...], coords) -> list[dict]:
    """The normal-mode energies and their summaries (``record.modes``; hertzian.core.spectrum)."""
    if not scene.record.modes:
        return []
    records, modes = scene.record_count, mode_count(scene)
    return [
        _variable(
            "mode_energy",
            dims + ("record", "mode"),
            (records, modes),
            np.float64,
            np.nan,
            {
                **coords("t mode"),
                "units": ENERGY_UNITS,
                "long_name": "harmonic normal-mode energy ½ m (P_k² + ω_k² Q_k²)",
            },
        ),
        _variable(
            "spectral_entropy",
            dims + ("record",),
            (records,),
            np.float64,
            np.nan,
            {
                **coords("t"),
                "units": DIMENSIONLESS,
                "long_name": "−Σ e_k ln e_k, e_k = E_k / Σ E over modes with ω_k > 0",
            },
        ),
        _variable(
            "participation",
            dims + ("record",),
            (records,),
            np.float64,
            np.nan,
            {**coords("t"), "units": DIMENSIONLESS, "long_name": "participation number 1 / Σ e_k²"},
        ),
    ]


def mode_count(scene: Scene) -> int:
    """Normal modes of a chain (hertzian.core.modes): N with walls, N (the translation, k = 0, included) free."""
    return scene.chain.grains


def _response_variables(scene: Scene, dims: tuple[str, ...], coords) -> list[dict]:
    """The drive's response windows (``response``, ``window_ke``, ``driver_open``, ``window_start``)."""
    if not scene.has_response:
        return []
    windows, harmonics, n = scene.record.response_windows, scene.record.harmonics + 1, scene.chain.grains
    return [
        _variable(
            "response",
            dims + ("window", "harmonic", "grain"),
            (windows, harmonics, n),
            np.complex128,
            complex(np.nan, np.nan),
            {
                **coords("window_start"),
                "units": FIELD_ATTRS["v"]["units"],
                "long_name": "V_k = (c_k/T_w) ∫ v e^{-ikωt} dt over the "
                "window (c_0 = 1, c_k = 2), t absolute [length/time]",
            },
        ),
        _variable(
            "window_ke",
            dims + ("window", "grain"),
            (windows, n),
            np.float64,
            np.nan,
            {**coords("window_start"), "units": ENERGY_UNITS, "long_name": "window-averaged kinetic energy ½ m v²"},
        ),
        _variable(
            "driver_open",
            dims + ("window",),
            (windows,),
            np.float64,
            np.nan,
            {
                **coords("window_start"),
                "units": DIMENSIONLESS,
                "long_name": "fraction of the window during which the driver–grain-1 contact is open",
            },
        ),
        _variable(
            "window_start",
            dims + ("window",),
            (windows,),
            np.float64,
            np.nan,
            {"units": TIME_UNITS, "long_name": "start time of the window (depends on the point's period)"},
        ),
    ]


def _trace_variables(scene: Scene, dims: tuple[str, ...], coords, real: np.dtype, block_points: int) -> list[dict]:
    """The traced grains' samples (``trace_u``, ``trace_v``)."""
    tt = trace_times(scene)
    if tt is None:
        return []
    per_record = trace_rows_per_record(scene)
    traced = len(scene.record.traces)
    rows = (
        None
        if per_record is None
        else per_record * records_per_shard(block_points, per_record * traced * real.itemsize)
    )
    return [
        _variable(
            f"trace_{name}",
            dims + ("sample", "traced"),
            (len(tt), traced),
            real,
            np.nan,
            {"units": FIELD_ATTRS[name]["units"], **coords("trace_t", "traced_grain")},
            rows_per_shard=rows,
        )
        for name in ("u", "v")
    ]


def _point_variables(dims: tuple[str, ...], coords, *, error_estimate: bool = False) -> list[dict]:
    """One value per point: ``status``, ``energy_error``, ``max_overlap``, ``error_estimate`` (when asked for),
    ``wall_seconds``, ``grain_steps_per_second``."""
    codes = status_codes()
    described = {  # name: (units, long name)
        "energy_error": (DIMENSIONLESS, "max_t |E(t) - E(0) [- W(t)]| / E_inj (absolute when nothing is injected)"),
        "max_overlap": (FIELD_ATTRS["u"]["units"], "largest overlap at any check"),
        "wall_seconds": ("s", "wall seconds of the ensemble, shared evenly among its chains"),
        "grain_steps_per_second": ("grain-steps/s", "throughput of the point's batch (all its chains)"),
    }
    out = [
        _variable(
            "status",
            dims,
            (),
            np.int32,
            NOT_RUN,
            # the point's launch group and its batch's throughput describe how it ran, not what it is: xarray reads
            # them as coordinates (CF's "coordinates" attribute), not data variables
            {**coords(*POINT_COORDINATES), "flag_values": [int(k) for k in codes], "flag_meanings": codes},
        )
    ]
    for name, (units, long_name) in described.items():
        out.append(_variable(name, dims, (), np.float64, np.nan, {**coords(), "units": units, "long_name": long_name}))
        if name == "max_overlap" and error_estimate:
            attrs = {**coords(), "units": "relative", "long_name": ERROR_ESTIMATE_MEANING}
            out.append(_variable("error_estimate", dims, (), np.float64, np.nan, attrs))
    return out


def variables(sweep: Sweep, scene: Scene, plan: Plan) -> list[dict[str, Any]]:
    """Every data variable of the store: name, dims, trailing shape, dtype, fill value, attributes (and
    ``rows_per_shard`` where records are sharded on their own)."""
    dims = sweep.dims
    companions = [a.name for d in sweep.dimensions for a in d.axes[1:]]
    real = _store_real(plan)
    block_points = math.prod(plan.block) if plan.block else 1

    def coords(*names: str) -> dict:
        joined = " ".join(list(names) + companions)
        return {"coordinates": joined} if joined else {}

    return (
        _record_variables(scene, dims, coords, real, block_points)
        + _response_variables(scene, dims, coords)
        + _spectrum_variables(scene, dims, coords)
        + _trace_variables(scene, dims, coords, real, block_points)
        + _point_variables(dims, coords, error_estimate=scene.record.error_estimate)
        + grain_variables(sweep, scene, coords())
    )


def store_estimate(sweep: Sweep, scene: Scene, plan: Plan) -> int:
    """Bytes the finished store takes at most [bytes]: every variable uncompressed (simulated floats barely
    compress), plus 1 MiB of metadata and coordinates."""
    points = max(1, plan.point_count)
    data = sum(math.prod(v["trailing"]) * v["dtype"].itemsize for v in variables(sweep, scene, plan))
    return points * data + (1 << 20)


def _trailing_chunks(trailing: tuple[int, ...], itemsize: int) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """(inner chunk, shard extent) along the trailing dims of one point: whole rows, at most about
    INNER_CHUNK_BYTES per chunk; the shard covers the whole extent (rounded up to whole chunks)."""
    if not trailing:
        return (), ()
    row = int(np.prod(trailing[1:])) * itemsize
    first = max(1, min(trailing[0], INNER_CHUNK_BYTES // max(row, 1)))
    shard_first = math.ceil(trailing[0] / first) * first
    return (first,) + trailing[1:], (shard_first,) + trailing[1:]


def _sub_block(block: tuple[int, ...], points: int) -> tuple[int, ...]:
    """A block of at most ``points`` points that tiles ``block`` (whole trailing dims, then a divisor)."""
    sub = [1] * len(block)
    room = max(1, points)
    for d in reversed(range(len(block))):
        if block[d] <= room:
            sub[d] = block[d]
            room //= block[d]
            continue
        sub[d] = max(k for k in range(1, room + 1) if block[d] % k == 0)
        break
    return tuple(sub)


def chunk_layout(block: tuple[int, ...], trailing: tuple[int, ...], itemsize: int, rows_per_shard: int | None = None):
    """(chunks, shards or None) of a variable: one shard (or chunk) per batch block along the sweep
    dims; inner chunks of about INNER_CHUNK_BYTES (a few points), so reading one point stays cheap.

    ``rows_per_shard``: cut the shards along the first trailing dim (records, trace samples) every that many rows,
    so a batch's early records can be written while it still runs (:class:`RowWriter`); the inner chunks then hold
    a divisor of it (whole rows) and more points."""
    block = tuple(block)
    if not trailing:
        return block, None
    trailing = tuple(trailing)
    if rows_per_shard is not None and 0 < rows_per_shard < trailing[0]:
        row = int(np.prod(trailing[1:])) * itemsize
        first = max(1, min(rows_per_shard, INNER_CHUNK_BYTES // max(row, 1)))
        # the shard holds whole inner chunks of ~INNER_CHUNK_BYTES: its rows rounded up to a multiple of theirs (53
        # records of 80 kB had made 53 one-record chunks a shard, 53 being prime)
        rows = -(-rows_per_shard // first) * first
        if rows >= trailing[0]:
            return chunk_layout(block, trailing, itemsize)
        inner, shard = (first,) + trailing[1:], (rows,) + trailing[1:]
    else:
        inner, shard = _trailing_chunks(trailing, itemsize)
    point_bytes = int(np.prod(inner)) * itemsize
    chunks = _sub_block(block, INNER_CHUNK_BYTES // max(point_bytes, 1)) + inner
    shards = block + shard
    return (chunks, None) if chunks == shards else (chunks, shards)


def _create(group, name: str, shape, dtype, dims, block, trailing, fill, attrs, rows_per_shard=None):
    chunks, shards = chunk_layout(tuple(block), tuple(trailing), np.dtype(dtype).itemsize, rows_per_shard)
    return group.create_array(
        name,
        shape=tuple(shape),
        dtype=dtype,
        chunks=chunks,
        shards=shards,
        dimension_names=list(dims),
        fill_value=fill,
        attributes=attrs,
        compressors=chunk_codecs(),
    )


def _small(
    group, name: str, data: np.ndarray, dims: tuple[str, ...], attrs: dict | None = None, chunks=None, fill=None
):
    data = np.asarray(data)
    arr = group.create_array(
        name,
        shape=data.shape,
        dtype=data.dtype if data.dtype.kind != "U" else str,
        chunks=tuple(chunks) if chunks else data.shape or (),
        dimension_names=list(dims),
        fill_value=fill if fill is not None else "" if data.dtype.kind == "U" else 0,
        attributes=attrs or {},
        compressors=chunk_codecs(),
    )
    arr[...] = data
    return arr


def launch_groups_attr(plan: Plan) -> list[dict[str, Any]]:
    out = []
    for g in plan.groups:
        key = g.key
        out.append(
            {
                "grains": key.grains,
                "method": key.method,
                "precision": key.precision,
                "dt": key.dt,
                "steps": g.grain_steps_per_chain // key.grains,
                "points": g.point_count,
                "kernel_features": {k: getattr(g.features, k) for k in g.features.__dataclass_fields__},
            }
        )
    return out


def _provenance(plan: Plan, device: str) -> dict[str, Any]:
    import warp as wp

    first = launch_groups_attr(plan)[0]
    return {
        "package": "hertzian",
        "package_version": package_version(),
        "warp_version": wp.config.version,
        "python_version": platform.python_version(),
        "device": device,
        "precision": first["precision"],
        "method": first["method"],
        "dt": first["dt"],
        "steps": first["steps"],
        "chains": plan.point_count,
        "grains": first["grains"],
        "wall_seconds": 0.0,
        "grain_steps_per_second": 0.0,
        "energy_error_max": 0.0,
        "kernel_features": first["kernel_features"],
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "complete": False,
        "batches": len(plan.batches),
        "batches_done": 0,
        "grain_steps": plan.grain_steps,
    }


def fixed_arrays(sweep: Sweep, scene: Scene, plan: Plan) -> list[tuple[str, np.ndarray, tuple[str, ...], dict]]:
    """The arrays a store holds from its creation on, never written by a batch: (name, data, dims, attributes) of
    every axis coordinate, ``t``, ``grain``, ``harmonic``, ``trace_t``, ``traced_grain``, ``mode``, ``mode_frequency``
    and ``launch_group``."""
    out = [
        (axis.name, axis.coordinate(), (d.name,), {"scene_key": axis.key, "long_name": f"scene key {axis.key}"})
        for d in sweep.dimensions
        for axis in d.axes
    ]
    out.append(("t", record_times(scene), ("record",), {"units": TIME_UNITS}))
    grains = np.arange(scene.chain.grains, dtype=np.int32)
    out.append(("grain", grains, ("grain",), {"long_name": "grain index from the surface"}))
    if scene.record.modes:
        from hertzian.core.modes import normal_modes

        numbers, _, frequency = normal_modes(scene)
        out.append(("mode", numbers.astype(np.int32), ("mode",), {"long_name": "harmonic normal mode number k"}))
        out.append(("mode_frequency", frequency, ("mode",), {"units": "1/time", "long_name": "ω_k"}))
    if scene.has_response:
        harmonics = np.arange(scene.record.harmonics + 1, dtype=np.int32)
        out.append(("harmonic", harmonics, ("harmonic",), {"long_name": "harmonic k of the drive frequency"}))
    tt = trace_times(scene)
    if tt is not None:
        out.append(("trace_t", tt, ("sample",), {"units": TIME_UNITS}))
        out.append(("traced_grain", np.asarray(scene.record.traces, dtype=np.int32), ("traced",), {}))
    group_attrs = {"long_name": "launch group of the point (index into the launch_groups attribute)"}
    companions = " ".join(a.name for d in sweep.dimensions for a in d.axes[1:])
    if companions:
        group_attrs["coordinates"] = companions
    out.append(("launch_group", plan.point_group.astype(np.int32), sweep.dims, group_attrs))
    return out


def _create_batches_group(root, count: int) -> None:
    """The ``batches`` group: ``done``, ``record`` and ``where``, one chunk per batch."""
    batches = root.create_group(BATCHES, attributes={"long_name": "completion records, one row per batch"})
    columns = {"record": (RECORD_COLUMNS, np.float64, np.nan), "where": (WHERE_COLUMNS, str, "")}
    batches.create_array(
        "done",
        shape=(count,),
        dtype=np.int8,
        chunks=(1,),
        fill_value=0,
        dimension_names=["batch"],
        attributes={"long_name": "1 once the batch is written"},
        compressors=chunk_codecs(),
    )
    for name, (names, dtype, fill) in columns.items():
        batches.create_array(
            name,
            shape=(count, len(names)),
            dtype=dtype,
            chunks=(1, len(names)),
            fill_value=fill,
            dimension_names=["batch", "column"],
            attributes={"columns": list(names)},
            compressors=chunk_codecs(),
        )


def _store_attributes(sweep: Sweep, plan: Plan, device: str) -> dict[str, Any]:
    return {
        "project": PROJECT,
        "schema_version": SCHEMA_VERSION,
        "scene": json.dumps(sweep.base.to_dict()),
        "scenes_differ_along": list(sweep.dims),
        "sweep": json.dumps({**sweep.to_dict(), "source": sweep.source}),
        "sweep_fingerprint": sweep.fingerprint(),
        "sweep_axes": {a.name: {"dim": d.name, "key": a.key} for d in sweep.dimensions for a in d.axes},
        "sweep_block": list(plan.block),
        "launch_groups": launch_groups_attr(plan),
        "status_codes": status_codes(),
        "provenance": _provenance(plan, device),
    }


def create_sweep_store(
    path: str | Path,
    sweep: Sweep,
    scene: "Scene | list[Scene]",
    plan: Plan,
    *,
    device: str,
    overwrite: bool = False,
    attributes: dict[str, Any] | None = None,
) -> Path:
    """Create the whole store (metadata, coordinates, attributes) with no batch written; atomic.

    ``scene``: any point's scene (they share the layout), e.g. ``SweepPoints.templates[0]``;
    ``attributes`` are added to the root group's. A failed write raises :class:`StorageError` (one line).
    """
    path = resolved_link(path)
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists")
    if path.exists():
        check_replaceable(path)
    if not isinstance(scene, Scene):
        scene = scene[0]
    with storage_faults("creating the store", path):
        tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", dir=path.parent if path.parent.exists() else None))
    try:
        with storage_faults("creating the store", path):
            target = tmp / "store.zarr"
            root = zarr.open_group(store=str(target), mode="w", zarr_format=3)
            for name, data, dims, attrs in fixed_arrays(sweep, scene, plan):
                lg = name == "launch_group"
                _small(root, name, data, dims, attrs, chunks=plan.block if lg else None, fill=-1 if lg else None)
            for var in variables(sweep, scene, plan):
                _create(
                    root,
                    var["name"],
                    sweep.shape + var["trailing"],
                    var["dtype"],
                    var["dims"],
                    plan.block,
                    var["trailing"],
                    var["fill"],
                    var["attrs"],
                    var.get("rows_per_shard"),
                )
            _create_batches_group(root, len(plan.batches))
            root.attrs.update({**_store_attributes(sweep, plan, device), **(attributes or {})})
            consolidate(target)
            write_manifest(target)
            if path.exists():
                shutil.rmtree(path)
            target.rename(path)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return path


# ---- resume -----------------------------------------------------------------------------


def _identity(path: Path) -> dict[str, Any]:
    """What names a store's sweep and versions: its manifest's copy where the manifest is intact (the root metadata
    may be the damaged file), else its root attributes. Raises SweepStoreError (one line) if neither reads."""
    try:
        identity = read_manifest(path).identity
        if identity.get("sweep_block") is not None:
            return {**identity, "provenance": identity}
    except ManifestError:
        pass
    try:
        root = zarr.open_group(store=str(path), mode="r")
        return dict(root.attrs)
    except Exception as err:  # noqa: BLE001 - any unreadable store is refused the same way
        raise SweepStoreError(f"{path}: not a readable Zarr store ({type(err).__name__})") from None


def check_resumable(path: str | Path, sweep: Sweep) -> tuple[int, ...]:
    """Raise SweepStoreError unless ``path`` was made from this sweep by this package; return its block."""
    path = Path(path)
    attrs = _identity(path)
    if not attrs.get("sweep_fingerprint"):
        raise SweepStoreError(f"{path}: not a hertzian sweep store (no sweep_fingerprint attribute)")
    if attrs.get("schema_version") != SCHEMA_VERSION:
        raise SweepStoreError(
            f"{path}: schema version {attrs.get('schema_version')} differs from this package's {SCHEMA_VERSION}"
        )
    if attrs["sweep_fingerprint"] != sweep.fingerprint():
        raise SweepStoreError(
            f"{path} was made from a different sweep (scene or axes differ); resume with the "
            "sweep file it was made from (and the same --set overrides, which are part of the sweep), "
            "or write a new store"
        )
    prov = attrs.get("provenance", {})
    for key, current in (("package_version", package_version()), ("warp_version", warp_version())):
        if prov.get(key) != current:
            raise SweepStoreError(
                f"{path} was written by {key.replace('_', ' ')} {prov.get(key)}, this is "
                f"{current}; a resumed store must come from one version (start a new store)"
            )
    return tuple(attrs["sweep_block"])


def completed_batches(path: str | Path) -> set[int]:
    """Indices of batches whose completion flag is set (a flag whose chunk is damaged counts as not set)."""
    try:
        root = zarr.open_group(store=str(path), mode="r")
    except (FileNotFoundError, KeyError, zarr.errors.NodeNotFoundError):
        return set()
    return finished_batches(root)


def repair_for_resume(path: str | Path, sweep: Sweep, scene: Scene, plan: Plan, *, device: str) -> Verification:
    """Read every chunk of the store (checksums verified) and check its files against the manifest. Damaged
    metadata, coordinates or manifest: every metadata file and coordinate is rebuilt from the sweep
    (:func:`rebuild_skeleton`), never re-consolidated from what is there. A damaged chunk (or completion row):
    its batch's flag is cleared and its chunks removed, so that it reruns and rewrites them with the same bits.
    Returns the verification (its damage as found); raises SweepStoreError (one line) if damage remains."""
    path = Path(path)
    verification = verify_store(path)
    with storage_faults("repairing the store", path):
        if any(not d.batches for d in verification.damage):
            rebuild_skeleton(path, sweep, scene, plan, device=device)
        if verification.damaged_batches:
            done = _open_for_writing(path, f"{BATCHES}/done")
            for index in sorted(verification.damaged_batches):
                _remove_chunks_of(path, index, plan)
                done[index] = 0
            write_manifest(path, finished=completed_batches(path))  # the files it covers are intact (or rebuilt)
    left = verify_store(path, read=False).damage
    if left:
        raise SweepStoreError(f"{path}: {left[0].variable} is damaged ({left[0].reason}) and could not be repaired")
    return verification


def rebuild_skeleton(path: Path, sweep: Sweep, scene: Scene, plan: Plan, *, device: str) -> None:
    """Rewrite every metadata file, coordinate and the manifest of the store at ``path`` as a fresh creation from
    the sweep writes them (the chunks of batches stay), and remove metadata files the sweep does not make."""
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", dir=path.parent))
    try:
        fresh = create_sweep_store(tmp / "store.zarr", sweep, scene, plan, device=device)
        wanted = covered_files(fresh, fixed_array_names(sweep_attrs(fresh))) + [MANIFEST]
        for rel in covered_files(path, fixed_array_names(sweep_attrs(fresh))):
            if rel not in wanted:
                (path / rel).unlink(missing_ok=True)
        for rel in wanted:  # the manifest last
            target = path / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            partial = target.with_name(target.name + ".partial")
            shutil.copyfile(fresh / rel, partial)
            partial.replace(target)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _remove_chunks_of(path: Path, index: int, plan: Plan) -> None:
    """Delete the chunk files (shards) batch ``index`` writes, and its completion rows, so that its rerun writes
    them afresh instead of reading damaged ones back (the store's chunk keys are ``c/i/j/…``, one shard per batch
    along the sweep dims; a run's one batch owns every chunk of its data arrays)."""
    for name in ("record", "where"):
        shutil.rmtree(path / BATCHES / name / "c" / str(index), ignore_errors=True)
    root = zarr.open_group(store=str(path), mode="r")
    dims = tuple(root.attrs.get("scenes_differ_along", []))
    fixed = set(fixed_array_names(dict(root.attrs)))
    for name, arr in root.arrays():
        if name in fixed or tuple(arr.metadata.dimension_names or ())[: len(dims)] != dims:
            continue
        if not dims:
            shutil.rmtree(path / arr.path / "c", ignore_errors=True)
            continue
        outer = arr.shards or arr.chunks
        corner = tuple(start // step for (start, _), step in zip(plan.batches[index].region, outer))
        key = arr.metadata.encode_chunk_key(corner + (0,) * (arr.ndim - len(dims)))
        base = path / arr.path / Path(*key.split("/")[: 1 + len(dims)])
        if base.is_dir():
            shutil.rmtree(base)
        else:
            base.unlink(missing_ok=True)


@contextlib.contextmanager
def writing_session(path: str | Path, sweep: Sweep, scene: Scene, plan: Plan, *, resuming: bool, device: str = "cpu"):
    """Guard a sweep's writes into the store at ``path``; yields notes (lines) for the user.

    Holds the store's lock (a second writer gets :class:`StoreLockedError`); refuses a store whose estimate
    (what is left of it, on resume) exceeds the free space (:class:`NoRoomError`); on resume, removes what a
    killed write left, verifies the store and repairs it (:func:`repair_for_resume`; ``device``: the store's
    creation label, should its metadata be rebuilt). A :class:`StorageError`
    raised inside gets the plan's store estimate (its ``need``), after the temporary files of the failed write
    are removed: the store then holds exactly the batches completed before it."""
    path = Path(path)
    need = store_estimate(sweep, scene, plan)
    with store_lock(path):
        notes = []
        if resuming:
            remove_partial_files(path)
            verification = repair_for_resume(path, sweep, scene, plan, device=device)
            if verification.unchecked:
                notes.append(f"note: {path} has no chunk checksums or manifest (written by an older version)")
            if verification.damage:
                batches = sorted(verification.damaged_batches)
                rebuilt = any(not d.batches for d in verification.damage)
                notes.append(
                    f"note: {len(verification.damage)} damaged chunk(s) or file(s) found"
                    + ("; metadata and coordinates rebuilt from the sweep" if rebuilt else "")
                    + (f"; rerunning batches {batches}" if batches else "")
                )
        done = completed_batches(path) if resuming else set()
        check_free_space(path, need * (len(plan.batches) - len(done)) // max(1, len(plan.batches)))
        try:
            yield notes
        except StorageError as err:
            err.need = need
            with contextlib.suppress(OSError):
                remove_partial_files(path)
            raise


def remove_partial_files(path: str | Path) -> int:
    """Delete temporary files a killed write left behind: zarr's ``*.partial`` files (written, then renamed), and
    the ``.NAME.*`` folders beside the store in which a store is created before it is renamed into place."""
    path = Path(path)
    count = 0
    for p in path.rglob("*.partial"):
        p.unlink(missing_ok=True)
        count += 1
    for folder in path.parent.glob(f".{path.name}.*"):
        if folder.is_dir() and {p.name for p in folder.iterdir()} <= {"store.zarr"}:
            shutil.rmtree(folder, ignore_errors=True)
            count += 1
    return count


# ---- filling -----------------------------------------------------------------------------


def _open_for_writing(path: Path, name: str):
    # write_empty_chunks: skip comparing every inner chunk with the fill value before writing it (a batch's
    # chunks are written whatever they hold, and the comparison is a large part of a shard's write time)
    return zarr.open_array(store=str(path), path=name, mode="r+").with_config({"write_empty_chunks": True})


class RowWriter:
    """Writes a running batch's records (and its trace samples up to them) into the store as the recorder
    unpacks them, in whole shards along the record (sample) dim, so that at the batch's end only its last
    records are left to write (:func:`write_batch` with ``rows=`` writes the rest).

    ``submit`` is the recorder's ``on_unpacked`` hook (main thread); the writes run in ``executor`` (one
    thread: they stay in order, before the batch's final write submitted to the same executor). A variable
    whose shards hold all its rows (a store made before records had shards of their own) is left to the
    final write."""

    def __init__(self, path: str | Path, batch: Batch, executor):
        self.path, self.batch, self.executor = Path(path), batch, executor
        self.written: dict[str, int] = {}
        """Rows (records, trace samples) of each variable written so far (writer thread)."""
        self.seconds = 0.0
        """Seconds spent in these writes (writer thread)."""
        self._arrays: dict[str, tuple[Any, int | None]] = {}
        self._opened: dict[str, Any] = {}
        self._futures: list = []

    def submit(self, recorder, r: int) -> None:
        """Queue the rows that record ``r``'s unpacking completed (records 0…r; trace samples to its step)."""
        available = {name: (data, r + 1) for name, data in recorder.fields.items()}
        if recorder.traced:
            samples = int(recorder.record_steps[r]) // recorder.stride + 1
            available.update({f"trace_{name}": (data, samples) for name, data in recorder.traces.items()})
        if not self._futures and r == 0:
            # the store's other per-point arrays opened while the batch runs, not after it (write_batch)
            self._futures.append(self.executor.submit(self._open_all))
        self._futures.append(self.executor.submit(self._write, available))

    def array(self, name: str):
        """The store's array ``name`` opened for writing, once per batch (writer thread)."""
        if name not in self._opened:
            self._opened[name] = _open_for_writing(self.path, name)
        return self._opened[name]

    def _open_all(self) -> None:
        check_store_present(self.path, f"writing batch {self.batch.index}")
        for name in zarr.open_group(store=str(self.path), mode="r").array_keys():
            self.array(name)

    def _rows_per_shard(self, name: str):
        if name not in self._arrays:
            arr = self.array(name)
            dim = len(self.batch.shape)
            outer = arr.shards or arr.chunks
            rows = outer[dim] if outer[dim] < arr.shape[dim] else None
            self._arrays[name] = (arr, rows)
        return self._arrays[name]

    def _write(self, available: dict[str, tuple[np.ndarray, int]]) -> None:
        with storage_faults(f"writing batch {self.batch.index}'s records", self.path):
            self._write_rows(available)

    def _write_rows(self, available: dict[str, tuple[np.ndarray, int]]) -> None:
        start = time.perf_counter()
        for name, (data, count) in available.items():
            arr, rows = self._rows_per_shard(name)
            done = self.written.get(name, 0)
            upto = count // rows * rows if rows else 0
            if upto > done:
                piece = np.asarray(data[:, done:upto], dtype=arr.dtype)
                arr[self.batch.slices + (slice(done, upto),)] = piece.reshape(self.batch.shape + piece.shape[1:])
                self.written[name] = upto
        self.seconds += time.perf_counter() - start

    def settle(self) -> None:
        """Wait for the queued writes; raise the first one's error."""
        for future in self._futures:
            future.result()
        self._futures = []


def write_batch(
    path: str | Path,
    batch: Batch,
    result: RunResult,
    *,
    grain_steps: int,
    worker: str = "",
    build_seconds: float = 0.0,
    rows: RowWriter | None = None,
) -> dict[str, Any]:
    """Write one batch's results into its block, then its completion record; return the record.

    ``build_seconds``: host time spent building the batch's model and initial state (recorded). ``rows``: the
    batch's :class:`RowWriter`, whose rows are already written (only the rest is). A failed write (full disk,
    no permission, read-only or vanished store) raises :class:`StorageError` (one line); the batch's completion
    flag is then not set, so ``--resume`` reruns it.
    """
    action = f"writing batch {batch.index}"
    with storage_faults(action, path):
        check_store_present(path, action)
        return _write_batch(
            path, batch, result, grain_steps=grain_steps, worker=worker, build_seconds=build_seconds, rows=rows
        )


def _write_batch(
    path: str | Path,
    batch: Batch,
    result: RunResult,
    *,
    grain_steps: int,
    worker: str,
    build_seconds: float,
    rows: RowWriter | None,
) -> dict[str, Any]:
    write_start = time.perf_counter()
    path = Path(path)
    region = batch.slices
    shape = batch.shape
    if rows is not None:
        rows.settle()
    written = rows.written if rows is not None else {}

    def put(name: str, data: np.ndarray) -> None:
        arr = rows.array(name) if rows is not None else _open_for_writing(path, name)
        done = written.get(name, 0)
        if done:
            if done >= data.shape[1]:
                return
            region_left = region + (slice(done, None),)
            data = data[:, done:]
        else:
            region_left = region
        arr[region_left] = np.asarray(data, dtype=arr.dtype).reshape(shape + data.shape[1:])

    for name, data in batch_arrays(result, grain_steps).items():
        put(name, data)
    finished = datetime.now(timezone.utc)
    record = batch_record(result, grain_steps, finished, build_seconds)
    record["write_seconds"] = time.perf_counter() - write_start + (rows.seconds if rows is not None else 0.0)
    where = batch_where(result, worker)
    batches = zarr.open_group(store=str(path), path=BATCHES, mode="r+")
    batches["record"][batch.index] = np.array([record[c] for c in RECORD_COLUMNS], dtype=np.float64)
    batches["where"][batch.index] = np.array([where[c] for c in WHERE_COLUMNS], dtype=object)
    # the completion flag comes last: a batch without it is rerun on --resume
    batches["done"][batch.index] = 1
    codes, counts = np.unique(result.status, return_counts=True)
    return {
        "batch": batch.index,
        **record,
        "grain_steps": int(grain_steps),
        **where,
        "status_counts": {str(int(c)): int(k) for c, k in zip(codes, counts)},
        "finished": finished.isoformat(timespec="seconds"),
    }


def batch_arrays(result: RunResult, grain_steps: int) -> dict[str, np.ndarray]:
    """Every store variable a batch writes, from its run's result: name → array with the chains first."""
    scene = result.scenes[0]
    chains = result.chain_count
    wall = float(result.wall_seconds)
    arrays = dict(result.fields)
    if scene.record.energy:
        arrays["energy"] = result.energy
        if result.work is not None:
            arrays["work"] = result.work
    if scene.record.energy and result.dissipated is not None:
        arrays["dissipated"] = result.dissipated
    arrays.update(result.response)
    arrays.update(result.spectrum)
    arrays.update({f"trace_{name}": data for name, data in result.traces.items()})
    arrays.update(
        {
            "status": result.status.astype(np.int32),
            "energy_error": result.energy_error,
            "max_overlap": result.max_overlap,
            **({"error_estimate": result.error_estimate} if result.error_estimate is not None else {}),
            "wall_seconds": np.full(chains, wall / chains),
            "grain_steps_per_second": np.full(chains, grain_steps / max(wall, 1e-12)),
        }
    )
    if records_grains(scene):
        arrays.update(grain_arrays(result.scenes))
    return arrays


def batch_record(result: RunResult, grain_steps: int, finished: datetime, build_seconds: float) -> dict[str, Any]:
    """A batch's completion record (``batches/record``'s columns; ``write_seconds`` 0 until it is written)."""
    wall = float(result.wall_seconds)
    return {
        "points": result.chain_count,
        "wall_seconds": wall,
        "grain_steps": int(grain_steps),
        "grain_steps_per_second": grain_steps / max(wall, 1e-12),
        "energy_error_max": float(np.max(result.energy_error)) if result.chain_count else 0.0,
        "finished": finished.timestamp(),
        "build_seconds": float(build_seconds),
        "write_seconds": 0.0,
    }


def batch_where(result: RunResult, worker: str) -> dict[str, str]:
    """Where a batch ran (``batches/where``'s columns)."""
    return {"device": result.device, "host": platform.node(), "worker": worker, "kernel": str(result.kernel)}


def batch_records(path: str | Path, *, status_counts: bool = False) -> list[dict[str, Any]]:
    """Every finished batch's completion record, by batch index (``status_counts`` reads the batch's
    status block too)."""
    done = sorted(completed_batches(path))
    if not done:
        return []
    batches = zarr.open_group(store=str(path), path=BATCHES, mode="r")
    record = np.asarray(batches["record"][...])
    where = np.asarray(batches["where"][...])
    status = None
    if status_counts:
        status = np.asarray(zarr.open_array(store=str(path), path="status", mode="r")[...])
        block = tuple(zarr.open_group(store=str(path), mode="r").attrs["sweep_block"])
    out = []
    for index in done:
        rec = {
            "batch": index,
            **dict(zip(RECORD_COLUMNS, record[index].tolist())),
            **dict(zip(WHERE_COLUMNS, [str(x) for x in where[index]])),
        }
        rec["points"], rec["grain_steps"] = int(rec["points"]), int(rec["grain_steps"])
        rec["finished"] = datetime.fromtimestamp(rec["finished"], timezone.utc).isoformat(timespec="seconds")
        if status is not None:
            counts_shape = [math.ceil(n / b) for n, b in zip(status.shape, block)]
            corner = np.unravel_index(index, counts_shape) if counts_shape else ()
            region = tuple(slice(c * b, (c + 1) * b) for c, b in zip(corner, block))
            codes, counts = np.unique(status[region], return_counts=True)
            rec["status_counts"] = {str(int(c)): int(k) for c, k in zip(codes, counts)}
        out.append(rec)
    return out


def finalize(path: str | Path, *, session_seconds: float | None = None, session_grain_steps: int = 0) -> dict:
    """Sum the completion records into ``provenance``; re-consolidate. Returns the provenance."""
    path = Path(path)
    with storage_faults("finishing the store", path):
        check_store_present(path, "finishing the store")
        return _finalize(path, session_seconds, session_grain_steps)


def _finalize(path: Path, session_seconds: float | None, session_grain_steps: int) -> dict:
    records = batch_records(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        root = zarr.open_group(store=str(path), mode="r+")
        prov = finished_provenance(dict(root.attrs["provenance"]), records, session_seconds, session_grain_steps)
        root.attrs["provenance"] = prov
    consolidate(path)
    write_manifest(path, finished=[r["batch"] for r in records])
    return prov


def finished_provenance(prov: dict, records: list[dict], session_seconds=None, session_grain_steps: int = 0) -> dict:
    """``prov`` (a store's provenance) with the sums of its batches' completion ``records`` (:func:`batch_records`'
    form) and, when given, this session's wall seconds and throughput."""
    wall = sum(r["wall_seconds"] for r in records)
    steps = sum(r["grain_steps"] for r in records)
    devices = sorted({r["device"] for r in records})
    kernels = sorted({r["kernel"] for r in records if r["kernel"]})
    prov = {
        **prov,
        "kernel": ",".join(kernels),
        "build_seconds": sum(r["build_seconds"] for r in records),
        "write_seconds": sum(r["write_seconds"] for r in records),
        "device": ",".join(devices) if devices else prov["device"],
        "hosts": sorted({r["host"] for r in records}),
        "wall_seconds": wall,
        "grain_steps_per_second": steps / wall if wall > 0 else 0.0,
        "energy_error_max": max((r["energy_error_max"] for r in records), default=0.0),
        "batches_done": len(records),
        "complete": len(records) == prov["batches"],
        "finished": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }
    if session_seconds is not None:
        prov["session_wall_seconds"] = session_seconds
        prov["session_grain_steps_per_second"] = session_grain_steps / max(session_seconds, 1e-12)
    return prov


def store_bytes(path: str | Path) -> int:
    """Bytes on disk under ``path``."""
    return sum(p.stat().st_size for p in Path(path).rglob("*") if p.is_file())


def sweep_attrs(path: str | Path) -> dict[str, Any]:
    root = zarr.open_group(store=str(path), mode="r")
    return dict(root.attrs)


def differing_arrays(a: str | Path, b: str | Path, *, skip: tuple[str, ...] = TIMING_VARIABLES) -> list[str]:
    """Names of arrays whose values (bytes, NaN included) or shape differ between two stores; the
    machine-timing variables are skipped. An empty list means the stores hold the same results."""
    ga, gb = zarr.open_group(store=str(a), mode="r"), zarr.open_group(store=str(b), mode="r")
    names = sorted(set(ga.array_keys()) | set(gb.array_keys()))
    out = []
    for name in names:
        if name in skip:
            continue
        if name not in ga or name not in gb:
            out.append(name)
            continue
        x, y = np.asarray(ga[name][...]), np.asarray(gb[name][...])
        if (
            x.shape != y.shape
            or x.dtype != y.dtype
            or (x.tobytes() != y.tobytes() if x.dtype.kind not in "OTU" else not np.array_equal(x, y))
        ):
            out.append(name)
    return out


# ---- a run as a store ---------------------------------------------------------------------


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
    attributes: dict[str, Any] | None = None,
) -> Path:
    """Write a run (or an ensemble shaped by ``axes``: name → coordinate values, C order) as a Zarr v3
    store, through the sweep store's writer: a run is a sweep with no axes, one batch.

    Scenes that differ between points are kept: the ``scene`` attribute holds the first point's,
    ``scene_overrides`` (JSON) every differing dotted key's value at every point, and an axis whose
    values are exactly one differing key's gets that key as its ``scene_key``. ``sweep`` (plain
    data) is stored as the ``sweep`` attribute when given, ``attributes`` are added to the root group's.

    Holds the store's lock while it writes; ``overwrite`` replaces only a hertzian store
    (``storage.check_replaceable``).
    """
    path = resolved_link(path)
    axes = {name: np.asarray(values) for name, values in (axes or {}).items()}
    shape = tuple(len(v) for v in axes.values())
    if int(np.prod(shape)) != result.chain_count:
        raise ValueError(f"axes {shape} do not match {result.chain_count} chains")
    clash = sorted(set(axes) & RESERVED_NAMES)
    if clash:
        raise ValueError(f"axis names {clash} are store variable names; choose others")
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists (pass --overwrite to replace it)")
    with store_lock(path):
        if path.exists():
            check_replaceable(path)
        return _write_result(path, result, axes, shape, sweep, attributes)


def _write_result(path: Path, result, axes: dict, shape: tuple, sweep: dict | None, extra: dict | None) -> Path:
    """:func:`write_result` once the store's lock is held and a store it replaces is known to be one."""
    definition, scene, plan, attributes = _result_layout(result, axes, shape, sweep, extra)
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


def _result_layout(result, axes: dict, shape: tuple, sweep: dict | None, extra: dict | None):
    """(the sweep a run's store describes, its first scene, its one-batch plan, the root's extra attributes)."""
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
    attributes = {"scene_overrides": json.dumps(differences), **(extra or {})}
    if sweep is not None:
        attributes["sweep"] = json.dumps(sweep)
    return definition, scene, plan, attributes


def result_dataset(result: RunResult, axes: dict[str, np.ndarray] | None = None):
    """``result`` as the ``xarray.Dataset`` (in memory) that ``hertzian run --out`` stores, built from the same
    layout as the store (:func:`variables`, :func:`fixed_arrays`, the root's attributes) without writing one: the
    same variables, coordinates, dimensions, dtypes and attributes (the provenance's times are this call's).
    ``axes`` as :func:`write_result`'s; an ensemble without them gets one axis ``chain`` (0, 1, …)."""
    import xarray as xr  # only where a dataset is asked for

    if axes is None and result.chain_count > 1:
        axes = {"chain": np.arange(result.chain_count)}
    axes = {name: np.asarray(values) for name, values in (axes or {}).items()}
    shape = tuple(len(v) for v in axes.values())
    if int(np.prod(shape)) != result.chain_count:
        raise ValueError(f"axes {shape} do not match {result.chain_count} chains")
    definition, scene, plan, attributes = _result_layout(result, axes, shape, None, None)
    grain_steps = result.grain_count * result.steps * result.chain_count
    arrays = batch_arrays(result, grain_steps)
    data_vars, named = {}, set()
    for var in variables(definition, scene, plan):
        attrs = dict(var["attrs"])
        named |= set(attrs.pop("coordinates", "").split())  # xarray reads the store's CF attribute as coordinates
        data = np.asarray(arrays[var["name"]], dtype=var["dtype"]).reshape(shape + var["trailing"])
        data_vars[var["name"]] = (var["dims"], data, attrs)
    coords = {
        name: (dims, np.asarray(data), dict(attrs)) for name, data, dims, attrs in fixed_arrays(definition, scene, plan)
    }
    dataset = xr.Dataset(data_vars, coords)
    dataset = dataset.set_coords([name for name in named if name in dataset.data_vars])
    record = {**batch_record(result, grain_steps, datetime.now(timezone.utc), 0.0), **batch_where(result, "")}
    root = {**_store_attributes(definition, plan, result.device), **attributes}
    root["provenance"] = finished_provenance(root["provenance"], [record])
    dataset.attrs.update(root)
    return dataset
