"""Plan a sweep: launch groups, batch blocks sized by memory, and the work each batch is.

* A **launch group** is the set of points that share a ``hertzian.core.model.LaunchKey`` (grain
  count, boundaries, method, precision, dt, record layout): they can share one kernel launch.
  Each group gets one kernel variant (``features_of`` over *all* its points, computed from their
  static configurations without a scene per point), so a point's result
  does not depend on which batch it lands in: batch size and worker count change the speed,
  never the bits.
* A **batch** is one launch and one work unit: a hyper-rectangular *block* of the sweep grid,
  the same shape for every batch (edge blocks are cut short). The store chunks (shards) the
  sweep dimensions by this block, so a batch writes whole chunks only. Dimensions along which
  the launch group changes get block extent 1, so a block never mixes groups.
* Batch size: the most points whose device memory fits ``free memory × 0.8`` on CUDA (a
  fixed 2 GiB on the CPU), whose host copy of the results fits 4 GiB, that stay under
  ``MAX_GRAIN_THREADS`` grain-threads per launch, and whose work bounds what a kill loses
  (:func:`work_cap`: about a minute at a conservative rate, or 5 % of the sweep); or ``--batch-size N``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from hertzian.core.model import STATIC_LEVELS, LaunchKey, chain_set_features, features_of, launch_key, scene_path_key
from hertzian.core.scene import Scene, SceneError
from hertzian.core.static import static_arrays
from hertzian.kernels.features import GEAR_CORRECTOR, Features
from hertzian.sweeping.spec import CHUNK_ELEMENTS, Sweep, SweepPoints, expand, static_subgrid

CPU_MEMORY_BUDGET = 2 << 30
"""Bytes a CPU batch may use (state and results live in the same memory)."""
HOST_MEMORY_BUDGET = 4 << 30
"""Bytes of host result arrays a GPU batch may hold before it is written."""
DEVICE_MEMORY_FRACTION = 0.8
"""Share of a GPU's free memory a batch may take."""
MAX_GRAIN_THREADS = 1 << 22
"""Grain-threads per launch beyond which a GPU gains nothing (a large GPU holds a few 1e5 resident threads); capping
keeps batches small enough to resume and to spread over workers."""
LOST_WORK_SECONDS = 60.0
"""A batch holds at most this many seconds of work at ``SAFE_RATE`` (unless 5 % of the sweep is more): what a
kill loses, since a batch is written whole or not at all."""
LOST_WORK_FRACTION = 0.05
"""…or at most this share of the sweep's grain-steps, whichever is more (a short sweep stays one batch)."""
SAFE_RATE = {"cpu": 1.0e7, "cuda": 1.0e10}
"""Conservative grain-steps per second of one batch [grain-steps/s], below what the per-step CPU kernel and full GPU
batches reach (measured rates: docs/benchmarks.md)."""
GPU_FILL_GRAIN_THREADS = 1 << 18
"""A GPU batch keeps at least this many grain-threads (about what a large GPU holds resident): a smaller one does not
finish sooner, so cutting below it would lose speed and save no work."""


@dataclass(frozen=True)
class LaunchGroup:
    """Points that can share one launch, and the kernel variant they all use."""

    key: LaunchKey
    """What every point of the group shares."""
    features: Features
    """Kernel variant covering every point of the group."""
    point_count: int
    device_bytes_per_chain: int
    """Device memory one chain needs during a run [bytes]."""
    host_bytes_per_chain: int
    """Host memory of one chain's results [bytes]."""
    grain_steps_per_chain: int


