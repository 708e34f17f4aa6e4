"""``hertzian sweep``: run a sweep file's grid as batched ensembles into one Zarr store.

See docs/sweeps.md for the file format, resuming and running on several GPUs or hosts.
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path
from typing import Annotated, Optional

import typer
from hertzian.cli.app import (
    DeviceOption,
    KernelOption,
    PrecisionOption,
    SetOption,
    app,
    exit_if_flagged,
    fail,
    one_line_errors,
    overrides_of,
)
from rich.console import Console
from rich.progress import BarColumn, Progress, ProgressColumn, TextColumn, TimeRemainingColumn
from rich.text import Text


class _Progress:
    """A rich progress bar on stderr: batches, simulated time of the running batch, ETA, grain-steps/s
    (the pipeline's SweepProgress, drawn)."""

    def __init__(self, enabled: bool):
        self.enabled = enabled
        self.total_batches = self.done_batches = self.finished_steps = 0

    def start(self, *, total_batches: int, done_batches: int, grain_steps: int) -> None:
        self.total_batches, self.done_batches = total_batches, done_batches
        if not self.enabled:
            return

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
        if self.enabled and hasattr(self, "bar"):
            self.bar.stop()


class _LogProgress:
    """Progress as plain lines on stderr, for a sweep whose output is not a terminal (a log file, a batch job): one
    line when it starts, then at most one every ``every`` seconds (after a record or a batch), and one at the end."""

    def __init__(self, every: float = 30.0, clock=time.monotonic):
        self.every, self.clock = every, clock
        self.total_batches = self.done_batches = self.finished_steps = self.total_steps = 0
        self.running = 0.0

    def start(self, *, total_batches: int, done_batches: int, grain_steps: int) -> None:
        self.total_batches, self.done_batches, self.total_steps = total_batches, done_batches, grain_steps
        self.started = self.last = self.clock()
        typer.echo(f"sweep: {self._batches()} batches done; {grain_steps:.3g} grain-steps to run", err=True)

    def _batches(self) -> str:
        return f"{self.done_batches}/{self.total_batches}"

    def _line(self) -> None:
        self.last = now = self.clock()
        done = self.finished_steps + self.running
        rate = done / max(now - self.started, 1e-9)
        left = f"about {(self.total_steps - done) / rate:.0f} s left" if rate > 0 else "time left not known yet"
        typer.echo(
            f"sweep: {self._batches()} batches, {100 * done / max(self.total_steps, 1):.0f} % of the grain-steps, "
            f"{rate:.3g} grain-steps/s, {now - self.started:.0f} s elapsed, {left}",
            err=True,
        )

    def record(self, job, done: int, total: int) -> None:
        self.running = (done - 1) / max(total - 1, 1) * job.grain_steps
        if self.clock() - self.last >= self.every:
            self._line()

    def batch_done(self, job, record) -> None:
        self.done_batches += 1
        self.finished_steps += job.grain_steps
        self.running = 0.0
        if self.clock() - self.last >= self.every or self.done_batches == self.total_batches:
            self._line()

    def stop(self) -> None:
        pass


PROGRESS_SECONDS_ENV = "HERTZIAN_PROGRESS_SECONDS"
"""Seconds between two progress lines when stderr is not a terminal (default 30)."""


def _progress(quiet: bool):
    """The progress display: a bar on a terminal, plain lines otherwise, nothing with ``--quiet``."""
    if quiet:
        return _Progress(False)
    if sys.stderr.isatty():
        return _Progress(True)
    try:
        every = float(os.environ.get(PROGRESS_SECONDS_ENV, "30"))
    except ValueError:
        fail(f"{PROGRESS_SECONDS_ENV} = {os.environ[PROGRESS_SECONDS_ENV]!r}: a number of seconds")
    return _LogProgress(every)


SweepFileArgument = Annotated[
    Path,
    typer.Argument(
        help="Sweep TOML file: a base scene and [[axis]] tables (docs/sweeps.md); or the name of a shipped "
        "sweep (e.g. example.toml), looked up when no such path exists."
    ),
]

OutOption = Annotated[
    Optional[Path],
    typer.Option(
        "--out", help="Zarr store to write (default: the sweep file's name with .zarr, in the current directory)."
    ),
]

ResumeOption = Annotated[
    bool,
    typer.Option(
        "--resume",
        help="Continue an interrupted store: skip finished batches (refused for a different sweep or package version).",
    ),
]

OverwriteOption = Annotated[bool, typer.Option("--overwrite", help="Replace an existing store.")]

DryRunOption = Annotated[
    bool, typer.Option("--dry-run", help="Print the plan (points, batches, memory, grain-steps) and write nothing.")
]

BatchSizeOption = Annotated[
    Optional[int],
    typer.Option("--batch-size", help="Points per ensemble launch (default: as many as fit the device's memory)."),
]

WorkersOption = Annotated[
    Optional[int],
    typer.Option(
        "--workers", help="Run batches on N local Dask worker processes (one device each: worker i uses cuda:i)."
    ),
]

SchedulerOption = Annotated[
    Optional[str],
    typer.Option("--scheduler", help="Run batches on an existing Dask cluster, e.g. tcp://host:8786."),
]

TlsCaOption = Annotated[
    Optional[Path],
    typer.Option("--tls-ca-file", help="With --scheduler tls://…: the CA certificate (PEM) that signed the cluster's."),
]

TlsCertOption = Annotated[
    Optional[Path], typer.Option("--tls-cert", help="With --scheduler tls://…: this client's certificate (PEM).")
]

TlsKeyOption = Annotated[
    Optional[Path],
    typer.Option("--tls-key", help="With --scheduler tls://…: this client's private key (PEM; omit if in --tls-cert)."),
]

QuietOption = Annotated[bool, typer.Option("--quiet", help="No progress bar.")]

StrictOption = Annotated[
    bool,
    typer.Option(
        "--strict",
        help="Refuse (exit 2) when dt looks unstable or inaccurate at a corner of the grid (see hertzian check).",
    ),
]

AsJsonOption = Annotated[
    bool,
    typer.Option(
        "--json",
        help="Print a JSON summary with the time split (load, "
        "expand, plan, store creation, model build, kernel, store writes) on "
        "stdout.",
    ),
]

AllowLargeOption = Annotated[
    bool, typer.Option("--allow-large", help="Run sweeps of more than 10^7 points (refused by default).")
]

ErrorEstimateOption = Annotated[
    bool,
    typer.Option("--error-estimate", help="Store each point's estimated position error (record.error_estimate)."),
]


@app.command()
def sweep(
    sweep_file: SweepFileArgument,
    out: OutOption = None,
    resume: ResumeOption = False,
    overwrite: OverwriteOption = False,
    dry_run: DryRunOption = False,
    batch_size: BatchSizeOption = None,
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    device: DeviceOption = None,
    precision: PrecisionOption = None,
    set_: SetOption = None,
    quiet: QuietOption = False,
    strict: StrictOption = False,
    as_json: AsJsonOption = False,
    allow_large: AllowLargeOption = False,
    kernel: KernelOption = "auto",
    error_estimate: ErrorEstimateOption = False,
    tls_ca_file: TlsCaOption = None,
    tls_cert: TlsCertOption = None,
    tls_key: TlsKeyOption = None,
):
    """Run a parameter sweep as batched ensembles into one Zarr store with one dimension per axis.

    Times are in program units (1.0102e-3 s). Kill it at any moment and rerun with --resume.
    """
    # the pipeline imports Warp and Zarr: only once a sweep runs, not for `hertzian --help`
    from hertzian.sweeping.pipeline import estimate_line, plan_summary, prepare_sweep, run_sweep
    from hertzian.sweeping.planner import describe

    notify = lambda line: typer.echo(line, err=True)  # noqa: E731
    with one_line_errors():
        prepared = prepare_sweep(
            sweep_file,
            out,
            device=device,
            resume=resume,
            overwrite=overwrite,
            batch_size=batch_size,
            workers=workers,
            scheduler=scheduler,
            kernel=kernel,
            overrides=overrides_of(set_, precision) | ({"record.error_estimate": True} if error_estimate else {}),
            allow_large=allow_large,
            strict=strict,
            dry_run=dry_run,
            notify=notify,
            tls=tls_files(tls_ca_file, tls_cert, tls_key),
        )
    if dry_run:
        typer.echo(describe(prepared.plan, prepared.definition), err=as_json)
        typer.echo(estimate_line(prepared), err=as_json)
        if as_json:
            typer.echo(json.dumps(plan_summary(prepared), indent=1))
        return
    from hertzian.sweeping.distributed import BatchFailedError
    from hertzian.sweeping.storage import StorageError

    progress = _progress(quiet)
    try:
        with one_line_errors():
            result = run_sweep(prepared, progress=progress, notify=notify)
    except (StorageError, BatchFailedError) as err:  # a full disk, a failed batch: the store keeps what completed
        typer.echo(f"error: {err}", err=True)
        raise typer.Exit(1) from None
    except KeyboardInterrupt:
        from hertzian.sweeping.sweep_store import completed_batches

        stored = len(completed_batches(prepared.out))  # what the store holds, not what this process saw finish
        typer.echo(
            f"interrupted with {stored}/{len(prepared.plan.batches)} batches in the store; continue with: "
            f"hertzian sweep {prepared.definition.source} --out {prepared.out} --resume",
            err=True,
        )
        raise typer.Exit(130) from None
    typer.echo(report(result, resumed=prepared.resuming), err=as_json)
    typer.echo(f"wrote {prepared.out}", err=as_json)
    if as_json:
        typer.echo(json.dumps(result, indent=1))
    exit_if_flagged(_store_status(prepared.out))


def _store_status(path):
    """Every point's status in the store (all batches, resumed ones included)."""
    import zarr

    return zarr.open_array(store=str(path), path="status", mode="r")[...]


def tls_files(ca_file: Path | None, cert: Path | None, key: Path | None):
    """The TLS files of ``--tls-ca-file``/``--tls-cert``/``--tls-key`` (None when none is given; the CA file and
    the certificate go together)."""
    if ca_file is None and cert is None and key is None:
        return None
    from hertzian.core.errors import OptionError
    from hertzian.sweeping.distributed import TlsFiles

    with one_line_errors():
        if ca_file is None or cert is None:
            missing = "tls_ca_file" if ca_file is None else "tls_cert"
            raise OptionError(missing, None, "TLS needs both --tls-ca-file and --tls-cert (and --tls-key)")
    return TlsFiles(str(ca_file), str(cert), None if key is None else str(key))


def report(result: dict, *, resumed: bool) -> str:
    """The one-line report of a sweep's summary: points, batches, device, seconds, rates, status counts, store size."""
    from hertzian.sweeping.planner import format_bytes
    from hertzian.sweeping.sweep_store import status_codes

    if result["batches_run"] == 0:
        return f"nothing to do: all {result['batches']} batches were complete"
    names = status_codes()
    status = ", ".join(f"{names[c].split(':')[0]} {k}" for c, k in result["status_counts"].items())
    batches = f"{result['batches']} batch" + ("es" if result["batches"] != 1 else "")
    ran = f"ran {result['batches_run']} of {batches}" if resumed else batches
    return (
        f"{result['points']} points, {ran} on {result['device']}: {result['seconds']['batches']:.2f} s, "
        f"{result['grain_steps_per_second']:.3g} grain-steps/s (per device "
        f"{result['grain_steps_per_second_per_device']:.3g}); status: {status}; store {format_bytes(result['store_bytes'])}"
    )
