"""The one sweep pipeline: load → expand → plan → create store → jobs → warm kernels → run → finalize → summary.

``hertzian sweep``, ``hertzian reproduce``, ``hertzian bench --sweep`` and :func:`hertzian.sweep` all run it.
:func:`prepare_sweep` checks everything a sweep needs and writes nothing; :func:`run_sweep` runs a prepared sweep
and returns the summary that ``hertzian sweep --json`` prints. Bad input raises one line: an
:class:`~hertzian.core.errors.OptionError` for an argument, a :class:`~hertzian.core.scene.SceneError` for the file.
Notes and warnings (a dt that looks unstable, the per-step kernel and why) go to ``notify``, one line each.
"""

from __future__ import annotations

import contextlib
import difflib
import inspect
import itertools
import numbers
import time
import warnings
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import warp as wp
import zarr
from hertzian.core.check import dt_warning, memory_refusal
from hertzian.core.devices import check_device
from hertzian.core.errors import OptionError, RefusedError, check_path
from hertzian.core.model import build_model
from hertzian.core.shipped import shipped_file
from hertzian.core.solvers import KERNELS, choose_config
from hertzian.core.solvers.calibrate import event_cost_note, step_reason_of
from hertzian.sweeping.balance import balance_plan, batch_priorities
from hertzian.sweeping.distributed import (
    BatchFailedError,
    jobs_for,
    run_distributed,
    run_serial,
    runs_of,
    warm_kernels,
)
from hertzian.sweeping.planner import Plan, plan_sweep
from hertzian.sweeping.spec import MAX_POINTS, Sweep, SweepPoints, expand, load_sweep
from hertzian.sweeping.storage import NoRoomError, StoreLockedError, check_out, resolved_link
from hertzian.sweeping.sweep_store import (
    SweepStoreError,
    batch_records,
    check_resumable,
    completed_batches,
    create_sweep_store,
    finalize,
    store_bytes,
    writing_session,
)


@dataclass
class PreparedSweep:
    """A checked sweep, ready to run: nothing written yet."""

    definition: Sweep
    points: SweepPoints
    plan: Plan
    out: Path
    device: str
    """The device batches run on here ('cpu', 'cuda:0', …)."""
    requested_device: str | None
    """The device as asked for (Dask workers resolve None themselves)."""
    kernel: str
    resuming: bool
    overwrite: bool
    workers: int | None
    scheduler: str | None
    timing: dict[str, float]
    """Seconds so far: load, expand, plan."""
    cluster: Any = None
    """The Dask workers (``distributed.ClusterStart``) of ``workers``/``scheduler``, started while this process
    plans; :func:`run_sweep` closes them."""


def tls_files(tls) -> Any:
    """``tls`` as ``distributed.TlsFiles``: one already, or a dict of its fields (``ca_file``, ``cert``, ``key``)."""
    if tls is None or not isinstance(tls, dict):
        return tls
    from hertzian.sweeping.distributed import TlsFiles

    unknown = sorted(set(tls) - {"ca_file", "cert", "key"})
    if unknown or not {"ca_file", "cert"} <= set(tls):
        raise OptionError("tls", tls, "a dict of ca_file and cert (and key): PEM file paths")
    return TlsFiles(**{k: str(v) for k, v in tls.items()})


WORKER_MEMORY_GIB = 1
"""Host memory a local Dask worker needs [GiB]: its process (Python, Warp, Dask, Zarr: 0.25–0.35 GB resident on a
CPU worker of a small sweep) and a batch's host copies."""


