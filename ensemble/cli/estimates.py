"""``hertzian estimates``: the per-point error estimate against the true error over a sweep, and its cost
(ensemble/studies/estimates.py; numbers in docs/accuracy.md)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Optional

import typer
from hertzian.cli.app import DeviceOption, app, check_output_file, command_line, fail, one_line_errors, resolve_device


@app.command("estimates")
def estimate_check(
    sweep: Annotated[
        Optional[Path], typer.Argument(help="Sweep file whose points are checked (they run as one ensemble).")
    ] = None,
    events: Annotated[str, typer.Option("--events", help="Comma-separated event settings: auto, off.")] = "auto,off",
    reference_divisor: Annotated[
        int, typer.Option("--reference-divisor", help="Reference step = the sweep's dt / this (gear6), even, ≥ 4.")
    ] = 16,
    cost: Annotated[
        bool,
        typer.Option("--cost", help="Also time --cost-chains chains × 200 grains with and without the estimate."),
    ] = False,
    cost_chains: Annotated[
        Optional[int],
        typer.Option(
            "--cost-chains",
            help="Chains of the --cost case (default: 64 on a CPU; 16384 on a GPU, enough to fill it: a smaller "
            "ensemble times kernel launches, not integration).",
        ),
    ] = None,
    cost_features: Annotated[
        bool,
        typer.Option(
            "--cost-features",
            help="With --cost: also time the cost case with walls, gravity and impurities, a drive, viscous and "
            "contact damping, each on the fused (CPU: chain) and the per-step kernel.",
        ),
    ] = False,
    defaults: Annotated[
        bool,
        typer.Option(
            "--defaults",
            help="Instead of SWEEP: time to accuracy (1e-4, 1e-6, 1e-8) of gear4, gear6, verlet × events auto, off × "
            "dt on three scenes (impact, loose, wall), the cheapest per target (docs/accuracy.md).",
        ),
    ] = False,
    as_json: Annotated[Optional[Path], typer.Option("--json", help="Write the record (JSON) here.")] = None,
    device: DeviceOption = None,
):
    """Estimate against true error: each point of SWEEP is run with its error estimate (per --events setting)
    and against gear6 at dt/--reference-divisor; prints the fraction of points whose estimate is within 3× of
    the true error, where contacts can open and where none can."""
    from hertzian.core.shipped import shipped_file
    from hertzian.studies.accuracy import parse_list
    from hertzian.studies.estimates import cost_scenes, estimate_check, estimate_cost, feature_costs
    from hertzian.sweeping.spec import load_sweep

    sweep = None if sweep is None else shipped_file(sweep)
    if defaults == (sweep is not None):
        fail(f"SWEEP = {str(sweep or '')!r}: give a sweep file or --defaults, not both or neither")
    if cost_features and not cost:
        fail("--cost-features = true: needs --cost")
    if cost_chains is not None and cost_chains < 1:
        fail(f"--cost-chains = {cost_chains}: must be at least 1")
    if reference_divisor < 4 or reference_divisor % 2:
        fail(f"--reference-divisor = {reference_divisor}: must be an even integer ≥ 4")
    check_output_file("--json", as_json)
    if defaults:
        _defaults(resolve_device(device), as_json)
        return
    with one_line_errors():
        settings = parse_list("--events", events, ("auto", "off"))
        scenes = load_sweep(sweep).scenes()
    dev = resolve_device(device)
    record = {
        "sweep": sweep.name,
        **estimate_check(scenes, device=dev, events=settings, reference_divisor=reference_divisor),
    }
    if cost:
        chains = cost_chains or (64 if dev == "cpu" else 16384)
        record["cost"] = estimate_cost(cost_scenes(chains), device=dev)
    if cost_features:
        kernels = ["chain" if dev == "cpu" else "fused", "step"]
        record["cost_features"] = feature_costs(dev, kernels, chains, progress=lambda s: typer.echo(s, err=True))
    for setting, row in record["events"].items():
        typer.echo(
            f"events {setting}: {row['fraction_within']:.0%} of {row['resolved_points']} resolved points within 3× "
            f"(contacts open: {_percent(row['fraction_within_where_contacts_open'])}, none open: "
            f"{_percent(row['fraction_within_where_none_open'])}); ratio {row['ratio_range'][0]:.2g} … "
            f"{row['ratio_range'][1]:.2g}"
        )
    if cost:
        c = record["cost"]
        typer.echo(f"cost: {c['ratio']:.2f}× ({c['chains']} chains × {c['grains']} grains, kernel {c['kernel']})")
    for row in record.get("cost_features", []):
        typer.echo(f"cost, {row['case']}, kernel {row['kernel_asked']}: {row['ratio']:.2f}×")
    _write(as_json, dev, record)


def _write(as_json: Optional[Path], device: str, record: dict) -> None:
    """The record at ``as_json`` (if given): the command that wrote it, where and when it ran, then its numbers."""
    if as_json is not None:
        from hertzian.core.outputs import provenance

        as_json.write_text(json.dumps({"command": command_line(), **provenance(device), **record}, indent=1) + "\n")
        typer.echo(f"wrote {as_json}", err=True)


def _percent(value: float | None) -> str:
    return "-" if value is None else f"{value:.0%}"


def _defaults(device: str, as_json: Optional[Path]) -> None:
    """``--defaults``: the defaults study (hertzian.studies.estimates.defaults_study), one line per scene and
    target, the record written to ``as_json``."""
    from hertzian.studies.estimates import defaults_study

    record = defaults_study(device, progress=lambda name: typer.echo(f"running {name}", err=True))
    for name, row in record["scenes"].items():
        for target, best in row["cheapest"].items():
            choice = (
                "none"
                if best is None
                else (
                    f"{best['method']} events {best['events']} dt {best['dt']:g}: {best['seconds']:.3g} s, "
                    f"error {best['error']:.2g}"
                )
            )
            typer.echo(f"{name} ≤ {float(target):g}: {choice}")
    _write(as_json, device, record)