@dataclass(frozen=True)
class Batch:
    """One launch: a block of the sweep grid."""

    index: int
    group: int
    """Index into Plan.groups."""
    region: tuple[tuple[int, int], ...]
    """(start, stop) along each sweep dimension."""
    grid_shape: tuple[int, ...] = ()
    """Points along each sweep dimension of the whole grid."""

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(stop - start for start, stop in self.region)

    @property
    def size(self) -> int:
        """Points in the batch."""
        return math.prod(self.shape)

    @property
    def slices(self) -> tuple[slice, ...]:
        return tuple(slice(start, stop) for start, stop in self.region)

    @property
    def points(self) -> np.ndarray:
        """Flat (C-order) indices of the points, in the order they are launched and written, int64."""
        if not self.region:
            return np.zeros(1, dtype=np.int64)
        grids = np.meshgrid(*[np.arange(a, z) for a, z in self.region], indexing="ij")
        return np.ravel_multi_index(tuple(g.ravel() for g in grids), self.grid_shape).astype(np.int64)


@dataclass(frozen=True)
class Plan:
    """How a sweep is cut into launches."""

    shape: tuple[int, ...]
    """Points along each sweep dimension."""
    block: tuple[int, ...]
    """Batch (and store chunk/shard) extent along each sweep dimension."""
    groups: tuple[LaunchGroup, ...]
    batches: tuple[Batch, ...]
    point_group: np.ndarray
    """Launch group of every point, shape ``shape``."""
    device: str
    memory_budget: int
    """Device bytes a batch may use [bytes]."""

    @property
    def point_count(self) -> int:
        return math.prod(self.shape)

    @property
    def batch_size(self) -> int:
        """Points per (full) batch."""
        return math.prod(self.block)

    @property
    def grain_steps(self) -> int:
        """Grain-steps of the whole sweep (points × grains × steps)."""
        return sum(g.grain_steps_per_chain * g.point_count for g in self.groups)

    def batch_grain_steps(self, batch: Batch) -> int:
        return batch.size * self.groups[batch.group].grain_steps_per_chain

    def batch_device_bytes(self, batch: Batch) -> int:
        return batch.size * self.groups[batch.group].device_bytes_per_chain

    def batch_host_bytes(self, batch: Batch) -> int:
        return batch.size * self.groups[batch.group].host_bytes_per_chain


def chain_memory(scene: Scene, features: Features) -> tuple[int, int]:
    """(device, host) bytes one chain of ``scene`` needs in a launch with ``features``."""
    item = 8 if features.precision == "float64" else 4
    n = scene.chain.grains
    traced = len(scene.record.traces)
    capacity = scene.steps_per_record // scene.trace_stride if traced else 0
    device = 2 * features.values * n * item  # two state buffers
    device += 2 * capacity * traced * item  # trace ring buffer
    if features.heterogeneous:
        device += (2 * n + 1) * item  # 1/m per grain, a_c per contact
    if features.static == "profile":
        device += (n + 1) * item
    device += 256  # per-chain scalars
    if features.damping != "none":
        device += n * 8  # dissipated energy per grain
    response = 0
    if scene.has_response:
        r = scene.record
        response = r.response_windows * ((2 * (r.harmonics + 1) + 1) * n + 1) * 8  # response sums
    device += response
    records = scene.record_count
    samples = (records - 1) * capacity + 1 if traced else 0
    host = len(scene.record.fields) * records * n * 8  # snapshots (stored as float64 at most)
    host += 2 * samples * traced * 8 + 2 * 2 * capacity * traced * item  # traces and a buffer copy
    host += 2 * records * 8 + 64  # energy, work, per-chain scalars
    host += 2 * response  # response windows and their reduction
    if scene.record.modes:  # mode energies, spectral entropy and participation per record (core/spectrum.py)
        spectrum = records * (n + 2) * 8
        device += spectrum
        host += spectrum
    return device, host


def device_budget(device: str) -> int:
    """Bytes a batch may use on ``device``: 80 % of a GPU's free memory, 2 GiB on the CPU."""
    import warp as wp

    d = wp.get_device(device)
    if d.is_cuda:
        return int(d.free_memory * DEVICE_MEMORY_FRACTION)
    return CPU_MEMORY_BUDGET


def _splitting_dims(point_group: np.ndarray) -> list[bool]:
    """Dimensions along which the launch group changes somewhere."""
    return [
        bool(point_group.shape[d] > 1 and np.any(np.diff(point_group, axis=d) != 0)) for d in range(point_group.ndim)
    ]


