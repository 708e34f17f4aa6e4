"""``hertzian reproduce``: the paper's figure groups, each a store, PNGs and a line in a JSON log."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer
from hertzian.cli.app import DeviceOption, app, check_output_file, command_line, fail, resolve_device

FigureOption = Annotated[
    Optional[list[str]],
    typer.Option(
        "--figure",
        help="A figure group or figure (fig1, fig1d, fig2, fig3, fig3_load, fig4, fig5, fig5_single, "
        "fig5_modes or modes, fig6, depth, fig7_8, fig7_8_single, fig7_8_slow, finite_g, fig9_10 or fig9/fig10, "
        "sec6_lag); repeatable. "
        "Default: every group.",
    ),
]

QuickOption = Annotated[
    bool,
    typer.Option(
        "--quick",
        help="Short chains and times: the whole paper in minutes on a "
        "CPU (a test of the pipeline, not the paper's numbers).",
    ),
]

OutDirOption = Annotated[Path, typer.Option("--out-dir", help="Folder for the stores, PNGs and log.json.")]

SweepsOption = Annotated[
    Optional[Path],
    typer.Option("--sweeps", help="Folder of the paper_*.toml sweep files (default: the repository's sweeps/)."),
]

DriveGrainsOption = Annotated[
    Optional[int],
    typer.Option(
        "--drive-grains",
        help="Length of the driven column of "
        "Figs. 9-10 (default 10000; 300 with --quick); the paper's "
        "times scale with the travel time, N^(5/6).",
    ),
]

GroupEventsOption = Annotated[
    Optional[str],
    typer.Option(
        "--events",
        help="auto | off: integrator.events for every group "
        "(default: as each sweep file says, plain Gear steps; auto = "
        "event-aware steps, a smaller energy error at 2-27x the GPU time, "
        "docs/reproduction.md).",
    ),
]

MeasureOption = Annotated[
    Optional[list[str]],
    typer.Option(
        "--measure",
        help="Instead of figure groups, a measurement with no figure (hertzian.studies.measures): "
        "daggers (every item of docs/records/reproduction/daggers_cpu.json), one of its items, or settle "
        "(reduces OUT_DIR/tau10.zarr, tau1.zarr and their _half twins), or groups (re-measures the figure-group "
        "stores a reproduction wrote in OUT_DIR, or in OUT_DIR/GROUP each, and writes --json whole: "
        "docs/records/reproduction/measurements.json); repeatable. Needs --json.",
    ),
]
MeasureRecordOption = Annotated[
    Optional[Path],
    typer.Option(
        "--json",
        help="With --measure: the JSON record the items are merged into (created if missing). With figure groups: "
        "the record of their measurements, written after the runs (as --measure groups writes it).",
    ),
]
GroupKernelOption = Annotated[
    Optional[str],
    typer.Option(
        "--kernel",
        help="auto | fused | step | tile | window | chain for "
        "every figure group's sweep (default, per group: fused on a GPU "
        "where the group takes plain Gear steps, so the short groups run "
        "on the fused kernels; "
        "else auto).",
    ),
]


@app.command()
def reproduce(
    figure: FigureOption = None,
    quick: QuickOption = False,
    out_dir: OutDirOption = Path("reproduce_out"),
    sweeps: SweepsOption = None,
    drive_grains: DriveGrainsOption = None,
    events: GroupEventsOption = None,
    kernel: GroupKernelOption = None,
    measure: MeasureOption = None,
    record: MeasureRecordOption = None,
    device: DeviceOption = None,
):
    """Run Sen, Manciu & Wright (1998)'s figure groups: per group a Zarr store, its figures as PNGs, and in
    OUT_DIR/log.json the device, wall seconds, grain-steps per second and largest energy error of every run.
    Full size needs a GPU for Figs. 9–10 (8e10 grain-steps); --quick runs everything small on a CPU."""
    from hertzian.studies.reproduce import GROUPS, default_sweeps_dir, group_of
    from hertzian.studies.reproduce import reproduce as run_all

    groups = []
    for name in figure or []:
        try:
            group = group_of(name)
        except ValueError as err:
            fail(f"--figure = {name!r}: {err}")
        if group not in groups:
            groups.append(group)
    sweeps_dir = sweeps or default_sweeps_dir()
    missing = [g for g in (groups or GROUPS) if not (sweeps_dir / GROUPS[g].sweep).is_file()]
    if missing:
        fail(
            f"--sweeps = {str(sweeps_dir)!r}: no {GROUPS[missing[0]].sweep} there (a folder of the paper_*.toml "
            "sweep files)"
        )
    if out_dir.exists() and not out_dir.is_dir():
        fail(f"--out-dir = {str(out_dir)!r}: exists and is not a folder")
    if not out_dir.parent.exists():
        fail(f"--out-dir = {str(out_dir)!r}: parent directory does not exist")
    if drive_grains is not None and drive_grains < 10:
        fail(f"--drive-grains = {drive_grains}: at least 10 grains")
    if events is not None and events not in ("auto", "off"):
        fail(f"--events = {events!r}: auto or off")
    from hertzian.core.solvers import KERNELS

    if kernel is not None and kernel not in KERNELS:
        fail(f"--kernel = {kernel!r}: one of {', '.join(KERNELS)}")
    dev = resolve_device(device)
    if measure:
        return _measure(measure, record, out_dir, dev)
    if record is not None and not (record.parent.resolve() == out_dir.resolve() and not out_dir.exists()):
        check_output_file("--json", record)  # (a record in the --out-dir the run makes has nothing in its way)
    if kernel == "chain" and dev != "cpu":
        fail(f"--kernel = 'chain': a CPU kernel; --device = {dev!r}")
    if kernel in ("tile", "window") and dev == "cpu":
        fail(f"--kernel = {kernel!r}: CUDA kernels; on --device cpu use auto, fused, step or chain")
    _check_outputs(out_dir, [g for g in GROUPS if g in groups] or list(GROUPS))
    log = run_all(
        out_dir,
        groups=[g for g in GROUPS if g in groups] or None,
        quick=quick,
        device=dev,
        sweeps_dir=sweeps_dir,
        drive_grains=drive_grains,
        events=events,
        kernel=kernel,
        say=typer.echo,
    )
    typer.echo(f"wrote {out_dir}/log.json ({len(log['runs'])} runs, {log['total_seconds']:.0f} s)")
    if record is not None:
        _write_measurements(record, out_dir)
    if log["figure_failures"]:
        typer.echo(f"error: {log['figure_failures']} figure(s) could not be drawn (see log.json)", err=True)
        raise typer.Exit(1)


def _check_outputs(out_dir: Path, names: list[str]) -> None:
    """Refuse (exit 2), before anything runs, an ``--out-dir`` where a store or file that reproducing ``names``
    writes is in the way and hertzian did not write it."""
    from hertzian.core.errors import OptionError
    from hertzian.studies.reproduce import outputs
    from hertzian.sweeping.storage import check_out

    if not out_dir.is_dir():
        return  # made by the run: nothing in the way
    stores, files = outputs(names)
    for store in stores:
        try:
            check_out(out_dir / store, overwrite=True)
        except OptionError as err:
            fail(f"--out-dir = {str(out_dir)!r}: {store} in it: {err.allowed.split('; --overwrite')[0]}")
    for file in files:
        check_output_file("--out-dir", out_dir / file)


def _measure(names: list[str], record: Path | None, out_dir: Path, device: str) -> None:
    """``--measure``: run the named items of hertzian.studies.measures into the record ``--json``."""
    import sys

    from hertzian.studies.measures import DAGGERS, MEASURES, measure_items

    allowed = ("daggers", "groups", *MEASURES)
    for name in names:
        if name not in allowed:
            fail(f"--measure = {name!r}: one of {', '.join(allowed)}")
    if record is None:
        fail("--measure: needs --json RECORD (the JSON file the items are written into)")
    if not record.parent.is_dir():
        fail(f"--json = {str(record)!r}: parent directory does not exist")
    if "groups" in names:
        return _measure_groups(names, record, out_dir)
    items = [item for name in names for item in (DAGGERS if name == "daggers" else (name,))]
    command = "hertzian " + " ".join(sys.argv[1:])
    measure_items(list(dict.fromkeys(items)), record, out_dir, device, command=command, say=typer.echo)
    typer.echo(f"wrote {record}")


def _measure_groups(names: list[str], record: Path, out_dir: Path) -> None:
    """``--measure groups``: the figure-group stores in ``out_dir`` re-measured into the record ``--json``, whole."""
    from hertzian.studies.reproduce import group_runs

    if names != ["groups"]:
        fail("--measure = 'groups': alone (it writes --json whole; the other items are merged into a record)")
    if not group_runs(out_dir):
        fail(
            f"--out-dir = {str(out_dir)!r}: no figure-group stores with their log.json "
            "(hertzian reproduce --figure GROUP --out-dir writes them)"
        )
    check_output_file("--json", record)
    _write_measurements(record, out_dir)


def _write_measurements(record: Path, out_dir: Path) -> None:
    """The figure-group stores in ``out_dir`` measured into the record ``record`` (hertzian.studies.reproduce)."""
    import json

    from hertzian.studies.reproduce import measure_stores

    log = measure_stores(out_dir, command=command_line())
    record.write_text(json.dumps(log, indent=1) + "\n")
    typer.echo(f"wrote {record} ({len(log['groups'])} figure groups measured)")