def max_local_workers() -> int:
    """The most local workers this machine's memory holds (distributed's ``MEMORY_LIMIT``: the host's memory, or
    its cgroup's limit), at :data:`WORKER_MEMORY_GIB` each; at least 1."""
    from distributed.system import MEMORY_LIMIT

    return max(1, MEMORY_LIMIT // (WORKER_MEMORY_GIB << 30))


def check_options(*, batch_size, workers, scheduler, resume, overwrite, kernel, tls=None) -> None:
    """Refuse arguments that cannot work together, before anything is read."""
    if tls is not None and not str(scheduler or "").startswith("tls://"):
        raise OptionError("tls_ca_file", tls.ca_file, "TLS files apply to a scheduler given as tls://HOST:PORT")
    for key, value in (("batch_size", batch_size), ("workers", workers)):
        if value is not None and (not isinstance(value, numbers.Integral) or isinstance(value, bool)):
            raise OptionError(key, value, "an integer ≥ 1")
        if value is not None and value < 1:
            raise OptionError(key, value, "must be ≥ 1")
    if workers is not None and scheduler is not None:
        raise OptionError("scheduler", scheduler, "give either workers (a local cluster) or scheduler, not both")
    if workers is not None and workers > max_local_workers():
        raise OptionError(
            "workers",
            workers,
            f"at most {max_local_workers()} on this machine (each worker process gets an even share of the host "
            f"memory, and needs {WORKER_MEMORY_GIB} GiB)",
        )
    if resume and overwrite:
        raise OptionError("resume", True, "resume continues a store, overwrite replaces it; give one")
    if kernel not in KERNELS:
        raise OptionError("kernel", kernel, f"one of {', '.join(KERNELS)}")


def load_points(sweep, overrides, *, allow_large: bool, timing: dict) -> tuple[Sweep, SweepPoints]:
    """The sweep (a file, a shipped name or a Sweep) and its points; ``timing`` gets load and expand."""
    clock = time.perf_counter()
    if isinstance(sweep, Sweep):
        if overrides:
            raise OptionError("overrides", overrides, "apply overrides to a sweep file, not to a loaded Sweep")
        definition = sweep
    elif isinstance(sweep, (str, Path)):
        definition = load_sweep(shipped_file(sweep), overrides, max_points=None if allow_large else MAX_POINTS)
    else:
        raise OptionError("sweep", type(sweep).__name__, "a sweep file's path, a shipped sweep's name or a Sweep")
    timing["load"] = time.perf_counter() - clock
    clock = time.perf_counter()
    points = expand(definition)
    timing["expand"] = time.perf_counter() - clock
    return definition, points


def corner_dt_warnings(definition: Sweep) -> list[str]:
    """``hertzian check``'s dt warning at the corners of the grid (at most 64 points).

    The stiffest contact grows monotonically with v_imp, l0, g, drive amplitude and the impurity
    constants, and the lightest mass shrinks monotonically, so a grid's extremes sit at its corners.
    """
    shape = list(definition.shape)
    corners = itertools.product(*[sorted({0, n - 1}) for n in shape])
    points = sorted({int(np.ravel_multi_index(c, shape)) for c in corners})[:64] if shape else [0]
    lines = []
    for index in points:
        where = tuple(int(i) for i in np.unravel_index(index, shape)) if shape else ()
        message = dt_warning(definition.scene_at(where) if shape else definition.base)
        if message:
            names = definition.coordinates_at(where) if shape else {}
            text = ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in names.items())
            lines.append(f"point {index}{' (' + text + ')' if text else ''}: {message}")
    return lines


def prepare_sweep(
    sweep: str | Path | Sweep,
    out: str | Path | None = None,
    *,
    device: str | None = None,
    resume: bool = False,
    overwrite: bool = False,
    batch_size: int | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    kernel: str = "auto",
    overrides: dict[str, Any] | None = None,
    allow_large: bool = False,
    strict: bool = False,
    dry_run: bool = False,
    notify: Callable[[str], None] | None = None,
    tls: Any = None,
) -> PreparedSweep:
    """Load, expand, check and plan a sweep; writes nothing. ``out`` defaults to the sweep's name with ``.zarr`` in
    the current directory; ``strict`` refuses a dt that looks unstable at a corner of the grid (else a warning);
    ``tls`` (``{"ca_file": …, "cert": …, "key": …}`` or a ``hertzian.sweeping.distributed.TlsFiles``) secures the
    connection to a ``tls://`` scheduler."""
    notify = notify or _warn
    tls = tls_files(tls)
    check_options(
        batch_size=batch_size,
        workers=workers,
        scheduler=scheduler,
        resume=resume,
        overwrite=overwrite,
        kernel=kernel,
        tls=tls,
    )
    timing: dict[str, float] = {}
    # the workers start in the background first: their start (process spawn, imports, the CUDA driver) is the
    # longest fixed cost of a distributed sweep; this process loads, checks and plans meanwhile
    cluster = None if dry_run else _start_cluster(workers, scheduler, device, tls)
    try:
        definition, points = _checked_points(sweep, overrides, allow_large, strict, notify, timing)
        out = resolved_link(out if out is not None else Path(str(definition.source or "sweep")).stem + ".zarr")
        if not dry_run:
            check_out(out, resume=resume, overwrite=overwrite)
        dev = check_device(device)
        resuming = resume and out.exists()
        plan = _plan(definition, points, out, dev, batch_size=batch_size, resuming=resuming, timing=timing)
        if cluster is not None and not resuming:  # a store being resumed keeps its block
            plan = balance_plan(plan, workers or cluster.worker_count)
        if kernel != "auto":
            check_kernel(kernel, plan, points, dev)
        else:
            per_step_notes(plan, dev, notify)
    except BaseException:
        if cluster is not None:
            cluster.close()
        raise
    if resuming and batch_size is not None and plan.batch_size != batch_size:
        notify(
            f"note: batch size {batch_size} ignored: {out} was planned with batches of up to {plan.batch_size} points"
        )
    return PreparedSweep(
        definition, points, plan, out, dev, device, kernel, resuming, overwrite, workers, scheduler, timing, cluster
    )


