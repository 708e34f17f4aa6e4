"""``hertzian accuracy``: the work–precision study of one scene (:mod:`hertzian.studies.accuracy`; numbers in
docs/stability.md)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Annotated, Optional

import typer
from hertzian.cli.app import (
    DeviceOption,
    SceneArgument,
    SetOption,
    app,
    check_output_file,
    fail,
    load_scene_or_fail,
    resolve_device,
)
from hertzian.core.scene import SceneError

MethodsOption = Annotated[str, typer.Option("--methods", help="Comma-separated methods, e.g. gear4,verlet.")]

DtOption = Annotated[
    Optional[str],
    typer.Option(
        "--dt",
        help="Comma-separated steps [program time]; each and the "
        "reference's must divide a common record interval, e.g. 2e-4,1e-4,5e-5. "
        "Default: twice, once and half the scene's dt.",
    ),
]

StudyPrecisionOption = Annotated[
    Optional[str], typer.Option("--precision", help="float64 | float32 | both (default: the scene's).")
]

ReferenceFactorOption = Annotated[
    int, typer.Option("--reference-factor", help="Reference step = smallest --dt / this (gear6, float64).")
]

RecordsOption = Annotated[
    int,
    typer.Option(
        "--records",
        help="About this many snapshots are compared (the record interval is a common multiple of all steps).",
    ),
]

StudyEventsOption = Annotated[
    Optional[str],
    typer.Option(
        "--events",
        help="auto | off | both: event-aware Gear steps "
        "near contacts that open or close (integrator.events); both: "
        "before/after curves (default: the scene's).",
    ),
]

StudyKernelOption = Annotated[
    Optional[str],
    typer.Option(
        "--kernel",
        help="Kernel for every run (auto | step | tile | window | chain); default: chain on a CPU, auto on a GPU.",
    ),
]

TargetOption = Annotated[
    Optional[list[str]],
    typer.Option(
        "--target",
        help="Accuracy target(s), repeatable or comma-separated, e.g. 1e-6,1e-8: per method and "
        "precision, the largest --dt meeting each (on --measure; only the steps studied, not interpolated) and "
        "the wall seconds of that run, cheapest first; 'none' when no step meets it.",
    ),
]

MeasureOption = Annotated[
    str,
    typer.Option(
        "--measure",
        help="What --target bounds: energy (default; the energy "
        "error max |E(t) − E(0)| / E_inj) | error (max |u − u_ref| / "
        "max|u_ref|).",
    ),
]

AsJsonOption = Annotated[
    bool,
    typer.Option(
        "--json", help="Print a JSON list of records (with --target: an object with 'records' and 'targets')."
    ),
]

PlotOption = Annotated[
    Optional[Path],
    typer.Option("--plot", help="Draw error and energy error against wall seconds (log–log) into this PNG."),
]

QuietOption = Annotated[bool, typer.Option("--quiet", help="No progress lines on stderr.")]

RECORD_COLUMNS = (
    "method",
    "precision",
    "events",
    "dt",
    "steps/T",
    "error",
    "energy error",
    "seconds",
    "grain-steps/s",
    "status",
)
"""Columns of the records table, in order."""


def _number(value: float) -> str:
    return f"{value:.3g}" if math.isfinite(value) else str(value)


def _target_table(reached, measure: str, *, several_events: bool):
    """The rich table of ``--target``: per target, method and precision, cheapest first."""
    from rich.table import Table

    name = "energy error" if measure == "energy" else "error"
    table = Table(title=f"time to accuracy ({name} ≤ target): largest studied dt, cheapest first")
    columns = (
        ["target", "method", "precision"]
        + (["events"] if several_events else [])
        + ["dt", "seconds", "error", "energy error"]
    )
    for col in columns:
        table.add_column(col, justify="left" if col in ("method", "precision", "events") else "right")
    for t in reached:
        row = [f"{t.target:g}", t.method, t.precision] + ([t.events] if several_events else [])
        if t.dt is None:
            row += ["none", "", "", ""]
        else:
            row += [
                f"{t.dt:g}",
                f"{t.seconds:.3g}",
                _number(t.error) + (" *" if t.reference_limited else ""),
                _number(t.energy_error),
            ]
        table.add_row(*row)
    return table


@app.command()
def accuracy(
    scene: SceneArgument = None,
    methods: MethodsOption = "gear4,gear5,gear6,verlet",
    dt: DtOption = None,
    precision: StudyPrecisionOption = None,
    reference_factor: ReferenceFactorOption = 4,
    records: RecordsOption = 40,
    events: StudyEventsOption = None,
    kernel: StudyKernelOption = None,
    target: TargetOption = None,
    measure: MeasureOption = "energy",
    as_json: AsJsonOption = False,
    plot: PlotOption = None,
    device: DeviceOption = None,
    set_: SetOption = None,
    quiet: QuietOption = False,
):
    """Work–precision study: error and energy error against wall seconds per method, step and precision.

    The error of a run is max over records and grains of |u − u_ref| / max|u_ref|, against the same
    scene run with gear6 in float64 at a step --reference-factor times below the smallest --dt
    (gear6 has the highest order; its own error is estimated by Richardson extrapolation from
    runs at 1, 2 and 4 times the reference step and printed). Times in program units
    (1.0102e-3 s); seconds are wall seconds without compilation.

    With --target (e.g. 1e-6,1e-8) it also gives, per method and precision, the largest --dt whose run
    ended OK with its --measure (default: energy error) at or below each target, and that run's wall
    seconds — time to accuracy, cheapest first; 'none' where no studied step meets the target.
    """
    from hertzian.studies.accuracy import study_request, time_to_target

    loaded = load_scene_or_fail(scene, set_, None)
    try:
        request = study_request(
            loaded,
            methods=methods,
            dt=dt,
            precision=precision,
            events=events,
            targets=target,
            measure=measure,
            reference_factor=reference_factor,
            records=records,
            kernel=kernel,
        )
    except SceneError as err:
        fail(str(err))
    check_output_file("--plot", plot)
    dev = resolve_device(device)

    results, reference, every = _run_study(loaded, request, dev, quiet=quiet)
    reached = time_to_target(results, request.targets, measure) if request.targets else []
    if plot is not None:
        _plot(results, reference, loaded, dev, plot)
    if as_json:
        _print_json(results, reference, reached, with_targets=bool(request.targets))
    else:
        _print_tables(
            results,
            reference,
            reached,
            request,
            title=f"{scene or 'built-in example'}",
            note=_note(results, reference, every, loaded, dev),
        )
    limited = [r for r in results if r.reference_limited]
    if limited and as_json and not quiet:
        typer.echo(
            f"warning: {len(limited)} record(s) are within a factor 10 of the reference's estimated error "
            "(reference_limited); use a larger --reference-factor",
            err=True,
        )
    if plot is not None and not quiet:
        typer.echo(f"wrote {plot}", err=True)


def _run_study(scene, request, device: str, *, quiet: bool):
    """(records, reference, record interval) of :func:`work_precision` for ``request``; refusals → ``fail``."""
    from hertzian.studies.accuracy import work_precision

    def progress(text: str) -> None:
        if not quiet:
            typer.echo(f"running {text}", err=True)

    try:
        return work_precision(
            scene,
            request.methods,
            request.dts,
            request.precisions,
            device=device,
            reference_factor=request.reference_factor,
            records=request.records,
            kernel=request.kernel,
            progress=progress,
            events=request.events,
        )
    except SceneError as err:
        fail(str(err))
    except ValueError as err:  # a forced --kernel that cannot run these features or on this device
        fail(f"--kernel = {request.kernel!r}: {err}")


def _note(results, reference, every: float, scene, device: str) -> str:
    """The line under the table: the reference, its estimated error and the run's setting."""
    return (
        f"reference: gear6 float64 dt = {reference.dt:g}, estimated error {_number(reference.error_estimate)} "
        f"(Richardson from dt, 2dt, 4dt; observed order {_number(reference.observed_order)}), "
        f"{reference.seconds:.2f} s; snapshots every {every:g} over {scene.integrator.duration:g}; "
        f"{scene.chain.grains} grains on {device}, kernel {results[0].kernel if results else '?'}"
    )


