"""Find damaged chunks of a store: read every chunk, so that zarr checks its CRC-32C, and name what each damaged one
holds (variable, sweep points by their coordinates, batch). ``hertzian verify`` prints them; ``sweep --resume``
reruns the batches they belong to.

A chunk is damaged when its bytes no longer match their checksum (or, in a store without checksums, no longer
decode), or when a finished batch's chunk file is missing (it would read back as fill values).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import zarr
from hertzian.sweeping.manifest import ManifestError, file_damage, fixed_array_names, is_project_store, read_manifest
from hertzian.sweeping.storage import MANIFEST
from hertzian.sweeping.store_format import DAMAGE_ERRORS, has_checksums

BATCHES = "batches"
"""Group holding the completion records (``done``, ``record``, ``where``), one row per batch."""


@dataclass(frozen=True)
class Damage:
    """One damaged chunk."""

    variable: str
    """Array path in the store, e.g. ``u`` or ``batches/record``."""
    region: tuple[tuple[int, int], ...]
    """(start, stop) of the chunk along each sweep dimension of the store; () for an array without them."""
    batches: tuple[int, ...]
    """Batches whose points the chunk holds (rerunning them rewrites it); () when no batch writes it."""
    reason: str
    """What is wrong: the reader's error, or ``missing``."""


@dataclass
class Verification:
    """Result of :func:`verify_store`."""

    damage: list[Damage] = field(default_factory=list)
    chunks: int = 0
    """Chunks read (inner chunks of the damaged shards counted once each)."""
    unchecked: list[str] = field(default_factory=list)
    """Arrays whose chunks carry no checksum (stores written before checksums): damage may read silently."""

    @property
    def damaged_batches(self) -> set[int]:
        return {b for d in self.damage for b in d.batches}