def _checked_points(sweep, overrides, allow_large: bool, strict: bool, notify, timing: dict):
    """The sweep loaded and expanded, refused (RefusedError) when one chain of its largest kind cannot fit or,
    with ``strict``, when dt looks unstable at a corner of its grid (else ``notify`` warns)."""
    definition, points = load_points(sweep, overrides, allow_large=allow_large, timing=timing)
    # one chain of the largest kind (the planner sizes batches); before any array is built
    too_big = memory_refusal(max(points.templates, key=lambda t: t.chain.grains))
    if too_big:
        raise RefusedError(too_big)
    unsafe = corner_dt_warnings(definition)
    if unsafe and strict:
        raise RefusedError(unsafe[0])
    for line in unsafe:
        notify(f"warning: {line}")
    return definition, points


def _plan(definition, points, out: Path, dev: str, *, batch_size, resuming: bool, timing: dict) -> Plan:
    """The plan (a resumed store's block kept); ``timing`` gets plan."""
    block = None
    if resuming:
        try:
            block = check_resumable(out, definition)
        except SweepStoreError as err:
            raise OptionError("resume", str(out), str(err)) from None
    clock = time.perf_counter()
    plan = plan_sweep(definition, points, dev, batch_size=batch_size, block=block)
    timing["plan"] = time.perf_counter() - clock
    return plan


def per_step_notes(plan: Plan, dev: str, notify: Callable[[str], None]) -> None:
    """One note for each launch group that ``auto`` leaves on the per-step kernel, and why; one for each CUDA
    launch group that carries event-aware steps (their cost)."""
    is_cpu = wp.get_device(dev).is_cpu
    for index, group in enumerate(plan.groups):
        batch = next((b for b in plan.batches if b.group == index), None)
        if batch is None:
            continue
        reason = step_reason_of(group.features, is_cpu, plan.batch_grain_steps(batch))
        if reason:
            notify(f"note: launch group {index}: per-step kernel: {reason}")
        events = event_cost_note(group.features, is_cpu)
        if events:
            notify(f"note: launch group {index}: {events}")


def check_kernel(kernel: str, plan: Plan, points: SweepPoints, dev: str) -> None:
    """Refuse a forced ``kernel`` that cannot run some launch group, before anything is written."""
    for index, group in enumerate(plan.groups):
        batch = next(b for b in plan.batches if b.group == index)
        model = build_model([points.scene(int(batch.points[0]))], dev, features=group.features)
        try:
            choose_config(model, kernel)
        except ValueError as err:
            raise OptionError("kernel", kernel, str(err).split(": ", 1)[-1]) from None


def plan_summary(prepared: PreparedSweep) -> dict[str, Any]:
    """What ``hertzian sweep --dry-run --json`` prints: points, batches, batch size, grain-steps, device, seconds
    (of the planning), and the estimated seconds of the run (:func:`estimated_seconds`)."""
    plan = prepared.plan
    return {
        "points": plan.point_count,
        "batches": len(plan.batches),
        "batch_size": plan.batch_size,
        "grain_steps": plan.grain_steps,
        "device": prepared.device,
        "seconds": prepared.timing,
        "estimate": estimated_seconds(prepared),
    }


