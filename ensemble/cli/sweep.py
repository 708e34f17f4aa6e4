"""``hertzian sweep``: run a sweep file's grid as batched ensembles into one Zarr store.

See docs/sweeps.md for the file format, resuming and running on several GPUs or hosts.
"""

from __future__ import annotations

import contextlib
import json
import sys
import time
from pathlib import Path
from typing import Annotated, Optional

import typer
from hertzian.cli.app import DeviceOption, KernelOption, PrecisionOption, SetOption, app, fail, resolve_device
from hertzian.core.scene import SceneError, parse_overrides


class _Progress:
    """A rich progress bar on stderr: batches, simulated time of the running batch, ETA, grain-steps/s."""

    def __init__(self, enabled: bool, *, total_batches: int, done_batches: int, grain_steps: int):
        self.enabled = enabled
        self.total_batches = total_batches
        self.done_batches = done_batches
        self.finished_steps = 0
        if not enabled:
            return
        from rich.console import Console
        from rich.progress import BarColumn, Progress, ProgressColumn, TextColumn, TimeRemainingColumn
        from rich.text import Text

        class RateColumn(ProgressColumn):
            def render(self, task):
                speed = task.finished_speed or task.speed
                return Text(f"{speed:.3g} grain-steps/s" if speed else "… grain-steps/s")

        self.bar = Progress(
            TextColumn("sweep"),
            BarColumn(bar_width=20),
            TextColumn("{task.fields[batches]} batches"),
            TextColumn("t={task.fields[sim]}"),
            RateColumn(),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            console=Console(stderr=True),
            transient=True,
        )
        self.bar.start()
        self.task = self.bar.add_task("sweep", total=max(grain_steps, 1), batches=self._batches(), sim="–")

    def _batches(self) -> str:
        return f"{self.done_batches}/{self.total_batches}"

    def record(self, job, done: int, total: int) -> None:
        if not self.enabled:
            return
        scene = job.chains.template
        fraction = (done - 1) / max(total - 1, 1)
        t = float(scene.record_times[done - 1])
        self.bar.update(
            self.task,
            completed=self.finished_steps + fraction * job.grain_steps,
            sim=f"{t:.4g}/{scene.integrator.duration:g}",
        )

    def batch_done(self, job, record) -> None:
        self.done_batches += 1
        self.finished_steps += job.grain_steps
        if self.enabled:
            self.bar.update(self.task, completed=self.finished_steps, batches=self._batches())

    def stop(self) -> None:
        if self.enabled:
            self.bar.stop()


def corner_dt_warnings(definition, scenes=None) -> list[str]:
    """``hertzian check``'s dt warning at the corners of the grid (at most 64 points).

    The stiffest contact grows monotonically with v_imp, l0, g, drive amplitude and the impurity
    constants, and the lightest mass shrinks monotonically, so a grid's extremes sit at its corners.
    """
    import itertools

    import numpy as np
    from hertzian.core.check import dt_warning

    shape = list(definition.shape)
    if shape:
        corners = itertools.product(*[sorted({0, n - 1}) for n in shape])
        points = sorted({int(np.ravel_multi_index(c, shape)) for c in corners})[:64]
    else:
        points = [0]
    lines = []
    for index in points:
        scene = definition.scene_at(tuple(int(i) for i in np.unravel_index(index, shape))) if shape else definition.base
        message = dt_warning(scene)
        if message:
            names = definition.coordinates_at(np.unravel_index(index, shape)) if shape else {}
            where = ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in names.items())
            lines.append(f"point {index}{' (' + where + ')' if where else ''}: {message}")
    return lines


