"""``hertzian verify``: read every chunk of a store, checksums checked, and name what is damaged."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from hertzian.cli.app import app, fail


@app.command()
def verify(store: Annotated[Path, typer.Argument(help="A store written by run, sweep or design.")]):
    """Read every chunk (each carries a CRC-32C) and print one line per damaged one: variable, sweep point(s) by
    coordinate, batch. Exit 0 if none is damaged, 1 otherwise; ``sweep --resume`` reruns the damaged batches."""
    from hertzian.studies.design_store import is_design_store
    from hertzian.sweeping.integrity import damage_lines, verify_store
    from hertzian.sweeping.manifest import is_project_store
    from hertzian.sweeping.storage import MANIFEST
    from hertzian.sweeping.store import open_store
    from hertzian.sweeping.store_format import DAMAGED_EXIT_CODE

    if is_design_store(store):
        _verify_design(store)
        return
    try:
        if not is_project_store(store):  # a store from before manifests, or not a hertzian store at all
            open_store(store, check=False)
        verification = verify_store(store)
    except (FileNotFoundError, ValueError, KeyError) as err:
        fail(f"store = {str(store)!r}: {err}")
    if verification.unchecked:
        typer.echo(
            f"note: {store} has no {'manifest' if MANIFEST in verification.unchecked else 'chunk checksums'} "
            f"(written by an older version): {', '.join(verification.unchecked[:4])} may read silently when damaged",
            err=True,
        )
    for line in damage_lines(store, verification):
        typer.echo(f"damaged: {line}")
    count = len(verification.damage)
    batches = sorted(verification.damaged_batches)
    typer.echo(
        f"{store}: {verification.chunks} chunks read, {count} damaged"
        + (
            f" (batches {', '.join(map(str, batches))}: rerun with hertzian sweep SWEEP --out {store} --resume)"
            if batches
            else ""
        ),
        err=count > 0,
    )
    if count:
        raise typer.Exit(DAMAGED_EXIT_CODE)


def _verify_design(store: Path) -> None:
    """A design store: every chunk of every generation read, one line per damaged one; exit 1 if any is."""
    from hertzian.studies.design_store import verify_design
    from hertzian.sweeping.store_format import DAMAGED_EXIT_CODE

    try:
        verification = verify_design(store)
    except (FileNotFoundError, ValueError, KeyError) as err:
        fail(f"store = {str(store)!r}: {err}")
    if verification["unchecked"]:
        typer.echo(
            f"note: {store} has no chunk checksums (written by an older version): "
            f"{', '.join(verification['unchecked'])} may read silently when damaged",
            err=True,
        )
    for line in verification["damaged"]:
        typer.echo(f"damaged: {line}")
    count = len(verification["damaged"])
    typer.echo(
        f"{store}: {verification['chunks']} chunks read, {count} damaged"
        + (f" (rerun the design with --out {store} --overwrite)" if count else ""),
        err=count > 0,
    )
    if count:
        raise typer.Exit(DAMAGED_EXIT_CODE)