def estimated_seconds(prepared: PreparedSweep) -> dict[str, Any]:
    """Seconds the sweep's integration should take on its device, and what the figure rests on. On a CPU: each
    launch group's grain-steps at the warm rate of the kernel ``auto`` picks for it, measured on the reference
    2-core CPU (``calibrate.CPU_COSTS``), plus its compile where Warp's cache lacks it (a scene with traces,
    damping or a drive runs slower than that rate: the figure is a lower bound there). On a GPU: an upper bound at
    the planner's conservative rate (``planner.SAFE_RATE``), which full batches exceed."""
    from hertzian.core.solvers.calibrate import CPU_COSTS, chain_kernel, cpu_seconds, in_kernel_cache, step_kernel
    from hertzian.sweeping.planner import SAFE_RATE

    plan = prepared.plan
    if not wp.get_device(prepared.device).is_cpu:
        rate = SAFE_RATE["cuda"]
        return {"seconds": plan.grain_steps / rate, "bound": "upper", "grain_steps_per_second": rate}
    total = 0.0
    for group in plan.groups:
        steps = plan.grain_steps * group.point_count / max(plan.point_count, 1)
        cached = {
            "chain": in_kernel_cache(chain_kernel(group.features).module, prepared.device),
            "step": in_kernel_cache(step_kernel(group.features).module, prepared.device),
        }
        total += min(cpu_seconds(kind, steps, cached[kind]) for kind in ("chain", "step"))
    return {"seconds": total, "bound": "estimate", "grain_steps_per_second": CPU_COSTS["chain"][1]}


def estimate_line(prepared: PreparedSweep) -> str:
    """The estimate as one line of ``--dry-run``'s plan."""
    found = estimated_seconds(prepared)
    if found["bound"] == "upper":
        return (
            f"estimated integration: at most about {found['seconds']:.3g} s on {prepared.device} (at "
            f"{found['grain_steps_per_second']:.0e} grain-steps/s, a conservative GPU rate)"
        )
    return (
        f"estimated integration: roughly {found['seconds']:.3g} s on {prepared.device} (the CPU kernels' rates on a "
        "2-core reference CPU at 200 grains, compiles included where not cached; shorter chains, traces, damping "
        "and drives run slower)"
    )


def _warn(line: str) -> None:
    """The default ``notify`` of the Python API: warnings as Python warnings, notes dropped."""
    if line.startswith("warning: "):
        warnings.warn(line.removeprefix("warning: "), stacklevel=3)


class SweepProgress:
    """What :func:`run_sweep` tells about progress; a subclass draws it (the CLI's bar), this one does nothing."""

    done_batches = 0

    def start(self, *, total_batches: int, done_batches: int, grain_steps: int) -> None:
        """Before the first batch: ``done_batches`` of ``total_batches`` already in the store."""
        self.done_batches = done_batches

    def record(self, job, done: int, total: int) -> None:
        """Record ``done`` of ``total`` of the running batch ``job`` is on the host (serial runs only)."""

    def batch_done(self, job, record: dict) -> None:
        """Batch ``job`` is written."""
        self.done_batches += 1

    def stop(self) -> None:
        """After the last batch, or on an interruption."""


class CallbackProgress(SweepProgress):
    """Calls ``callback(done_batches, total_batches)`` after each batch (the Python API's ``progress``)."""

    def __init__(self, callback: Callable[[int, int], None]):
        self.callback = callback
        self.total_batches = 0

    def start(self, *, total_batches: int, done_batches: int, grain_steps: int) -> None:
        super().start(total_batches=total_batches, done_batches=done_batches, grain_steps=grain_steps)
        self.total_batches = total_batches

    def batch_done(self, job, record: dict) -> None:
        super().batch_done(job, record)
        self.callback(self.done_batches, self.total_batches)


def _start_cluster(workers: int | None, scheduler: str | None, device: str | None, tls=None):
    """The workers of ``workers`` (a local cluster, one GPU each, starting in the background) or ``scheduler``
    (an existing cluster; a bad address is an OptionError); None for a serial sweep."""
    if workers is None and scheduler is None:
        return None
    # Dask is imported only for a distributed sweep: it is optional and slow to import
    from hertzian.sweeping.distributed import ClusterError, ClusterStart

    try:  # --device cpu or an explicit cuda:N: workers share what they are told, no GPU of their own
        return ClusterStart(workers, scheduler, gpus=None if device in (None, "cuda") else [], tls=tls)
    except ClusterError as err:
        raise OptionError("scheduler", scheduler, str(err)) from None


