"""``hertzian bench``: time the project's kernels against NumPy and JAX peers (see ensemble/bench.py)."""

from __future__ import annotations

import json
from typing import Annotated, Optional

import typer

from .app import DeviceOption, app, fail, resolve_device


def _counts(text: str, flag: str) -> list[int]:
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        values = []
    if not values or any(v < 1 for v in values):
        fail(f"{flag} = {text!r}: positive integers, comma-separated (e.g. 16384,1)")
    return values


@app.command()
def bench(
    device: DeviceOption = None,
    chains: Annotated[str, typer.Option("--chains", help="Chain counts, comma-separated; zipped with --grains "
                                        "(a single value repeats).")] = "64",
    grains: Annotated[str, typer.Option("--grains", help="Grains per chain, comma-separated.")] = "1000",
    steps: Annotated[Optional[int], typer.Option("--steps", help="Steps per timed run (default: enough for "
                                                 "~0.3 s on a GPU, ~0.5 s on a CPU).")] = None,
    kernel: Annotated[str, typer.Option("--kernel", help="all | auto | step | tile | window | sweep: the "
                                        "project kernels to time (peers are always timed).")] = "all",
    repeats: Annotated[int, typer.Option("--repeats", help="Timed runs per implementation; the median counts.")] = 5,
    peers: Annotated[bool, typer.Option("--peers/--no-peers", help="Time the NumPy (and JAX) peers.")] = True,
    as_json: Annotated[bool, typer.Option("--json", help="Print a JSON list of records.")] = False,
):
    """Grain-steps per second of every implementation, gear4 float64, the paper's chain (program units).

    Each implementation is first checked against the per-step kernel (same state after 64 steps), then
    warmed up and timed; rates are medians. Ratios: to the memory wall (measured copy bandwidth over
    64 bytes per grain-step) and to the best implementation of the size.
    """
    from ..bench import KERNEL_CHOICES, run_bench

    chain_list, grain_list = _counts(chains, "--chains"), _counts(grains, "--grains")
    if len(chain_list) > 1 and len(grain_list) > 1 and len(chain_list) != len(grain_list):
        fail(f"--grains = {grains!r}: as many values as --chains ({len(chain_list)}), or one")
    count = max(len(chain_list), len(grain_list))
    sizes = [(chain_list[i if len(chain_list) > 1 else 0], grain_list[i if len(grain_list) > 1 else 0])
             for i in range(count)]
    if kernel not in KERNEL_CHOICES:
        fail(f"--kernel = {kernel!r}: one of {', '.join(KERNEL_CHOICES)}")
    if steps is not None and steps < 1:
        fail(f"--steps = {steps}: a positive integer")
    if repeats < 1:
        fail(f"--repeats = {repeats}: a positive integer")
    dev = resolve_device(device)
    if kernel in ("tile", "window") and not dev.startswith("cuda"):
        fail(f"--kernel = {kernel!r}: a CUDA kernel; use --device cuda (or sweep on a CPU)")
    if kernel == "sweep" and dev != "cpu":
        fail(f"--kernel = {kernel!r}: a CPU kernel; use --device cpu")

    log = lambda message: typer.echo(message, err=True)  # noqa: E731  (progress on stderr; --json on stdout)
    try:
        records = run_bench(dev, sizes, kernel=kernel, steps=steps, repeats=repeats, peers=peers, log=log)
    except RuntimeError as err:
        typer.echo(f"error: {err}", err=True)
        raise typer.Exit(1)
    if as_json:
        typer.echo(json.dumps(records, indent=1))
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"hertzian bench on {records[0]['device_name'] if records else dev}")
    for column in ("implementation", "kernel", "chains", "grains", "steps", "GS/s", "steps/s", "x wall",
                   "x best", "rel. diff"):
        table.add_column(column)
    for r in records:
        table.add_row(r["implementation"], r["kernel"], str(r["chains"]), str(r["grains"]), str(r["steps"]),
                      f"{r['grain_steps_per_second']:.3g}", f"{r['steps_per_second']:.3g}",
                      f"{r['ratio_to_memory_wall']:.2f}", f"{r['ratio_to_best']:.2f}",
                      f"{r['max_relative_difference']:.1e}")
    Console(width=200).print(table)
