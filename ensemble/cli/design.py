"""``hertzian design``: evolve a protector (which beads, materials and sizes give the wall the smallest force)."""

from __future__ import annotations

import contextlib
import json
import sys
from pathlib import Path
from typing import Annotated, Optional

import typer
from hertzian.cli.app import DeviceOption, app, fail, one_line_errors, resolve_device


@app.command()
def design(
    path: Annotated[Path, typer.Argument(help="A design file: a [scene] table (the base chain) and a [design] table.")],
    out: Annotated[Path, typer.Option("--out", help="Zarr store of every generation (genomes, objectives, best).")],
    device: DeviceOption = None,
    generations: Annotated[Optional[int], typer.Option("--generations", help="Override design.generations.")] = None,
    population: Annotated[Optional[int], typer.Option("--population", help="Override design.population.")] = None,
    seed: Annotated[Optional[int], typer.Option("--seed", help="Override design.seed.")] = None,
    set_: Annotated[
        Optional[list[str]],
        typer.Option("--set", help="Override design.KEY=VALUE or scene.SECTION.KEY=VALUE (repeatable)."),
    ] = None,
    resume: Annotated[bool, typer.Option("--resume", help="Continue a stopped design (same file).")] = False,
    overwrite: Annotated[bool, typer.Option("--overwrite", help="Replace an existing design store.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the result as one JSON object.")] = False,
):
    """Minimise the peak force on the wall behind a chain (or the impulse, or the mass, or several of them: their
    Pareto front) over the materials and radii of the grains a design file names, by CMA-ES or a genetic algorithm: every
    generation is one ensemble run of all its candidates.

    docs/design.md describes the design file and the store."""
    from hertzian.core.scene import parse_overrides
    from hertzian.core.shipped import shipped_file
    from hertzian.studies.design import load_design, optimise, split_overrides
    from hertzian.sweeping.storage import check_out

    if resume and overwrite:
        fail("--resume = --overwrite: give one of them")
    given = (("generations", generations), ("population", population), ("seed", seed))
    with one_line_errors():
        overrides, scene_overrides = split_overrides(parse_overrides(set_))
        overrides |= {k: v for k, v in given if v is not None}
        scene, spec = load_design(shipped_file(path), overrides, scene_overrides)
        check_out(out, overwrite=overwrite, resume=resume, hint="resume to continue it or overwrite to replace it")
    dev = resolve_device(device)
    with one_line_errors(), _generations_bar(spec.generations, shown=not as_json and sys.stderr.isatty()) as bar:
        progress = bar or (None if as_json else _progress)
        result = optimise(scene, spec, out, device=dev, resume=resume, progress=progress)
    if as_json:
        typer.echo(json.dumps(result.to_dict()))
        return
    front = f"; Pareto front of {len(result.pareto_objectives)} designs" if len(spec.objective) > 1 else ""
    typer.echo(
        f"{spec.generations} generations of {spec.population} ({spec.optimizer}) on {dev}: best {spec.objective[0]} "
        f"{result.best_objective:.6g}{front} ({result.seconds:.1f} s)"
    )
    typer.echo(f"wrote {out}")


@contextlib.contextmanager
def _generations_bar(total: int, *, shown: bool):
    """On a terminal, a transient rich bar of the generations done with each objective's best so far, as a
    ``progress(generation, generations, best)`` callback (None when not shown: then one line a generation)."""
    if not shown:
        yield None
        return
    from rich.progress import BarColumn, Progress, TimeRemainingColumn

    bar = Progress(
        "[progress.description]{task.description}", BarColumn(), "{task.completed}/{task.total}", TimeRemainingColumn()
    )
    bar.start()
    task = bar.add_task("generations", total=total)

    def update(generation: int, generations: int, best) -> None:
        text = ", ".join(f"{value:.4g}" for value in best)
        bar.update(task, completed=generation, description=f"best {text}")

    try:
        yield update
    finally:
        bar.stop()


def _progress(generation: int, generations: int, best) -> None:
    """One line a generation on stderr: each objective's best so far."""
    text = ", ".join(f"{value:.6g}" for value in best)
    print(f"generation {generation}/{generations}: best {text}", file=sys.stderr, flush=True)