def _plot(results, reference, scene, device: str, path: Path) -> None:
    """``--plot``: the work–precision figure, titled with the scene and the reference."""
    from hertzian.studies.accuracy import plot_work_precision

    plot_work_precision(
        results,
        path,
        reference_error=reference.error_estimate,
        title=(
            f"{scene.chain.grains} grains, duration {scene.integrator.duration:g}, v_imp {scene.excitation.impact:g}, "
            f"l0 {scene.chain.l0:g}, on {device} (kernel {results[0].kernel}); reference gear6 float64 "
            f"dt = {reference.dt:g}, estimated error {_number(reference.error_estimate)}; labels: dt"
        ),
    )


def _print_json(results, reference, reached, *, with_targets: bool) -> None:
    """``--json``: the records (with the reference's step and error), and the targets when asked."""
    rows = [{**r.to_dict(), "reference_dt": reference.dt, "reference_error": reference.error_estimate} for r in results]
    typer.echo(
        json.dumps({"records": rows, "targets": [t.to_dict() for t in reached]} if with_targets else rows, indent=1)
    )


def _print_tables(results, reference, reached, request, *, title: str, note: str) -> None:
    """The rich table of the records, the note, the reference-limited footnote and the ``--target`` table."""
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"{title}: error against run time")
    for col in RECORD_COLUMNS:
        table.add_column(col, justify="left" if col in ("method", "precision", "events", "status") else "right")
    for r in results:
        table.add_row(
            r.method,
            r.precision,
            r.events,
            f"{r.dt:g}",
            f"{r.steps_per_contact_time:.3g}",
            _number(r.error) + (" *" if r.reference_limited else ""),
            _number(r.energy_error),
            f"{r.seconds:.3g}",
            f"{r.grain_steps_per_second:.3g}",
            r.status_name,
        )
    console = Console(width=140)
    console.print(table)
    console.print(note)
    if any(r.reference_limited for r in results):
        console.print(
            "* within a factor 10 of the reference's own estimated error: not resolved; use a larger --reference-factor"
        )
    if request.targets:
        several_events = len({r.events for r in results}) > 1
        console.print(_target_table(reached, request.measure, several_events=several_events))
