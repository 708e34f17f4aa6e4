"""``hertzian accuracy``: the work–precision study of one scene (see ensemble/studies/accuracy.py; numbers in
docs/stability.md)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Annotated, Optional

import typer
from hertzian.cli.app import DeviceOption, SceneArgument, SetOption, app, fail, load_scene_or_fail, resolve_device
from hertzian.core.scene import METHODS, SceneError


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
    methods: Annotated[
        str, typer.Option("--methods", help="Comma-separated methods, e.g. gear4,verlet.")
    ] = "gear4,gear5,gear6,verlet",
    dt: Annotated[
        str,
        typer.Option(
            "--dt",
            help="Comma-separated steps [program time]; each and the "
            "reference's must divide a common record interval, e.g. 2e-4,1e-4,5e-5.",
        ),
    ] = "2e-4,1e-4,5e-5",
    precision: Annotated[
        Optional[str], typer.Option("--precision", help="float64 | float32 | both (default: the scene's).")
    ] = None,
    reference_factor: Annotated[
        int, typer.Option("--reference-factor", help="Reference step = smallest --dt / this (gear6, float64).")
    ] = 4,
    records: Annotated[
        int,
        typer.Option(
            "--records",
            help="About this many snapshots are compared (the record interval is a common multiple of all steps).",
        ),
    ] = 40,
    events: Annotated[
        Optional[str],
        typer.Option(
            "--events",
            help="auto | off | both: event-aware Gear steps "
            "near contacts that open or close (integrator.events); both: "
            "before/after curves (default: the scene's).",
        ),
    ] = None,
    kernel: Annotated[
        Optional[str],
        typer.Option(
            "--kernel",
            help="Kernel for every run (auto | step | tile | window | chain); default: chain on a CPU, auto on a GPU.",
        ),
    ] = None,
    target: Annotated[
        Optional[list[str]],
        typer.Option(
            "--target",
            help="Accuracy target(s), repeatable or comma-separated, e.g. 1e-6,1e-8: per method and "
            "precision, the largest --dt meeting each (on --measure; only the steps studied, not interpolated) and "
            "the wall seconds of that run, cheapest first; 'none' when no step meets it.",
        ),
    ] = None,
    measure: Annotated[
        str,
        typer.Option(
            "--measure",
            help="What --target bounds: energy (default; the energy "
            "error max |E(t) − E(0)| / E_inj) | error (max |u − u_ref| / "
            "max|u_ref|).",
        ),
    ] = "energy",
    as_json: Annotated[
        bool,
        typer.Option(
            "--json", help="Print a JSON list of records (with --target: an object with 'records' and 'targets')."
        ),
    ] = False,
    plot: Annotated[
        Optional[Path],
        typer.Option("--plot", help="Draw error and energy error against wall seconds (log–log) into this PNG."),
    ] = None,
    device: DeviceOption = None,
    set_: SetOption = None,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress lines on stderr.")] = False,
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
    from hertzian.studies.accuracy import (
        TARGET_MEASURES,
        parse_list,
        parse_steps,
        parse_targets,
        plot_work_precision,
        time_to_target,
        work_precision,
    )

    loaded = load_scene_or_fail(scene, set_, None)
    try:
        method_list = parse_list("--methods", methods, METHODS)
        steps = parse_steps(dt)
        targets = parse_targets(target or [])
        if measure not in TARGET_MEASURES:
            raise SceneError("--measure", measure, f"allowed: {', '.join(TARGET_MEASURES)}")
        if precision is None:
            precisions = [loaded.integrator.precision]
        elif precision == "both":
            precisions = ["float64", "float32"]
        elif precision in ("float64", "float32"):
            precisions = [precision]
        else:
            raise SceneError("--precision", precision, "allowed: float64, float32, both")
        if events is None:
            event_modes = [loaded.integrator.events]
        elif events == "both":
            event_modes = ["auto", "off"]
        elif events in ("auto", "off"):
            event_modes = [events]
        else:
            raise SceneError("--events", events, "allowed: auto, off, both")
        if reference_factor < 1:
            raise SceneError("--reference-factor", reference_factor, "must be an integer ≥ 1")
        if records < 1:
            raise SceneError("--records", records, "must be ≥ 1")
        from hertzian.core.solvers import KERNELS

        if kernel is not None and kernel not in KERNELS:
            raise SceneError("--kernel", kernel, f"allowed: {', '.join(KERNELS)}")
    except SceneError as err:
        fail(str(err))
    if plot is not None and not plot.parent.exists():
        fail(f"--plot = {str(plot)!r}: parent directory does not exist")
    dev = resolve_device(device)

    def progress(text: str) -> None:
        if not quiet:
            typer.echo(f"running {text}", err=True)

    try:
        results, reference, every = work_precision(
            loaded,
            method_list,
            steps,
            precisions,
            device=dev,
            reference_factor=reference_factor,
            records=records,
            kernel=kernel,
            progress=progress,
            events=event_modes,
        )
    except SceneError as err:
        fail(str(err))
    except ValueError as err:  # a forced --kernel that cannot run these features or on this device
        fail(f"--kernel = {kernel!r}: {err}")
    grains = loaded.chain.grains
    note = (
        f"reference: gear6 float64 dt = {reference.dt:g}, estimated error {_number(reference.error_estimate)} "
        f"(Richardson from dt, 2dt, 4dt; observed order {_number(reference.observed_order)}), "
        f"{reference.seconds:.2f} s; snapshots every {every:g} over {loaded.integrator.duration:g}; "
        f"{grains} grains on {dev}, kernel {results[0].kernel if results else '?'}"
    )
    limited = [r for r in results if r.reference_limited]
    reached = time_to_target(results, targets, measure) if targets else []
    if plot is not None:
        plot_work_precision(
            results,
            plot,
            reference_error=reference.error_estimate,
            title=(
                f"{grains} grains, duration {loaded.integrator.duration:g}, v_imp {loaded.excitation.impact:g}, "
                f"l0 {loaded.chain.l0:g}, on {dev} (kernel {results[0].kernel}); reference gear6 float64 "
                f"dt = {reference.dt:g}, estimated error {_number(reference.error_estimate)}; labels: dt"
            ),
        )
    if as_json:
        rows = [
            {**r.to_dict(), "reference_dt": reference.dt, "reference_error": reference.error_estimate} for r in results
        ]
        typer.echo(
            json.dumps({"records": rows, "targets": [t.to_dict() for t in reached]} if targets else rows, indent=1)
        )
    else:
        from rich.console import Console
        from rich.table import Table

        table = Table(title=f"{scene or 'built-in example'}: error against run time")
        for col in (
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
        ):
            table.add_column(col, justify="left" if col in ("method", "precision", "events", "status") else "right")
        for r in results:
            error = _number(r.error) + (" *" if r.reference_limited else "")
            table.add_row(
                r.method,
                r.precision,
                r.events,
                f"{r.dt:g}",
                f"{r.steps_per_contact_time:.3g}",
                error,
                _number(r.energy_error),
                f"{r.seconds:.3g}",
                f"{r.grain_steps_per_second:.3g}",
                r.status_name,
            )
        console = Console(width=140)
        console.print(table)
        console.print(note)
        if limited:
            console.print(
                "* within a factor 10 of the reference's own estimated error: not resolved; "
                "use a larger --reference-factor"
            )
        if targets:
            console.print(_target_table(reached, measure, several_events=len({r.events for r in results}) > 1))
    if limited and as_json and not quiet:
        typer.echo(
            f"warning: {len(limited)} record(s) are within a factor 10 of the reference's estimated error "
            "(reference_limited); use a larger --reference-factor",
            err=True,
        )
    if plot is not None and not quiet:
        typer.echo(f"wrote {plot}", err=True)