def block_for(shape: tuple[int, ...], splitting: list[bool], target: int) -> tuple[int, ...]:
    """Largest block of at most ``target`` points: whole trailing dimensions, one dimension cut
    into near-equal parts, extent 1 elsewhere and along splitting dimensions."""
    block = [1] * len(shape)
    room = max(1, target)
    for d in reversed(range(len(shape))):
        if splitting[d]:
            continue
        if shape[d] <= room:
            block[d] = shape[d]
            room //= shape[d]
            continue
        parts = math.ceil(shape[d] / room)
        block[d] = chunkable_extent(math.ceil(shape[d] / parts), shape[d], room)
        break
    return tuple(block)


def chunkable_extent(extent: int, length: int, room: int) -> int:
    """``extent`` rounded up to a multiple of a power of two (up to 64, at most an eighth of it) where that keeps
    the number of parts of ``length`` and stays within ``room``: the store's inner chunks of a few points divide the
    block (a prime extent, such as 10 000 points in 7 batches of 1429, leaves only one-point chunks: one chunk encode
    per point and record, which makes the store's writer thread slower than a GPU)."""
    parts = math.ceil(length / extent)
    for step in (64, 32, 16, 8, 4, 2):
        rounded = -(-extent // step) * step
        if 8 * step <= extent and rounded <= room and math.ceil(length / rounded) == parts:
            return rounded
    return extent


def batches_for(shape: tuple[int, ...], block: tuple[int, ...], point_group: np.ndarray) -> list[Batch]:
    """Every block of the grid in C order, as batches (a block never mixes launch groups: it has
    extent 1 along every dimension where the group changes)."""
    counts = [math.ceil(n / b) for n, b in zip(shape, block)]
    batches = []
    for index, corner in enumerate(np.ndindex(*counts)):
        region = tuple((c * b, min((c + 1) * b, n)) for c, b, n in zip(corner, block, shape))
        group = point_group[tuple(start for start, _ in region)] if shape else point_group.reshape(-1)[0]
        batches.append(Batch(index=index, group=int(group), region=region, grid_shape=tuple(shape)))
    return batches


def plan_sweep(
    sweep: Sweep,
    points: "SweepPoints | list[Scene] | None",
    device: str,
    *,
    batch_size: int | None = None,
    block: tuple[int, ...] | None = None,
) -> Plan:
    """Group the sweep's points into launches on ``device``, without a scene per point.

    ``points``: the sweep expanded by ``hertzian.sweeping.spec.expand`` (a list of scenes or None expands it
    here). ``batch_size`` caps points per batch; ``block`` (from an existing store) fixes the batch shape.
    """
    if not isinstance(points, SweepPoints):
        points = expand(sweep)
    shape = sweep.shape
    template_keys = [launch_key(t) for t in points.templates]
    keys: dict[LaunchKey, int] = {}
    template_group = np.array([keys.setdefault(k, len(keys)) for k in template_keys], dtype=np.int64)
    flat = np.arange(sweep.point_count, dtype=np.int64)
    point_group = template_group[points.template_index(flat)].reshape(shape)
    counts = np.bincount(point_group.reshape(-1), minlength=len(keys))
    groups = []
    for g, key in enumerate(keys):
        members = [t for t in range(len(points.templates)) if template_group[t] == g]
        features = _group_features(points, members)
        first = points.templates[members[0]]
        device_bytes, host_bytes = chain_memory(first, features)
        groups.append(
            LaunchGroup(
                key=key,
                features=features,
                point_count=int(counts[g]),
                device_bytes_per_chain=device_bytes,
                host_bytes_per_chain=host_bytes,
                grain_steps_per_chain=first.chain.grains * first.step_count,
            )
        )
    budget = device_budget(device)
    splitting = _splitting_dims(point_group)
    if block is None:
        import warp as wp

        cpu = not wp.get_device(device).is_cuda
        per_device = max(g.device_bytes_per_chain + (g.host_bytes_per_chain if cpu else 0) for g in groups)
        per_host = max(g.host_bytes_per_chain for g in groups)
        grains = points.templates[0].chain.grains
        fit = min(budget // per_device, HOST_MEMORY_BUDGET // per_host, max(1, MAX_GRAIN_THREADS // grains))
        if fit < 1:
            raise SceneError(
                "chain.grains",
                grains,
                f"one chain needs {per_device} bytes, more than the {budget} bytes available on {device}",
            )
        cap = work_cap(groups, "cpu" if cpu else "cuda", grains)
        target = min(fit, batch_size) if batch_size else min(fit, cap)
        block = block_for(shape, splitting, target)
    else:
        block = tuple(block)
        if (
            len(block) != len(shape)
            or any(b < 1 for b in block)
            or any(s and b != 1 and sp for b, s, sp in zip(block, shape, splitting))
        ):
            raise SceneError("store batch block", list(block), f"does not fit this sweep's shape {list(shape)}")
    batches = batches_for(shape, block, point_group)
    return Plan(
        shape=shape,
        block=block,
        groups=tuple(groups),
        batches=tuple(batches),
        point_group=point_group,
        device=str(device),
        memory_budget=budget,
    )


def work_cap(groups: "list[LaunchGroup] | tuple[LaunchGroup, ...]", kind: str, grains: int) -> int:
    """Most points of a batch whose work stays under ``LOST_WORK_SECONDS`` at ``SAFE_RATE[kind]`` or under
    ``LOST_WORK_FRACTION`` of the sweep, whichever is more (at least 1; on a GPU at least
    ``GPU_FILL_GRAIN_THREADS`` grain-threads; on a CPU at least one chain per thread of the chain kernel, so that
    every core works)."""
    from hertzian.core.solvers.chain import cpu_threads

    total = sum(g.grain_steps_per_chain * g.point_count for g in groups)
    budget = max(LOST_WORK_SECONDS * SAFE_RATE[kind], LOST_WORK_FRACTION * total)
    points = int(budget // max(1, max(g.grain_steps_per_chain for g in groups)))
    floor = GPU_FILL_GRAIN_THREADS // max(1, grains) if kind == "cuda" else cpu_threads()
    return max(1, floor, points)


def _group_features(points: SweepPoints, templates: list[int]) -> Features:
    """The kernel variant covering every point of the given templates, as ``features_of`` over every
    point's scene: only the static configurations are scanned (the parameter dimensions that hold a
    static key — exponent and gravity included — at every index, the others at index 0), in chunks."""
    combined = None
    for t in templates:
        if scene_path_key(points.templates[t]) is not None:
            found = _scene_features(points, t)
            combined = found if combined is None else _widen(combined, found)
            continue
        chains = static_subgrid(points, t)
        # homogeneous chains without gravity carry one static force on every contact: the first
        # contacts decide (as in build_model); otherwise every contact is scanned. Without event-aware
        # steps (events off, verlet/yoshida4, damping) only "is there a static overlap" is asked of the contacts,
        # and contact 1 (carrying F0 + g·m_0) answers it for every chain
        i = chains.template.integrator
        events_possible = i.events == "auto" and i.method in GEAR_CORRECTOR and chains.template.damping.model == "none"
        window = (
            None
            if events_possible and (chains.template.impurities or np.any(chains.column("chain.gravity") > 0))
            else 2
        )
        step = max(1, CHUNK_ELEMENTS // ((window or chains.template.chain.grains) + 1))
        for start in range(0, len(chains), step):
            part = chains.take(np.arange(start, min(start + step, len(chains))))
            found = chain_set_features(part, static_arrays(part, grains=window))
            combined = found if combined is None else _widen(combined, found)
    return combined


def _scene_features(points: SweepPoints, template: int) -> Features:
    """``features_of`` over every point of a template that runs one scene per point (``scene_path_key``), in
    chunks of scenes."""
    if not points.parameter:  # a template per point
        return features_of([points.templates[template]])
    members = np.flatnonzero(points.template_index(np.arange(points.point_count)) == template)
    combined = None
    for start in range(0, len(members), SCENE_CHUNK):
        found = features_of([points.scene(int(p)) for p in members[start : start + SCENE_CHUNK]])
        combined = found if combined is None else _widen(combined, found)
    return combined


SCENE_CHUNK = 4096
"""Scenes built at a time for the kernel variant of a template that runs one scene per point."""


def _widen(a: Features, b: Features) -> Features:
    """features_of over the union of two sets of chains (sharing method, precision, boundaries, traces)."""
    static = STATIC_LEVELS[max(STATIC_LEVELS.index(a.static), STATIC_LEVELS.index(b.static))]
    heterogeneous = a.heterogeneous or b.heterogeneous
    if static == "uniform" and heterogeneous:
        static = "profile"
    return replace(
        a,
        static=static,
        heterogeneous=heterogeneous,
        hertz=a.hertz and b.hertz,
        event_window=max(a.event_window, b.event_window),
    )


def format_bytes(count: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if count < 1024 or unit == "TiB":
            return f"{count:.3g} {unit}" if unit != "B" else f"{int(count)} B"
        count /= 1024
    return f"{count:.3g} TiB"


def describe(plan: Plan, sweep: Sweep, *, max_rows: int = 20) -> str:
    """The plan as text (``hertzian sweep --dry-run``)."""

    def dimension(d) -> str:
        zipped = f", with {', '.join(a.name for a in d.axes[1:])}" if len(d.axes) > 1 else ""
        return f"{d.name} ({d.size}{zipped})"

    dims = " × ".join(dimension(d) for d in sweep.dimensions) or "no axes"
    lines = [f"points: {plan.point_count} over {dims}", f"launch groups: {len(plan.groups)}"]
    for g_index, g in enumerate(plan.groups):
        key, f = g.key, g.features
        lines.append(
            f"  group {g_index}: {g.point_count} points, {key.grains} grains, "
            f"{key.method} {key.precision} dt={key.dt:g}, "
            f"{g.grain_steps_per_chain // key.grains} steps; kernel: static={f.static}, "
            f"heterogeneous={f.heterogeneous}, hertz={f.hertz}, traces={f.traces}"
        )
    lines.append(
        f"batches: {len(plan.batches)} of up to {plan.batch_size} points (block "
        f"{' × '.join(map(str, plan.block)) or '1'}) on {plan.device}, memory budget "
        f"{format_bytes(plan.memory_budget)}"
    )
    lines.append(f"estimated work: {plan.grain_steps:.4g} grain-steps")
    lines.append(f"{'batch':>7} {'group':>5} {'points':>7} {'device mem':>11} {'host mem':>10} {'grain-steps':>12}")
    for b in plan.batches[:max_rows]:
        lines.append(
            f"{b.index:>7} {b.group:>5} {len(b.points):>7} {format_bytes(plan.batch_device_bytes(b)):>11} "
            f"{format_bytes(plan.batch_host_bytes(b)):>10} {plan.batch_grain_steps(b):>12.4g}"
        )
    if len(plan.batches) > max_rows:
        lines.append(f"    … {len(plan.batches) - max_rows} more")
    return "\n".join(lines)


def single_batch_plan(shape: tuple[int, ...], scene: Scene, features: Features, device: str) -> Plan:
    """The plan of an ensemble already run as one launch (``hertzian run``, ``write_result``): one
    launch group, one batch covering the whole grid ``shape`` (() for a single run)."""
    shape = tuple(shape)
    device_bytes, host_bytes = chain_memory(scene, features)
    group = LaunchGroup(
        key=launch_key(scene),
        features=features,
        point_count=math.prod(shape),
        device_bytes_per_chain=device_bytes,
        host_bytes_per_chain=host_bytes,
        grain_steps_per_chain=scene.chain.grains * scene.step_count,
    )
    batch = Batch(index=0, group=0, region=tuple((0, n) for n in shape), grid_shape=shape)
    return Plan(
        shape=shape,
        block=shape,
        groups=(group,),
        batches=(batch,),
        point_group=np.zeros(shape, dtype=np.int64),
        device=str(device),
        memory_budget=0,
    )
