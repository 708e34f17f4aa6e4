"""The ``hertzian`` command line (SPEC §7).

Bad input prints one line ``error: KEY = VALUE: what is allowed`` to stderr and exits with
code 2, writing nothing.
"""

from __future__ import annotations

import json
import sys
from importlib import resources
from pathlib import Path
from typing import Annotated, Optional

import typer

from .scene import SceneError, load_scene, parse_overrides

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="Simulate many Hertzian granular chains at once (Warp kernels on GPU or CPU).")

EXIT_BAD_INPUT = 2

DeviceOption = Annotated[Optional[str], typer.Option("--device", help="cpu | cuda | cuda:N (default: cuda if present, else cpu).")]
SetOption = Annotated[Optional[list[str]], typer.Option("--set", help="Override a scene key, e.g. --set chain.l0=1e-4 (repeatable).")]
PrecisionOption = Annotated[Optional[str], typer.Option("--precision", help="float64 | float32 (overrides integrator.precision).")]


def fail(message: str) -> None:
    """One clear line on stderr, exit code 2."""
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(EXIT_BAD_INPUT)


def example_path(name: str = "impact") -> Path:
    """A built-in example scene shipped with the package."""
    return Path(str(resources.files("ensemble") / "examples" / f"{name}.toml"))


def resolve_device(device: str | None) -> str:
    import warp as wp

    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    if device is None:
        return "cuda" if wp.is_cuda_available() else "cpu"
    try:
        wp.get_device(device)
    except Exception:
        available = ", ".join(str(d) for d in wp.get_devices())
        fail(f"--device = {device!r}: not available here; available: {available}")
    return device


def _load(scene_path: Path | None, overrides: list[str] | None, precision: str | None):
    try:
        sets = parse_overrides(overrides)
        if precision is not None:
            sets["integrator.precision"] = precision
        return load_scene(scene_path or example_path(), sets)
    except SceneError as err:
        fail(str(err))


@app.command()
def run(
    scene: Annotated[Optional[Path], typer.Argument(help="Scene TOML (SPEC §8). Default: the built-in example "
                                                   "(1000-grain impact, l0 = 1e-4, v_imp = 1e-2).")] = None,
    out: Annotated[Path, typer.Option("--out", help="Zarr store to write.")] = Path("hertzian-run.zarr"),
    device: DeviceOption = None,
    precision: PrecisionOption = None,
    set_: SetOption = None,
    overwrite: Annotated[bool, typer.Option("--overwrite", help="Replace an existing store.")] = False,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress bar.")] = False,
    strict: Annotated[bool, typer.Option("--strict", help="Refuse (exit 2) when dt looks unstable or "
                                         "inaccurate (see hertzian check) instead of warning.")] = False,
):
    """Run one scene and store it as Zarr (times in program units of 1.0102e-3 s)."""
    loaded = _load(scene, set_, precision)
    from .check import dt_warning

    unsafe = dt_warning(loaded)
    if unsafe and strict:
        fail(unsafe)
    if unsafe:
        typer.echo(f"warning: {unsafe}", err=True)
    if out.exists() and not overwrite:
        fail(f"--out = {str(out)!r}: exists; choose another path or pass --overwrite")
    if not out.parent.exists():
        fail(f"--out = {str(out)!r}: parent directory does not exist")
    dev = resolve_device(device)

    from .runner import run_scene
    from .store import write_result

    progress = None
    if not quiet and sys.stderr.isatty():
        from rich.progress import BarColumn, Progress, TimeRemainingColumn

        bar = Progress("[progress.description]{task.description}", BarColumn(), "{task.completed}/{task.total} records",
                       TimeRemainingColumn(), transient=True)
        bar.start()
        task = bar.add_task("integrating", total=loaded.record_count)
        progress = lambda done, total: bar.update(task, completed=done)  # noqa: E731
    try:
        result = run_scene(loaded, dev, progress=progress)
    finally:
        if progress is not None:
            bar.stop()
    write_result(out, result, overwrite=overwrite)
    status = int(result.status[0])
    typer.echo(
        f"{loaded.chain.grains} grains, {result.steps} steps of {loaded.integrator.method} "
        f"dt={loaded.integrator.dt:g} on {result.device} ({result.kernel} kernel): {result.wall_seconds:.2f} s, "
        f"{result.grain_steps_per_second:.3g} grain-steps/s, energy error {result.energy_error[0]:.2e}, "
        f"status {status}")
    typer.echo(f"wrote {out}")


@app.command()
def summarize(
    store: Annotated[Path, typer.Argument(help="A store written by run or sweep.")],
    as_json: Annotated[bool, typer.Option("--json", help="Print a JSON list of records.")] = False,
):
    """Per point: status, energy error, wall seconds, grain-steps per second."""
    from .store import summary_records

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


from . import cli_sweep  # noqa: E402,F401  (registers commands)
from . import cli_bench  # noqa: E402,F401  (registers commands)
from . import cli_accuracy  # noqa: E402,F401  (registers commands)
from . import cli_plot  # noqa: E402,F401  (registers commands)
from . import cli_detect  # noqa: E402,F401  (registers commands)


def main() -> None:
    """Entry point of the ``hertzian`` script."""
    app()


if __name__ == "__main__":
    # `python -m ensemble.cli`: run the package module's app, on which the other command
    # modules registered (this file executing as __main__ is a separate module object).
    from ensemble.cli import main as package_main

    package_main()