@app.command()
def sweep(
    ctx: typer.Context,
    sweep_file: Annotated[Path, typer.Argument(help="Sweep TOML: a base scene and [[axis]] tables (docs/sweeps.md).")],
    out: Annotated[
        Optional[Path],
        typer.Option(
            "--out", help="Zarr store to write (default: the sweep file's name with .zarr, in the current directory)."
        ),
    ] = None,
    resume: Annotated[
        bool,
        typer.Option(
            "--resume",
            help="Continue an interrupted store: skip finished "
            "batches (refused for a different sweep or package version).",
        ),
    ] = False,
    overwrite: Annotated[bool, typer.Option("--overwrite", help="Replace an existing store.")] = False,
    dry_run: Annotated[
        bool, typer.Option("--dry-run", help="Print the plan (points, batches, memory, grain-steps) and write nothing.")
    ] = False,
    batch_size: Annotated[
        Optional[int],
        typer.Option("--batch-size", help="Points per ensemble launch (default: as many as fit the device's memory)."),
    ] = None,
    workers: Annotated[
        Optional[int],
        typer.Option(
            "--workers", help="Run batches on N local Dask worker processes (one device each: worker i uses cuda:i)."
        ),
    ] = None,
    scheduler: Annotated[
        Optional[str],
        typer.Option("--scheduler", help="Run batches on an existing Dask cluster, e.g. tcp://host:8786."),
    ] = None,
    device: DeviceOption = None,
    precision: PrecisionOption = None,
    set_: SetOption = None,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress bar.")] = False,
    strict: Annotated[
        bool,
        typer.Option(
            "--strict",
            help="Refuse (exit 2) when dt looks unstable or inaccurate at a corner of the grid (see hertzian check).",
        ),
    ] = False,
    as_json: Annotated[
        bool,
        typer.Option(
            "--json",
            help="Print a JSON summary with the time split (load, "
            "expand, plan, store creation, model build, kernel, store writes) on "
            "stdout.",
        ),
    ] = False,
    allow_large: Annotated[
        bool, typer.Option("--allow-large", help="Run sweeps of more than 10^7 points (refused by default).")
    ] = False,
    kernel: KernelOption = "auto",
):
    """Run a parameter sweep (SPEC §8) as batched ensembles into one Zarr store with one dimension per axis.

    Times are in program units (1.0102e-3 s). Kill it at any moment and rerun with --resume.
    """
    if batch_size is not None and batch_size < 1:
        fail(f"--batch-size = {batch_size}: must be ≥ 1")
    if workers is not None and workers < 1:
        fail(f"--workers = {workers}: must be ≥ 1")
    if workers is not None and scheduler is not None:
        fail(f"--scheduler = {scheduler!r}: give either --workers (a local cluster) or --scheduler, not both")
    if resume and overwrite:
        fail("--resume = true: --resume continues a store, --overwrite replaces it; give one")
    from hertzian.core.check import memory_refusal
    from hertzian.core.solvers import KERNELS
    from hertzian.sweeping.spec import MAX_POINTS, expand, load_sweep

    if kernel not in KERNELS:
        fail(f"--kernel = {kernel!r}: one of {', '.join(KERNELS)}")
    timing = {}
    clock = time.perf_counter()
    try:
        sets = parse_overrides(set_)
        if precision is not None:
            sets["integrator.precision"] = precision
        definition = load_sweep(sweep_file, sets, max_points=None if allow_large else MAX_POINTS)
        timing["load"] = time.perf_counter() - clock
        clock = time.perf_counter()
        points = expand(definition)
        timing["expand"] = time.perf_counter() - clock
    except SceneError as err:
        fail(str(err))
    # one chain of the largest kind (the planner sizes batches); before any array is built
    too_big = memory_refusal(max(points.templates, key=lambda t: t.chain.grains))
    if too_big:
        fail(too_big)
    unsafe = corner_dt_warnings(definition)
    if unsafe and strict:
        fail(unsafe[0])
    for line in unsafe:
        typer.echo(f"warning: {line}", err=True)
    out = out if out is not None else Path(sweep_file.stem + ".zarr")
    if not dry_run:
        if out.exists() and not (resume or overwrite):
            fail(f"--out = {str(out)!r}: exists; pass --resume to continue it or --overwrite to replace it")
        if not out.parent.exists():
            fail(f"--out = {str(out)!r}: parent directory does not exist")
    dev = resolve_device(device)
    # a local cluster starts in a background thread while this process plans and creates the store
    cluster = _start_cluster(workers, scheduler, device, ctx) if not dry_run else None

    from hertzian.sweeping.balance import balance_plan
    from hertzian.sweeping.planner import describe, plan_sweep
    from hertzian.sweeping.sweep_store import SweepStoreError, check_resumable

    block = None
    resuming = resume and out.exists()
    if resuming:
        try:
            block = check_resumable(out, definition)
        except SweepStoreError as err:
            fail(f"--resume = {str(out)!r}: {err}")
    clock = time.perf_counter()
    try:
        plan = plan_sweep(definition, points, dev, batch_size=batch_size, block=block)
    except SceneError as err:
        fail(str(err))
    if not resuming and (workers or cluster):  # a store being resumed keeps its block
        plan = balance_plan(plan, workers or cluster.worker_count)
    timing["plan"] = time.perf_counter() - clock
    if kernel != "auto":
        _check_kernel(kernel, plan, points, dev)
    else:
        _per_step_notes(plan, dev)
    if dry_run:
        if as_json:
            typer.echo(describe(plan, definition), err=True)
            typer.echo(
                json.dumps(
                    {
                        "points": plan.point_count,
                        "batches": len(plan.batches),
                        "batch_size": plan.batch_size,
                        "grain_steps": plan.grain_steps,
                        "device": dev,
                        "seconds": timing,
                    },
                    indent=1,
                )
            )
        else:
            typer.echo(describe(plan, definition))
        return
    if resuming and batch_size is not None and plan.batch_size != batch_size:
        typer.echo(
            f"note: --batch-size {batch_size} ignored: {out} was planned with batches of up to "
            f"{plan.batch_size} points",
            err=True,
        )
    _run(
        definition,
        points,
        plan,
        out,
        dev,
        resuming=resuming,
        overwrite=overwrite,
        workers=workers,
        scheduler=scheduler,
        cluster=cluster,
        requested_device=device,
        quiet=quiet,
        timing=timing,
        as_json=as_json,
        kernel=kernel,
    )


