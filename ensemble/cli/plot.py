"""``hertzian plot``: a picture of any store, or one figure group of Sen, Manciu & Wright (1998), as a PNG."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Optional

import typer
from hertzian.cli.app import app, fail, open_dataset_or_fail


def _parse_at(items: list[str] | None) -> dict[str, float | str]:
    """``axis=value`` items: a number, or a word for an axis of names (a law, a material)."""
    at: dict[str, float | str] = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip() or not value.strip():
            fail(f"--at = {item!r}: must be written axis=value, e.g. --at v_imp=0.01 or --at law=fput")
        try:
            at[key.strip()] = float(value)
        except ValueError:
            at[key.strip()] = value.strip()
            continue
        if not math.isfinite(at[key.strip()]):
            fail(f"--at = {item!r}: the value must be a finite number")
    return at


@app.command()
def plot(
    store: Annotated[
        Path, typer.Argument(help="A store written by `hertzian run`, `hertzian sweep` or `hertzian reproduce`.")
    ],
    figure: Annotated[
        Optional[str],
        typer.Option(
            "--figure",
            help="A paper figure group instead of the store picture: fig1 | fig1d | fig2 | fig3 | fig4 | "
            "fig5 | modes | fig6 | depth | fig7_8 | fig9 | fig10 (the store must hold that figure's sweep); drive_map: the "
            "response map of a drive sweep (docs/drive.md), its numbers also written as JSON next to the PNG; standing: "
            "the standing fraction of a drive sweep (forward and backward waves at the drive frequency), also as JSON; "
            "distribution: a histogram of one observable (--of) over the store's points (docs/heterogeneous.md).",
        ),
    ] = None,
    field: Annotated[str, typer.Option("--field", help="u | v: the field of the depth–time picture.")] = "v",
    at: Annotated[
        Optional[list[str]],
        typer.Option(
            "--at",
            help="Which point of a sweep store: axis=value, the nearest coordinate of a number axis or the name on "
            "an axis of names such as law=fput (repeatable; default: the first along each axis).",
        ),
    ] = None,
    of: Annotated[
        Optional[str],
        typer.Option("--of", help="With --figure distribution: the observable whose histogram is drawn."),
    ] = None,
    out: Annotated[
        Optional[Path],
        typer.Option("--out", help="PNG file to write (default: STORE's name with .png, or FIGURE.png)."),
    ] = None,
):
    """Draw a store: the depth–time picture of u or v, the traced grains and the energy error of one point
    (program units: length 1e-5 m, time 1.0102e-3 s; the store's sign, + into the chain). With --figure,
    a paper figure group in the paper's representation (profiles in the paper's sign, + toward the surface)."""
    from hertzian.plotting.figures import FIGURES, PlotError, not_this_figure, plot_figure, plot_store

    if figure == "distribution":
        return _plot_distribution(store, of, out)
    if figure is not None and figure not in FIGURES:
        fail(f"--figure = {figure!r}: allowed: {', '.join(FIGURES)}")
    if field not in ("u", "v"):
        fail(f"--field = {field!r}: u or v")
    points = _parse_at(at)
    if not store.exists():
        fail(f"store = {str(store)!r}: no such store")
    if out is None:
        out = Path(f"{figure}.png") if figure else Path(store.name).with_suffix(".png")
    if out.suffix.lower() != ".png":
        fail(f"--out = {str(out)!r}: must end in .png")
    from hertzian.core.outputs import why_not_replaceable
    from hertzian.studies.design_store import is_design_store
    from hertzian.sweeping.storage import check_writable_folder

    why = check_writable_folder(out)
    if why:
        fail(f"--out = {str(out)!r}: {why}")
    design = is_design_store(store)
    for target in (out, out.with_suffix(".json")) if design or figure in ("drive_map", "standing") else (out,):
        why = why_not_replaceable(target)
        if why:
            fail(f"--out = {str(out)!r}: {target} {why}")
    if design:
        if figure is not None or points:
            fail(f"store = {str(store)!r}: a design store; plot it without --figure and --at")
        return _plot_design(store, out)

    dataset = open_dataset_or_fail(store)
    what = f"--figure = {figure!r}" if figure else f"store = {str(store)!r}"
    try:
        if figure == "drive_map":
            import json

            from hertzian.studies import analysis as an

            numbers = an.response_map(dataset)
            rows = [
                {
                    **{d: float(numbers["coords"][d][i]) for d, i in zip(numbers["dims"], index)},
                    **{m: float(numbers[m][index]) for m in an.MAP_METRICS},
                    "label_name": an.LABELS[int(numbers["label"][index])]
                    if numbers["label"][index] == numbers["label"][index]
                    else None,
                }
                for index in __import__("numpy").ndindex(*numbers["label"].shape)
            ]
            record = {"command": f"hertzian plot {store} --figure {figure} --out {out}", "store": str(store)}
            out.with_suffix(".json").write_text(json.dumps({**record, "points": rows}, indent=1))
        if figure == "standing":
            import json

            from hertzian.studies import analysis as an

            numbers = {
                "command": f"hertzian plot {store} --figure {figure} --out {out}",
                **an.store_provenance(dataset, store),
                "points": an.standing_fractions(dataset),
            }
            out.with_suffix(".json").write_text(json.dumps(numbers, indent=1))
        if figure:
            plot_figure(dataset, figure, out)
        else:
            plot_store(dataset, out, field=field, at=points, notify=lambda line: typer.echo(line, err=True))
    except PlotError as err:
        fail(f"{what}: {err}")
    except (KeyError, IndexError, ValueError, TypeError, AttributeError):  # a store of another sweep than the figure's
        fail(f"{what}: {not_this_figure(dataset, figure) if figure else 'cannot draw this store'}")
    typer.echo(f"wrote {out}")


def _plot_design(store: Path, out: Path) -> None:
    """A design store's picture, and its numbers as JSON next to the PNG (hertzian.studies.design.compare)."""
    import json

    from hertzian.cli.app import resolve_device
    from hertzian.plotting.design import plot_design
    from hertzian.studies.design import compare
    from hertzian.sweeping.store_format import StoreDamagedError

    try:
        summary = compare(store, resolve_device(None))
    except StoreDamagedError as err:
        fail(str(err))
    plot_design(summary, out)
    record = {"command": f"hertzian plot {store.name} --out {out.name}"}
    record |= {k: v for k, v in summary.items() if k != "traces"}
    out.with_suffix(".json").write_text(json.dumps(record, indent=1) + "\n")
    typer.echo(f"wrote {out} and {out.with_suffix('.json')}")


def _plot_distribution(store: Path, of: str | None, out: Path | None) -> None:
    from hertzian.studies.realisations import SCALAR_OBSERVABLES, plot_distribution

    if of is None:
        fail(f"--figure distribution needs --of: one of {', '.join(SCALAR_OBSERVABLES)}")
    out = out or Path(f"{of}.png")
    if out.suffix.lower() != ".png" or not out.parent.exists():
        fail(f"--out = {str(out)!r}: must end in .png, in an existing directory")
    from hertzian.sweeping.storage import check_writable_folder

    why = check_writable_folder(out)
    if why:
        fail(f"--out = {str(out)!r}: {why}")
    dataset = open_dataset_or_fail(store)
    try:
        plot_distribution(dataset, of, out)
    except ValueError as err:
        fail(str(err))
    typer.echo(f"wrote {out}")