def run_sweep(
    prepared: PreparedSweep,
    *,
    progress: SweepProgress | None = None,
    notify: Callable[[str], None] | None = None,
    on_result: Callable | None = None,
) -> dict[str, Any]:
    """Run a prepared sweep into its store and finalize it; returns :func:`summary`'s dict. ``on_result(job, result,
    build_seconds)`` is called after each batch of a serial run. An interruption (KeyboardInterrupt) leaves a store
    that ``resume`` continues.

    The writes are guarded (``sweep_store.writing_session``): a second writer of the same store gets an
    :class:`OptionError` on ``out``, as does a store larger than the free space; on resume, damaged chunks are found
    and their batches rerun; a storage fault while running (a full disk, lost permission) raises
    ``StorageError`` (one line) and leaves the store as of its last completed batch."""
    p, notify = prepared, notify or _warn
    try:
        session = writing_session(
            p.out, p.definition, p.points.templates[0], p.plan, resuming=p.resuming, device=label_of(p)
        )
        with session as notes:
            for line in notes:
                notify(line)
            return _run_pending(p, progress or SweepProgress(), notify, on_result)
    except (StoreLockedError, NoRoomError) as err:
        raise OptionError("out", str(p.out), str(err)) from None
    except SweepStoreError as err:  # damage that --resume cannot repair
        raise OptionError("resume", str(p.out), str(err)) from None
    finally:
        if p.cluster is not None:
            p.cluster.close()


def _run_pending(p: PreparedSweep, progress: SweepProgress, notify, on_result) -> dict[str, Any]:
    """The batches not yet complete, run here or on Dask workers, then the store finalized."""
    distributed = p.cluster is not None
    done = completed_batches(p.out) if p.resuming else set()
    pending = [b for b in p.plan.batches if b.index not in done]
    if not pending:
        prov = finalize(p.out, session_seconds=0.0, session_grain_steps=0)
        return summary(p, [], prov, 0.0)
    with contextlib.ExitStack() as stack:
        create, jobs = _setup(p, pending, stack, notify)
        clock = time.perf_counter()
        client = p.cluster.client() if distributed else None  # the workers' own warm-up is their first batch
        p.timing["cluster_wait"] = time.perf_counter() - clock
        progress.start(
            total_batches=len(p.plan.batches), done_batches=len(done), grain_steps=sum(j.grain_steps for j in jobs)
        )
        start = time.perf_counter()
        try:
            if client is None:
                run_serial(
                    jobs,
                    p.device,
                    on_record=progress.record,
                    on_done=progress.batch_done,
                    on_result=on_result,
                    create_store=create,
                    timing=p.timing,
                )
            else:
                try:
                    run_distributed(
                        jobs,
                        client,
                        p.requested_device,
                        on_done=progress.batch_done,
                        priorities=batch_priorities(p.plan, [j.batch.index for j in jobs]),
                    )
                except BatchFailedError as err:  # the batches that completed stay: --resume runs the rest
                    err.hint = (
                        "the store keeps the completed batches; continue with: "
                        f"hertzian sweep {p.definition.source} --out {p.out} --resume"
                    )
                    raise
        finally:
            progress.stop()
        batches_seconds = time.perf_counter() - start
    clock = time.perf_counter()
    prov = finalize(p.out, session_seconds=batches_seconds, session_grain_steps=sum(j.grain_steps for j in jobs))
    p.timing["finalize"] = time.perf_counter() - clock
    return summary(p, jobs, prov, batches_seconds)


def _setup(p: PreparedSweep, pending: list, stack: contextlib.ExitStack, notify) -> tuple:
    """Warm the kernels (in a thread), create or clean up the store, build the jobs; returns (the store's creation
    for run_serial's store thread, or None; the jobs). ``p.timing`` gets create_store (distributed), jobs and
    warm_kernels."""
    distributed = p.cluster is not None
    features = [g.features for g in p.plan.groups]

    def warm():  # the kernels load from Warp's cache or compile into it; one writer: this process
        warm_kernels(features, p.device, runs=runs_of(p.plan, p.points, pending))

    warming = stack.enter_context(ThreadPoolExecutor(max_workers=1)).submit(warm)
    create = None
    if p.resuming:  # (writing_session removed the temporary files of a killed write)
        earlier = {r["device"].split(":")[0] for r in batch_records(p.out)}
        if earlier - {p.device.split(":")[0]}:
            notify(
                f"note: earlier batches ran on {', '.join(sorted(earlier))}, these run on {p.device}: "
                "results agree to rounding, not bit for bit, across device kinds"
            )
    else:

        def create():
            create_sweep_store(
                p.out, p.definition, p.points.templates[0], p.plan, device=label_of(p), overwrite=p.overwrite
            )

        if distributed:  # workers write into it: it exists before they start
            clock = time.perf_counter()
            create()
            p.timing["create_store"] = time.perf_counter() - clock
            create = None
        # else: run_serial's store thread creates it while the first batch's first records run
    clock = time.perf_counter()
    # workers may run elsewhere: give them the absolute store path
    jobs = jobs_for(p.out.resolve(), p.plan, p.points, pending, kernel=p.kernel)
    p.timing["jobs"] = time.perf_counter() - clock
    clock = time.perf_counter()
    warming.result()
    p.timing["warm_kernels"] = time.perf_counter() - clock
    return create, jobs