def _per_step_notes(plan, dev: str) -> None:
    """One line on stderr for each launch group that ``auto`` leaves on the per-step kernel, and why; one
    for each CUDA launch group that carries event-aware steps (their cost)."""
    import warp as wp
    from hertzian.core.solvers.calibrate import event_cost_note, step_reason_of

    is_cpu = wp.get_device(dev).is_cpu
    for index, group in enumerate(plan.groups):
        batch = next((b for b in plan.batches if b.group == index), None)
        if batch is None:
            continue
        reason = step_reason_of(group.features, is_cpu, plan.batch_grain_steps(batch))
        if reason:
            typer.echo(f"note: launch group {index}: per-step kernel: {reason}", err=True)
        events = event_cost_note(group.features, is_cpu)
        if events:
            typer.echo(f"note: launch group {index}: {events}", err=True)


def _check_kernel(kernel: str, plan, points, dev: str) -> None:
    """Refuse (exit 2) a forced ``--kernel`` that cannot run some launch group, before anything is written."""
    from hertzian.core.model import build_model
    from hertzian.core.solvers import choose_config

    for index, group in enumerate(plan.groups):
        batch = next(b for b in plan.batches if b.group == index)
        model = build_model([points.scene(int(batch.points[0]))], dev, features=group.features)
        try:
            choose_config(model, kernel, calibrate_now=False)
        except ValueError as err:
            fail(f"--kernel = {kernel!r}: {str(err).split(': ', 1)[-1]}")


def _start_cluster(workers, scheduler, device, ctx: typer.Context):
    """The workers of --workers (a local cluster, one GPU each, starting in the background) or --scheduler (bad
    address: exit 2); closed when the command ends."""
    from hertzian.sweeping.distributed import ClusterError, ClusterStart

    if workers is None and scheduler is None:
        return None
    try:  # --device cpu or an explicit cuda:N: workers share what they are told, no GPU of their own
        cluster = ClusterStart(workers, scheduler, gpus=None if device in (None, "cuda") else [])
    except ClusterError as err:
        fail(f"--scheduler = {scheduler!r}: {err}")
    ctx.call_on_close(cluster.close)
    return cluster