@dataclass(frozen=True)
class _Layout:
    """The store's sweep geometry: what maps a chunk to points and batches."""

    dims: tuple[str, ...]
    shape: tuple[int, ...]
    block: tuple[int, ...]
    done: frozenset[int]
    coordinates: dict = field(default_factory=dict)
    """Sweep dimension → [(axis name, values)]."""
    fixed: frozenset[str] = frozenset()
    """Arrays written at creation (coordinates, ``launch_group``): no batch owns their chunks."""

    def batches_of(self, region: tuple[tuple[int, int], ...]) -> tuple[int, ...]:
        if not self.dims:
            return (0,)
        counts = [math.ceil(n / b) for n, b in zip(self.shape, self.block)]
        ranges = [range(a // b, (z - 1) // b + 1) for (a, z), b in zip(region, self.block)]
        return tuple(int(np.ravel_multi_index(c, counts)) for c in itertools.product(*ranges))

    def describe(self, region: tuple[tuple[int, int], ...]) -> str:
        """The points of ``region`` by their sweep coordinates, e.g. ``v_imp=0.001..0.01, l0=0``."""
        parts = []
        for dim, (start, stop) in zip(self.dims, region):
            for name, values in self.coordinates.get(dim, [(dim, None)])[:1]:
                ends = [values[start], values[stop - 1]] if values is not None else [f"[{start}]", f"[{stop - 1}]"]
                text = [f"{v:g}" if isinstance(v, float) else str(v) for v in ends]
                parts.append(f"{name}={text[0]}" + (f"..{text[1]}" if stop - start > 1 else ""))
        return ", ".join(parts) or "the run"


def _layout(root, done: set[int]) -> _Layout:
    attrs = dict(root.attrs)
    dims = tuple(attrs.get("scenes_differ_along", []))
    status = root["status"]
    block = tuple(attrs.get("sweep_block", status.shape))
    coordinates: dict = {}
    for name, spec in dict(attrs.get("sweep_axes", {})).items():
        try:
            values = np.asarray(root[name][...]).tolist()
        except DAMAGE_ERRORS:
            values = None
        coordinates.setdefault(spec["dim"], []).append((name, values))
    fixed = frozenset(fixed_array_names(attrs))
    return _Layout(dims, tuple(status.shape), block, frozenset(done), coordinates, fixed)


def finished_batches(root, verification: Verification | None = None) -> set[int]:
    """Batches whose flag in ``batches/done`` is set; a flag whose chunk is damaged counts as not set (and is
    added to ``verification``)."""
    if BATCHES not in root or "done" not in root[BATCHES]:
        return set()
    done = root[BATCHES]["done"]
    try:
        flags = np.asarray(done[...])
        if verification is not None:
            verification.chunks += done.shape[0]
        return {int(i) for i in np.flatnonzero(flags == 1)}
    except DAMAGE_ERRORS:
        pass
    out = set()
    for index in range(done.shape[0]):
        try:
            if int(done[index]) == 1:
                out.add(index)
        except DAMAGE_ERRORS as err:
            if verification is not None:
                verification.damage.append(Damage(f"{BATCHES}/done", (), (index,), _reason(err)))
    return out


def _reason(err: BaseException) -> str:
    text = str(err).split(". Stored")[0]
    return f"{type(err).__name__}: {text}"[:120]


def _blocks(shape: tuple[int, ...], step: tuple[int, ...]):
    """(start, stop) regions of a chunk grid over ``shape``."""
    counts = [math.ceil(n / s) for n, s in zip(shape, step)]
    for corner in itertools.product(*[range(c) for c in counts]):
        yield tuple((c * s, min((c + 1) * s, n)) for c, s, n in zip(corner, step, shape))


def _read(arr, region) -> str | None:
    """None if the region reads, else why not."""
    try:
        arr[tuple(slice(a, z) for a, z in region)]
    except DAMAGE_ERRORS as err:
        return _reason(err)
    return None


def _check_array(path: Path, arr, name: str, layout: _Layout, verification: Verification, *, read: bool) -> None:
    """Check ``arr`` shard by shard (chunk by chunk where it has no shards): a finished batch's chunk file must exist,
    and with ``read`` each must read (checksums verified); in a shard that fails, every inner chunk, so that the
    damage is named as closely as the layout allows."""
    dims = tuple(arr.metadata.dimension_names or ())
    sweep_dims = len(layout.dims) if dims[: len(layout.dims)] == layout.dims and layout.dims else 0
    batch_rows = name.startswith(f"{BATCHES}/") and name != f"{BATCHES}/done"
    by_batch = batch_rows or name not in layout.fixed  # a run's data arrays belong to its one batch
    outer = arr.shards or arr.chunks
    for region in _blocks(arr.shape, outer):
        verification.chunks += 1
        sweep_region = region[:sweep_dims]
        batches = (region[0][0],) if batch_rows else layout.batches_of(sweep_region) if by_batch else ()
        key = arr.metadata.encode_chunk_key(tuple(a // s for (a, _), s in zip(region, outer)))
        if by_batch and set(batches) <= layout.done and not (path / arr.path / key).exists():
            verification.damage.append(Damage(name, sweep_region, batches, "missing: a finished batch's chunk file"))
            continue
        if not read or _read(arr, region) is None:
            continue
        inner_blocks = list(_blocks(tuple(z - a for a, z in region), arr.chunks)) if arr.shards else [None]
        for inner in inner_blocks:
            part = region if inner is None else tuple((a + i, a + j) for (a, _), (i, j) in zip(region, inner))
            reason = _read(arr, part)
            if reason is not None:
                part_batches = layout.batches_of(part[:sweep_dims]) if by_batch and not batch_rows else batches
                verification.damage.append(Damage(name, part[:sweep_dims], part_batches, reason))


def _check_files(path: Path, verification: Verification) -> frozenset[int]:
    """The manifest's check of the metadata and fixed arrays' files (a damaged one is added to ``verification``);
    returns the batches the manifest names finished. A store from before manifests gets a note in ``unchecked``."""
    try:
        manifest = read_manifest(path)
    except ManifestError as err:
        if is_project_store(path):
            verification.damage.append(Damage(MANIFEST, (), (), str(err)))
        else:
            verification.unchecked.append(MANIFEST)
        return frozenset()
    for rel, reason in file_damage(path, manifest):
        verification.damage.append(Damage(rel, (), (), reason))
    return manifest.finished


def verify_store(path: str | Path, *, read: bool = True) -> Verification:
    """Check the store at ``path``: its metadata and coordinates against the manifest, every chunk file a finished
    batch owns, and (``read``) every chunk's checksum; list what is damaged. ``read=False`` checks files only, as
    the readers do before they open a store."""
    path = Path(path)
    verification = Verification()
    finished = _check_files(path, verification)
    metadata_damage = {d.variable.removesuffix("zarr.json").rstrip("/") for d in verification.damage}
    if "" in metadata_damage:
        return verification  # the root metadata is damaged: zarr would read the store wrongly
    try:
        root = zarr.open_group(store=str(path), mode="r")
        flagged = finished_batches(root, verification)
    except Exception as err:  # noqa: BLE001 - any unreadable root is damage, named in one line
        verification.damage.append(Damage("zarr.json", (), (), f"unreadable ({type(err).__name__})"))
        return verification
    for index in sorted(finished - flagged):
        reason = "missing: the flag of a batch that was finished when the store was finalized"
        verification.damage.append(Damage(f"{BATCHES}/done", (), (index,), reason))
    layout = _layout(root, flagged | finished)
    arrays = [(name, arr) for name, arr in root.arrays()]
    if BATCHES in root:
        arrays += [(f"{BATCHES}/{name}", arr) for name, arr in root[BATCHES].arrays() if name != "done"]
    for name, arr in arrays:
        if any(f"{damaged}/".startswith(f"{name}/") for damaged in metadata_damage):
            continue  # a file of it is named already (its metadata or a coordinate's chunk): rebuilt from the sweep
        if not has_checksums(arr):
            verification.unchecked.append(name)
        _check_array(path, arr, name, layout, verification, read=read)
    return verification


def damage_lines(path: str | Path, verification: Verification) -> list[str]:
    """One line per damaged chunk or file: variable (or file), points (sweep coordinates), batches, reason."""
    try:
        layout = _layout(zarr.open_group(store=str(path), mode="r"), set())
    except Exception:  # noqa: BLE001 - a damaged root: points are named by index
        layout = _Layout((), (), (), frozenset())
    lines = []
    for d in verification.damage:
        batches = f"; batch {', '.join(map(str, d.batches[:8]))}" + ("…" if len(d.batches) > 8 else "")
        if not d.batches and not d.region:
            lines.append(f"{d.variable}: {d.reason}")
            continue
        where = layout.describe(d.region) if d.region or not d.variable.startswith(BATCHES) else "its row"
        lines.append(f"{d.variable}: {where}{batches if d.batches else ''}: {d.reason}")
    return lines
