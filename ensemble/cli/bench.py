"""``hertzian bench``: time the project's kernels against NumPy and JAX peers (see ensemble/studies/bench.py)."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Annotated, Optional

import typer
from hertzian.cli.app import DeviceOption, SetOption, app, check_output_file, command_line, fail, resolve_device


def _counts(text: str, flag: str, *, least: int = 1, example: str = "16384,1") -> list[int]:
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        values = []
    if not values or any(v < least for v in values):
        fail(f"{flag} = {text!r}: integers ≥ {least}, comma-separated (e.g. {example})")
    return values


def _sizes(chains: str, grains: str) -> list[tuple[int, int]]:
    """(chains, grains) pairs of ``--chains`` zipped with ``--grains`` (a single value repeats); bad input → fail."""
    chain_list, grain_list = _counts(chains, "--chains"), _counts(grains, "--grains", least=2, example="1000,100")
    if len(chain_list) > 1 and len(grain_list) > 1 and len(chain_list) != len(grain_list):
        fail(f"--grains = {grains!r}: as many values as --chains ({len(chain_list)}), or one")
    count = max(len(chain_list), len(grain_list))
    return [
        (chain_list[i if len(chain_list) > 1 else 0], grain_list[i if len(grain_list) > 1 else 0]) for i in range(count)
    ]


def _print_table(records: list[dict], device: str) -> None:
    """The rich table of the bench records, one row per implementation and size."""
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"hertzian bench on {records[0]['device_name'] if records else device}")
    for column in (
        "implementation",
        "kernel",
        "chains",
        "grains",
        "steps",
        "GS/s",
        "steps/s",
        "x wall",
        "x best",
        "rel. diff",
    ):
        table.add_column(column)
    for r in records:
        table.add_row(
            r["implementation"],
            r["kernel"],
            str(r["chains"]),
            str(r["grains"]),
            str(r["steps"]),
            f"{r['grain_steps_per_second']:.3g}",
            f"{r['steps_per_second']:.3g}",
            f"{r['ratio_to_memory_wall']:.2f}",
            f"{r['ratio_to_best']:.2f}",
            f"{r['max_relative_difference']:.1e}",
        )
    Console(width=200).print(table)


@app.command()
def bench(
    device: DeviceOption = None,
    chains: Annotated[
        str,
        typer.Option("--chains", help="Chain counts, comma-separated; zipped with --grains (a single value repeats)."),
    ] = "64",
    grains: Annotated[str, typer.Option("--grains", help="Grains per chain, comma-separated.")] = "1000",
    steps: Annotated[
        Optional[int],
        typer.Option("--steps", help="Steps per timed run (default: enough for ~0.3 s on a GPU, ~0.5 s on a CPU)."),
    ] = None,
    kernel: Annotated[
        str,
        typer.Option(
            "--kernel",
            help="all | auto | step | tile | window | chain: the project kernels to time (peers are always timed).",
        ),
    ] = "all",
    repeats: Annotated[int, typer.Option("--repeats", help="Timed runs per implementation; the median counts.")] = 5,
    peers: Annotated[bool, typer.Option("--peers/--no-peers", help="Time the NumPy (and JAX) peers.")] = True,
    as_json: Annotated[bool, typer.Option("--json", help="Print a JSON list of records.")] = False,
    law: Annotated[
        str,
        typer.Option(
            "--law",
            help="The benchmark ensemble's contact law: hertz (the paper's chain) or fput (β-FPUT between walls, "
            "a = m = 1, β = 1, dt = 0.05).",
        ),
    ] = "hertz",
    scene: Annotated[
        Optional[Path],
        typer.Option(
            "--scene", help="End to end: time `hertzian run` of this scene file (records and store writes included)."
        ),
    ] = None,
    sweep: Annotated[
        Optional[Path],
        typer.Option(
            "--sweep",
            help="End to end: time `hertzian sweep` of this sweep file (serial, store in a temporary directory).",
        ),
    ] = None,
    cold: Annotated[
        bool,
        typer.Option(
            "--cold",
            help="End to end with empty Warp kernel and calibration caches "
            "(a fresh temporary directory): what compile and calibration cost.",
        ),
    ] = False,
    set_: SetOption = None,
    scale_out: Annotated[
        Optional[str],
        typer.Option(
            "--scale-out",
            help="Worker counts, comma-separated (e.g. 1,2,4): strong scaling of `hertzian sweep --workers N` on "
            "--sweep, end to end, stores compared bit for bit (docs/scale-out.md); --json prints the record.",
        ),
    ] = None,
    scale_weak: Annotated[
        bool,
        typer.Option(
            "--scale-weak/--no-scale-weak",
            help="With --scale-out: weak scaling too (integrator.duration in proportion to the workers).",
        ),
    ] = False,
    scale_budget: Annotated[
        Optional[float],
        typer.Option(
            "--scale-budget",
            help="With --scale-out: seconds for the whole measurement; a run estimated not to fit is skipped.",
        ),
    ] = None,
    scale_json: Annotated[
        Optional[Path],
        typer.Option(
            "--scale-json",
            help="With --scale-out: write the record to this file after every run (a killed measurement keeps "
            "every finished run).",
        ),
    ] = None,
    record: Annotated[
        Optional[Path],
        typer.Option(
            "--record",
            help="Also add this run (command, date, device and the --json records) to the JSON record FILE, under "
            "parts.PART.runs (FILE created if missing; other parts and runs kept).",
        ),
    ] = None,
    part: Annotated[str, typer.Option("--part", help="With --record: the part the run is added to.")] = "bench",
):
    """Grain-steps per second of every implementation, gear4 float64, the paper's chain (program units).

    Each implementation is first checked against the per-step kernel (same state after 64 steps), then
    warmed up and timed; rates are medians. Ratios: to the memory wall (measured copy bandwidth over
    64 bytes per grain-step) and to the best implementation of the size.
    """
    from hertzian.studies.bench import KERNEL_CHOICES, LAWS, run_bench

    keep = _keeper(record, part, scale_out is not None)
    if scale_out is not None:
        _scale_out(scale_out, sweep, device, set_, as_json, weak=scale_weak, budget=scale_budget, path=scale_json)
        return
    if scene is not None or sweep is not None:
        _end_to_end(scene, sweep, device, kernel, cold, set_, as_json, keep)
        return
    sizes = _sizes(chains, grains)
    if law not in LAWS:
        fail(f"--law = {law!r}: one of {', '.join(LAWS)}")
    if kernel not in KERNEL_CHOICES:
        fail(f"--kernel = {kernel!r}: one of {', '.join(KERNEL_CHOICES)}")
    if steps is not None and steps < 1:
        fail(f"--steps = {steps}: a positive integer")
    if repeats < 1:
        fail(f"--repeats = {repeats}: a positive integer")
    dev = resolve_device(device)
    if kernel in ("tile", "window") and not dev.startswith("cuda"):
        fail(f"--kernel = {kernel!r}: a CUDA kernel; use --device cuda (or --kernel chain on a CPU)")
    if kernel == "chain" and dev != "cpu":
        fail(f"--kernel = {kernel!r}: a CPU kernel; use --device cpu")

    log = lambda message: typer.echo(message, err=True)  # noqa: E731  (progress on stderr; --json on stdout)
    try:
        records = run_bench(dev, sizes, kernel=kernel, steps=steps, repeats=repeats, peers=peers, log=log, law=law)
    except RuntimeError as err:
        typer.echo(f"error: {err}", err=True)
        raise typer.Exit(1)
    keep(records, dev)
    if as_json:
        typer.echo(json.dumps(records, indent=1))
        return
    _print_table(records, dev)


def _keeper(path: Path | None, part: str, scale_out: bool):
    """``--record``/``--part``, checked (exit 2) before anything runs: a function that adds a run's records to the
    record file (nothing without ``--record``)."""
    if path is None:
        return lambda records, device: None
    if scale_out:
        fail(f"--record = {str(path)!r}: not with --scale-out (its record is --scale-json)")
    if not part.strip():
        fail(f"--part = {part!r}: a name")
    check_output_file("--record", path)

    def keep(records: list[dict], device: str) -> None:
        from hertzian.core.outputs import add_run, provenance

        add_run(path, part, {"command": command_line(), **provenance(device), "records": records})

    return keep


def _end_to_end(
    scene: Path | None, sweep: Path | None, device, kernel: str, cold: bool, set_, as_json: bool, keep
) -> None:
    """``--scene`` / ``--sweep``: one whole run or sweep, split into build/compile/kernel/record/store seconds."""
    from hertzian.core.scene import SceneError, parse_overrides
    from hertzian.core.solvers import KERNELS

    if scene is not None and sweep is not None:
        fail(f"--sweep = {str(sweep)!r}: give --scene or --sweep, not both")
    from hertzian.core.shipped import shipped_file

    path = shipped_file(scene if scene is not None else sweep)
    if not path.is_file():
        fail(f"--{'scene' if scene is not None else 'sweep'} = {str(path)!r}: no such file")
    kernel = "auto" if kernel == "all" else kernel
    if kernel not in KERNELS:
        fail(f"--kernel = {kernel!r}: one of {', '.join(KERNELS)} (end to end)")
    try:
        overrides = parse_overrides(set_)
    except SceneError as err:
        fail(str(err))
    if cold:
        import warp as wp

        cache = tempfile.mkdtemp(prefix="hertzian-cold-")
        wp.config.kernel_cache_dir = os.path.join(cache, "warp")
        os.environ["HERTZIAN_CACHE"] = os.path.join(cache, "calibration.json")
    dev = resolve_device(device)
    from hertzian.studies.endtoend import bench_scene, bench_sweep

    log = lambda message: typer.echo(message, err=True)  # noqa: E731
    try:
        if scene is not None:
            record = bench_scene(path, dev, kernel=kernel, overrides=overrides, log=log)
        else:
            record = bench_sweep(path, dev, kernel=kernel, overrides=overrides, log=log)
    except SceneError as err:
        fail(str(err))
    except ValueError as err:  # a forced kernel that cannot run these features here
        fail(f"--kernel = {kernel!r}: {str(err).split(': ', 1)[-1]}")
    record["cold"] = cold
    keep([record], dev)
    for note in record["notes"]:
        typer.echo(f"note: {note}", err=True)
    if as_json:
        typer.echo(json.dumps([record], indent=1))
        return
    s = record["seconds"]
    typer.echo(
        f"{record['workload']} on {record['device_name']} ({record['kernel']}; {'cold' if cold else 'warm'} "
        f"caches): {s['total']:.2f} s end to end = build {s['build']:.2f} + compile {s['compile']:.2f} + "
        f"kernel {s['kernel']:.2f} + record {s['record']:.2f} + store {s['store']:.2f} s; "
        f"{record['grain_steps_per_second']:.3g} GS/s end to end, {record['kernel_grain_steps_per_second']:.3g} "
        f"in the kernel; device busy {record['device_busy']:.0%}"
    )


def _scale_out(counts_text: str, sweep: Path | None, device, set_, as_json: bool, *, weak, budget, path) -> None:
    """``--scale-out``: strong (and weak) scaling of ``sweep`` (ensemble/studies/scaling.py); one line per run on
    stderr, the record in ``path`` after every run and, with ``as_json``, on stdout at the end."""
    from hertzian.core.scene import SceneError, parse_overrides

    counts = _counts(counts_text, "--scale-out", example="1,2,4")
    if sweep is None or not sweep.is_file():
        fail(f"--sweep = {str(sweep) if sweep else None!r}: --scale-out needs a sweep file")
    if budget is not None and not budget > 0:
        fail(f"--scale-budget = {budget!r}: a positive number of seconds")
    if path is not None and not path.parent.is_dir():
        fail(f"--scale-json = {str(path)!r}: no such directory {str(path.parent)!r}")
    try:
        parse_overrides(set_)
    except SceneError as err:
        fail(str(err))
    from hertzian.studies.scaling import scale_out

    log = lambda message: typer.echo(message, err=True)  # noqa: E731
    with tempfile.TemporaryDirectory(prefix="hertzian-scale-", dir=".") as workdir:
        try:
            record = scale_out(
                sweep,
                counts,
                sets=list(set_ or []),
                device=device,
                workdir=Path(workdir),
                weak=weak,
                budget=budget,
                record_path=path,
                log=log,
            )
        except RuntimeError as err:
            typer.echo(f"error: {err}", err=True)
            raise typer.Exit(1)
    typer.echo(f"stores bitwise equal: {record['bitwise_equal']}", err=True)
    if as_json:
        typer.echo(json.dumps(record, indent=1))
    if not record["bitwise_equal"]:
        raise typer.Exit(1)