def _run(
    definition,
    points,
    plan,
    out: Path,
    dev: str,
    *,
    resuming: bool,
    overwrite: bool,
    workers,
    scheduler,
    cluster,
    requested_device,
    quiet: bool,
    timing: dict,
    as_json: bool,
    kernel: str = "auto",
) -> None:
    from concurrent.futures import ThreadPoolExecutor

    import numpy as np
    import zarr
    from hertzian.sweeping.balance import batch_priorities
    from hertzian.sweeping.distributed import (
        calibrate_ahead,
        jobs_for,
        run_distributed,
        run_serial,
        runs_of,
        warm_kernels,
    )
    from hertzian.sweeping.planner import format_bytes
    from hertzian.sweeping.sweep_store import (
        batch_records,
        completed_batches,
        create_sweep_store,
        finalize,
        remove_partial_files,
        status_codes,
        store_bytes,
    )

    distributed = cluster is not None
    label = (
        f"{workers} local Dask workers"
        if workers is not None
        else f"Dask cluster {scheduler}"
        if scheduler is not None
        else dev
    )
    features = [g.features for g in plan.groups]
    with contextlib.ExitStack() as stack:
        # the kernels this process's batches (or the workers') will use load in a thread, from Warp's cache or
        # compiled into it; for workers, shapes not yet calibrated are calibrated here first (one cache writer)
        todo = [b for b in plan.batches if b.index not in (completed_batches(out) if resuming else ())]

        def warm():
            if distributed:
                calibrate_ahead(plan, points, todo, dev, kernel=kernel)
            warm_kernels(features, dev, runs=runs_of(plan, points, todo))

        warming = stack.enter_context(ThreadPoolExecutor(max_workers=1)).submit(warm)
        create = None
        if resuming:
            remove_partial_files(out)
            done = completed_batches(out)
            earlier = {r["device"].split(":")[0] for r in batch_records(out)}
            if earlier - {dev.split(":")[0]}:
                typer.echo(
                    f"note: earlier batches ran on {', '.join(sorted(earlier))}, these run on {dev}: "
                    "results agree to rounding, not bit for bit, across device kinds",
                    err=True,
                )
        else:

            def create():
                create_sweep_store(out, definition, points.templates[0], plan, device=label, overwrite=overwrite)

            if distributed:  # workers write into it: it exists before they start
                clock = time.perf_counter()
                create()
                timing["create_store"] = time.perf_counter() - clock
                create = None
            # else: run_serial's store thread creates it while the first batch's first records run
            done = set()
        clock = time.perf_counter()
        pending = [b for b in plan.batches if b.index not in done]
        # workers may run elsewhere: give them the absolute store path
        jobs = jobs_for(out.resolve(), plan, points, pending, kernel=kernel)
        timing["jobs"] = time.perf_counter() - clock
        clock = time.perf_counter()
        warming.result()
        timing["warm_kernels"] = time.perf_counter() - clock
        clock = time.perf_counter()
        client = cluster.client() if distributed else None  # the workers' own warm-up is their first batch
        timing["cluster_wait"] = time.perf_counter() - clock
        progress = _Progress(
            not quiet and sys.stderr.isatty(),
            total_batches=len(plan.batches),
            done_batches=len(done),
            grain_steps=sum(j.grain_steps for j in jobs),
        )
        start = time.perf_counter()
        try:
            if client is None:
                run_serial(
                    jobs,
                    dev,
                    on_record=progress.record,
                    on_done=progress.batch_done,
                    create_store=create,
                    timing=timing,
                )
            else:
                run_distributed(
                    jobs,
                    client,
                    requested_device,
                    on_done=progress.batch_done,
                    priorities=batch_priorities(plan, [j.batch.index for j in jobs]),
                )
        except KeyboardInterrupt:
            progress.stop()
            typer.echo(
                f"interrupted after {progress.done_batches}/{len(plan.batches)} batches; continue with: "
                f"hertzian sweep {definition.source} --out {out} --resume",
                err=True,
            )
            raise typer.Exit(130) from None
        finally:
            progress.stop()
        session = time.perf_counter() - start
    session_steps = sum(j.grain_steps for j in jobs)
    clock = time.perf_counter()
    prov = finalize(out, session_seconds=session, session_grain_steps=session_steps)
    timing["finalize"] = time.perf_counter() - clock
    records = [r for r in batch_records(out) if r["batch"] in {j.batch.index for j in jobs}]
    timing["batches"] = session
    timing["build"] = sum(r["build_seconds"] for r in records)
    timing["kernel"] = sum(r["wall_seconds"] for r in records)
    timing["write"] = sum(r["write_seconds"] for r in records)

    status = np.asarray(zarr.open_array(store=str(out), path="status", mode="r")[...])
    codes, counts = np.unique(status, return_counts=True)
    names = status_codes()
    status_text = ", ".join(f"{names[str(int(c))].split(':')[0]} {int(k)}" for c, k in zip(codes, counts))
    ran = f"ran {len(jobs)} of {len(plan.batches)} batches" if resuming else f"{len(plan.batches)} batches"
    typer.echo(
        f"{plan.point_count} points, {ran} on {label}: {session:.2f} s, "
        f"{session_steps / max(session, 1e-12):.3g} grain-steps/s (per device "
        f"{prov['grain_steps_per_second']:.3g}); status: {status_text}; store {format_bytes(store_bytes(out))}",
        err=as_json,
    )
    typer.echo(f"wrote {out}", err=as_json)
    if as_json:
        typer.echo(
            json.dumps(
                {
                    "points": plan.point_count,
                    "batches": len(plan.batches),
                    "batches_run": len(jobs),
                    "device": label,
                    "grain_steps": session_steps,
                    "grain_steps_per_second": session_steps / max(session, 1e-12),
                    "status_counts": {str(int(c)): int(k) for c, k in zip(codes, counts)},
                    "store": str(out),
                    "store_bytes": store_bytes(out),
                    "seconds": timing,
                    # host time of this command outside the integration (interpreter start-up and imports excluded)
                    "seconds_outside_kernel": sum(
                        timing.get(k, 0.0)
                        for k in ("load", "expand", "plan", "jobs", "warm_kernels", "cluster_wait", "finalize")
                    )
                    + (timing.get("create_store", 0.0) if distributed else 0.0)
                    + timing["batches"]
                    - timing["kernel"],
                },
                indent=1,
            )
        )
