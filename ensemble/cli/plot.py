"""``hertzian plot``: one figure group of Sen, Manciu & Wright (1998) from a store, as a PNG."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from .app import app, fail


@app.command()
def plot(
    store: Annotated[Path, typer.Argument(help="A store written by `hertzian sweep sweeps/paper_*.toml` "
                                          "(or docs/reproduce_gpu.py for fig9/fig10).")],
    figure: Annotated[str, typer.Option("--figure", help="fig1 | fig1d | fig2 | fig3 | fig4 | fig5 | fig6 | "
                                        "depth | fig7_8 | fig9 | fig10.")],
    out: Annotated[Path, typer.Option("--out", help="PNG file to write.")] = Path("figure.png"),
):
    """Draw a paper figure group in the paper's representation (program units: length 1e-5 m,
    time 1.0102e-3 s; profiles in the paper's sign, + toward the surface)."""
    from ..plot import FIGURES, PlotError, plot_figure

    if figure not in FIGURES:
        fail(f"--figure = {figure!r}: allowed: {', '.join(FIGURES)}")
    if not store.exists():
        fail(f"store = {str(store)!r}: no such store")
    if out.suffix.lower() != ".png":
        fail(f"--out = {str(out)!r}: must end in .png")
    if not out.parent.exists():
        fail(f"--out = {str(out)!r}: parent directory does not exist")
    import xarray as xr

    try:
        dataset = xr.open_zarr(store)
    except Exception as err:  # noqa: BLE001  (any unreadable store is bad input)
        fail(f"store = {str(store)!r}: not a readable Zarr store ({type(err).__name__})")
    try:
        plot_figure(dataset, figure, out)
    except PlotError as err:
        fail(f"--figure = {figure!r}: {err}")
    except (KeyError, IndexError, ValueError) as err:  # a store of another sweep than the figure's
        fail(f"--figure = {figure!r}: store {str(store)!r} does not hold this figure's sweep ({err})")
    typer.echo(f"wrote {out}")
