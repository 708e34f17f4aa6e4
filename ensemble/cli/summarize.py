"""``hertzian summarize``: a table (or JSON) of a store's points."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Optional

import typer
from hertzian.cli.app import app, fail, open_dataset_or_fail


@app.command()
def summarize(
    store: Annotated[Path, typer.Argument(help="A store written by run, sweep or design.")],
    as_json: Annotated[bool, typer.Option("--json", help="Print a JSON list of records (one per point).")] = False,
    rows: Annotated[
        int,
        typer.Option(
            "--rows",
            help="Most points listed in the table; a larger store shows "
            "its status counts and the points with the largest energy error.",
        ),
    ] = 40,
    over: Annotated[
        Optional[str],
        typer.Option(
            "--over",
            help="A sweep dimension (e.g. seed): print as JSON the mean, standard deviation and 5/50/95 % "
            "quantiles over it of per-point impact observables (hertzian.studies.realisations).",
        ),
    ] = None,
):
    """Per point: status, energy error [relative], max overlap [length], wall seconds, grain-steps per second.

    Reads only the per-point variables (never u, v or traces), vectorised over the points; a damaged chunk among
    them stops it with one line (exit 1). ``hertzian verify`` checks every chunk.
    """
    import numpy as np
    from hertzian.studies.design_store import is_design_store
    from hertzian.sweeping.store import StoreDamagedError, summary_columns, unchecked_note
    from hertzian.sweeping.store_format import DAMAGED_EXIT_CODE

    if rows < 1:
        fail(f"--rows = {rows}: must be ≥ 1")
    if is_design_store(store):
        if over is not None:
            fail(f"--over = {over!r}: a design store has no sweep dimensions (summarize it without --over)")
        _summarize_design(store, as_json)
        return
    if over is not None:
        _print_statistics(store, over)
        return
    try:
        columns = summary_columns(store)
        note = unchecked_note(store)
    except StoreDamagedError as err:
        typer.echo(f"error: {err}", err=True)
        raise typer.Exit(DAMAGED_EXIT_CODE) from None
    except (FileNotFoundError, ValueError, KeyError) as err:
        fail(f"store = {str(store)!r}: {err}")
    if note:
        typer.echo(note, err=True)
    count = len(columns["status"])
    if as_json:
        names = list(columns)
        # indented for reading; a large store's list unindented (json's C encoder, ~10× faster)
        typer.echo(
            json.dumps(
                [dict(zip(names, row)) for row in zip(*[columns[n].tolist() for n in names])],
                indent=1 if count <= 1000 else None,
            )
        )
        return
    from rich.console import Console
    from rich.table import Table

    if not count:
        typer.echo("no points")
        return
    scheme = ("device", "method", "precision", "dt", "steps", "grains")
    keys = [k for k in columns if k not in scheme]
    shown = np.arange(count)
    title = f"{store}"
    if count > rows:
        # the points to look at first: not OK, then the largest energy errors
        error = np.where(np.isfinite(columns["energy_error"]), columns["energy_error"], np.inf)
        order = np.lexsort((-error, columns["status"] == 0))
        shown = np.sort(order[:rows])
        title = f"{store}: {rows} of {count} points (not OK first, then the largest energy errors)"
    table = Table(title=title)
    for k in keys:
        table.add_column(k)
    for p in shown:
        table.add_row(
            *[
                f"{v:.3g}" if isinstance(v, float) else str(v)
                for v in (columns[k][p].item() if hasattr(columns[k][p], "item") else columns[k][p] for k in keys)
            ]
        )
    console = Console(width=160)
    console.print(table)
    codes, counts = np.unique(columns["status_name"].astype(str), return_counts=True)
    finite = columns["energy_error"][np.isfinite(columns["energy_error"])]
    console.print(
        f"{count} point(s); {columns['grains'][0]} grains, {columns['steps'][0]} steps of "
        f"{columns['method'][0]} dt={columns['dt'][0]:g} ({columns['precision'][0]}) on "
        f"{columns['device'][0]}"
    )
    console.print(
        "status: "
        + ", ".join(f"{c} {k}" for c, k in zip(codes, counts))
        + (f"; energy error max {finite.max():.3g}, median {np.median(finite):.3g}" if finite.size else "")
    )
    line = _tolerance_line(store)
    if line:
        console.print(line)


def _summarize_design(store: Path, as_json: bool) -> None:
    """A design store: the design, each objective's best so far and the best protector (JSON with ``--json``)."""
    from hertzian.core.errors import OptionError
    from hertzian.studies.design import summary
    from hertzian.sweeping.store_format import DAMAGED_EXIT_CODE, StoreDamagedError

    try:
        numbers = summary(store)
    except StoreDamagedError as err:
        typer.echo(f"error: {err}", err=True)
        raise typer.Exit(DAMAGED_EXIT_CODE) from None
    except (OptionError, KeyError, ValueError) as err:
        fail(f"store = {str(store)!r}: {err}")
    if as_json:
        typer.echo(json.dumps(numbers, indent=1))
        return
    typer.echo(
        f"{store}: design, {numbers['generations_done']} of {numbers['generations']} generations of "
        f"{numbers['population']} candidates ({numbers['optimizer']}, seed {numbers['seed']}), "
        f"{numbers['seconds']:.1f} s"
    )
    if not numbers["generations_done"]:
        return
    best = ", ".join(f"{name} {value:.6g}" for name, value in numbers["best"].items())
    first = numbers["objectives"][0]
    typer.echo(f"best so far: {best}; {first} unchanged since generation {numbers['best_since_generation']}")
    names = list(dict.fromkeys(numbers["best_materials"]))
    letters = [name[0].upper() for name in names]
    if len(set(letters)) < len(letters):
        letters = [str(k) for k in range(len(names))]
    beads = " ".join(
        f"{letters[names.index(m)]}{r:.2f}" for m, r in zip(numbers["best_materials"], numbers["best_radius_ratio"])
    )
    typer.echo(f"best design (material and R/R0 of each varying grain): striker → {beads} → wall")
    typer.echo("  " + ", ".join(f"{letter}: {name}" for letter, name in zip(letters, names)))


def _tolerance_line(store: Path) -> str:
    """How a run to ``integrator.tolerance`` chose its step (the store's attributes), or '' for any other store."""
    import zarr

    attrs = zarr.open_group(str(store), mode="r").attrs
    if "tolerance_choice" not in attrs:
        return ""
    choice, pilot = attrs["tolerance_choice"], attrs.get("tolerance_pilot", [])
    return (
        f"tolerance {attrs['tolerance']:g}: {choice['method']}, events {choice['events']}, dt {choice['dt']:g}, chosen "
        f"by {len(pilot)} pilot runs ({sum(run['seconds'] for run in pilot):.2f} s)"
    )


def _print_statistics(store: Path, over: str) -> None:
    from hertzian.studies.realisations import statistics_json

    dataset = open_dataset_or_fail(store)
    try:
        numbers = statistics_json(dataset, over)
    except ValueError as err:
        fail(str(err))
    typer.echo(json.dumps({"store": str(store), **numbers}, indent=1))
