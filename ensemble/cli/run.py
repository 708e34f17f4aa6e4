"""``hertzian run``: one scene to a Zarr store."""

from __future__ import annotations

import contextlib
import importlib
import sys
import threading
from pathlib import Path
from typing import Annotated, Optional

import typer
from hertzian.cli.app import (
    SCENE_HELP,
    DeviceOption,
    KernelOption,
    PrecisionOption,
    SetOption,
    app,
    check_store_out,
    check_timeline_path,
    exit_if_flagged,
    load_scene_or_fail,
    one_line_errors,
)
from hertzian.core import timeline


@app.command()
def run(
    scene: Annotated[
        Optional[Path],
        typer.Argument(help=f"{SCENE_HELP} (1000-grain impact, l0 = 1e-4, v_imp = 1e-2)."),
    ] = None,
    out: Annotated[Path, typer.Option("--out", help="Zarr store to write.")] = Path("hertzian-run.zarr"),
    device: DeviceOption = None,
    precision: PrecisionOption = None,
    set_: SetOption = None,
    overwrite: Annotated[bool, typer.Option("--overwrite", help="Replace an existing store.")] = False,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress bar.")] = False,
    strict: Annotated[
        bool,
        typer.Option(
            "--strict",
            help="Refuse (exit 2) when dt looks unstable or inaccurate (see hertzian check) instead of warning.",
        ),
    ] = False,
    kernel: KernelOption = "auto",
    error_estimate: Annotated[
        bool,
        typer.Option(
            "--error-estimate", help="Estimate the run's position error (record.error_estimate; docs/accuracy.md)."
        ),
    ] = False,
):
    """Run one scene and store it as Zarr (times in program units of 1.0102e-3 s).

    With HERTZIAN_TIMELINE=PATH set, the seconds since process start at each phase are written to PATH as JSON
    (docs/fixed-costs.md)."""
    timeline.mark("cli_ready")
    check_timeline_path()
    loaded = load_scene_or_fail(
        scene, [*(set_ or []), *(["record.error_estimate=true"] if error_estimate else [])], precision
    )
    check_store_out(out, overwrite=overwrite)
    timeline.mark("scene_loaded")
    from hertzian.api import prepare_run  # hz.run's path: the same checks, warnings and tolerance handling

    with one_line_errors():
        prepared = prepare_run([loaded], device, kernel=kernel, strict=strict)
    for line in prepared.notes:
        typer.echo(line, err=True)
    if prepared.runner is None:
        _run_to_tolerance(loaded, prepared, out, overwrite=overwrite)
        return
    store_import = _import_in_background("hertzian.sweeping.sweep_store")
    with _progress_bar(loaded.record_count, shown=not quiet and sys.stderr.isatty()) as progress:
        result = prepared.run(progress)
    timeline.mark("integrated", kernel=result.kernel, seconds_in_run=result.timing)
    store_import.join()
    from hertzian.sweeping.sweep_store import write_result

    timeline.mark("store_imported")
    with one_line_errors():
        write_result(out, result, overwrite=overwrite)
    timeline.mark("store_written")
    typer.echo(_summary(loaded, result, prepared.runner.solver.describe()))
    typer.echo(f"wrote {out}")
    exit_if_flagged(result.status)


def _run_to_tolerance(scene, prepared, out: Path, *, overwrite: bool) -> None:
    """integrator.tolerance: pilot runs choose method and dt (``meet_tolerance``); the chosen run is stored with
    the choice in the store's attributes."""
    from hertzian.sweeping.sweep_store import write_result

    with one_line_errors():
        result = prepared.run()
    choice = prepared.choice
    with one_line_errors():
        write_result(out, result, overwrite=overwrite, attributes=choice.attrs())
    chosen = result.scenes[0].integrator
    typer.echo(
        f"tolerance {chosen.tolerance or scene.integrator.tolerance:g}: {chosen.method} events {chosen.events} "
        f"dt={chosen.dt:g} after {len(choice.pilot)} pilot runs ({sum(p.seconds for p in choice.pilot):.2f} s), "
        f"error estimate {float(result.error_estimate.max()):.2e}, status {int(result.status[0])}"
    )
    typer.echo(f"wrote {out}")
    exit_if_flagged(result.status)


def _import_in_background(module: str) -> threading.Thread:
    """Import ``module`` in a thread (started, to be joined): Zarr's import overlaps the run, whose kernels and waits
    release the GIL. A failed import fails again, with its message, where the module is imported for use."""

    def load() -> None:
        with contextlib.suppress(Exception):
            importlib.import_module(module)

    thread = threading.Thread(target=load, name=f"import {module}", daemon=True)
    thread.start()
    return thread


@contextlib.contextmanager
def _progress_bar(total: int, *, shown: bool):
    """A transient rich bar of records done, as a ``progress(done, total)`` callback (None when not shown)."""
    if not shown:
        yield None
        return
    from rich.progress import BarColumn, Progress, TimeRemainingColumn

    bar = Progress(
        "[progress.description]{task.description}",
        BarColumn(),
        "{task.completed}/{task.total} records",
        TimeRemainingColumn(),
        transient=True,
    )
    bar.start()
    task = bar.add_task("integrating", total=total)
    try:
        yield lambda done, total: bar.update(task, completed=done)
    finally:
        bar.stop()


def _summary(scene, result, kernel: str) -> str:
    """The one line ``hertzian run`` prints: size, steps, device, kernel, speed, energy error, status."""
    estimate = (
        f", error estimate {result.error_estimate[0]:.2e} (+{result.timing['error_estimate']:.2f} s)"
        if result.error_estimate is not None
        else ""
    )
    return (
        f"{scene.chain.grains} grains, {result.steps} steps of {scene.integrator.method} "
        f"dt={scene.integrator.dt:g} on {result.device} ({kernel} kernel): {result.wall_seconds:.2f} s, "
        f"{result.grain_steps_per_second:.3g} grain-steps/s, energy error {result.energy_error[0]:.2e}, "
        f"status {int(result.status[0])}" + estimate
    )