def label_of(p: PreparedSweep) -> str:
    """Where the batches run, in words: the device, or the Dask workers or cluster."""
    if p.workers is not None:
        return f"{p.workers} local Dask workers"
    return f"Dask cluster {p.scheduler}" if p.scheduler is not None else p.device


def summary(p: PreparedSweep, jobs: list, prov: dict, batches_seconds: float) -> dict[str, Any]:
    """The summary of a run: points, batches (and how many ran), device, grain-steps and rates, status counts,
    the store and its bytes, the time split [s] and the host seconds outside the kernel."""
    timing = p.timing
    ran = {j.batch.index for j in jobs}
    records = [r for r in batch_records(p.out) if r["batch"] in ran]
    timing["batches"] = batches_seconds
    for key, column in (("build", "build_seconds"), ("kernel", "wall_seconds"), ("write", "write_seconds")):
        timing[key] = sum(r[column] for r in records)
    status = np.asarray(zarr.open_array(store=str(p.out), path="status", mode="r")[...])
    codes, counts = np.unique(status, return_counts=True)
    steps = sum(j.grain_steps for j in jobs)
    overhead = ("load", "expand", "plan", "jobs", "warm_kernels", "cluster_wait", "finalize")
    distributed = p.cluster is not None
    return {
        "points": p.plan.point_count,
        "batches": len(p.plan.batches),
        "batches_run": len(jobs),
        "device": label_of(p),
        "grain_steps": steps,
        "grain_steps_per_second": steps / max(batches_seconds, 1e-12),
        "grain_steps_per_second_per_device": prov["grain_steps_per_second"],
        "energy_error_max": prov["energy_error_max"],
        "kernel": prov.get("kernel", ""),
        "status_counts": {str(int(c)): int(k) for c, k in zip(codes, counts)},
        "store": str(p.out),
        "store_bytes": store_bytes(p.out),
        "seconds": timing,
        # host time outside the integration (interpreter start-up and imports excluded)
        "seconds_outside_kernel": sum(timing.get(k, 0.0) for k in overhead)
        + (timing.get("create_store", 0.0) if distributed else 0.0)
        + timing["batches"]
        - timing["kernel"],
    }


def sweep(
    sweep: str | Path | Sweep,
    out: str | Path | None = None,
    *,
    progress: SweepProgress | Callable[[int, int], None] | None = None,
    notify: Callable[[str], None] | None = None,
    on_result: Callable | None = None,
    **options: Any,
) -> dict[str, Any]:
    """Prepare (:func:`prepare_sweep`'s ``options``) and run a sweep; returns the summary dict.
    ``progress``: a :class:`SweepProgress`, or ``callback(done_batches, total_batches)``."""
    check_path("out", out, optional=True)
    if not (progress is None or isinstance(progress, SweepProgress) or callable(progress)):
        raise OptionError("progress", type(progress).__name__, "a SweepProgress or a function (done, total)")
    known = [p for p in inspect.signature(prepare_sweep).parameters if p not in ("sweep", "out", "notify")]
    for name in options:
        if name not in known:
            close = difflib.get_close_matches(name, known, n=1)
            hint = f" (did you mean {close[0]}?)" if close else ""
            raise OptionError(name, options[name], f"not an option of sweep{hint}; options: {', '.join(known)}")
    prepared = prepare_sweep(sweep, out, notify=notify, **options)
    if progress is not None and not isinstance(progress, SweepProgress):
        progress = CallbackProgress(progress)
    return run_sweep(prepared, progress=progress, notify=notify, on_result=on_result)
