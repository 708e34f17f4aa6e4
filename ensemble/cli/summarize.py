"""``hertzian summarize``: a table (or JSON) of a store's points."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from .app import app, fail


@app.command()
def summarize(
    store: Annotated[Path, typer.Argument(help="A store written by run or sweep.")],
    as_json: Annotated[bool, typer.Option("--json", help="Print a JSON list of records.")] = False,
):
    """Per point: status, energy error, wall seconds, grain-steps per second."""
    from ..store import summary_records

    try:
        records = summary_records(store)
    except (FileNotFoundError, ValueError, KeyError) as err:
        fail(f"store = {str(store)!r}: {err}")
    if as_json:
        typer.echo(json.dumps(records, indent=1))
        return
    from rich.console import Console
    from rich.table import Table

    if not records:
        typer.echo("no points")
        return
    table = Table(title=f"{store}")
    keys = [k for k in records[0] if k not in ("device", "method", "precision", "dt", "steps", "grains")]
    for k in keys:
        table.add_column(k)
    for rec in records:
        table.add_row(*[f"{rec[k]:.3g}" if isinstance(rec[k], float) else str(rec[k]) for k in keys])
    console = Console(width=160)
    console.print(table)
    first = records[0]
    console.print(f"{len(records)} point(s); {first['grains']} grains, {first['steps']} steps of {first['method']} "
                  f"dt={first['dt']:g} ({first['precision']}) on {first['device']}")
