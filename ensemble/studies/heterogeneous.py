"""The shipped heterogeneous-chain study (docs/heterogeneous.md): the taper sweep (sweeps/taper.toml) and the
disorder sweep (sweeps/disorder.toml), reduced with :mod:`hertzian.studies.realisations` into one JSON record with
each sweep's wall time. By default CPU-sized (fewer grains, a shorter run and fewer seeds); ``--shipped`` runs
the sweeps at their shipped sizes with plain Gear steps (:data:`SHIPPED_EVENTS`), a GPU's job.

``python -m hertzian.studies.heterogeneous OUT.json [--grains 40] [--seeds 20]``
``python -m hertzian.studies.heterogeneous OUT.json --shipped [--device cuda] [--events auto] [--seeds 1000]``
``python -m hertzian.studies.heterogeneous OUT.json --shipped --only taper --device cpu [--dt 5e-6]`` (the shipped
taper sweep is a CPU's job: 9 chains of 100 grains)
"""

from __future__ import annotations

import argparse
import json
import platform
import tempfile
import time
import tomllib
from datetime import date
from importlib import resources
from pathlib import Path

import numpy as np


def binary_collision_fraction(q: float, grains: int) -> float:
    """Energy reaching the bottom grain in the binary-collision picture: each elastic collision of grain k (at
    speed) with grain k+1 (at rest) passes on 4μ/(1 + μ)² of the energy, μ = m_(k+1)/m_k = (1 − q)³ for an
    exponential taper (Machado, Rosas & Lindenberg 2013), so N − 1 collisions pass on (4μ/(1 + μ)²)^(N−1)."""
    mu = (1.0 - q) ** 3
    return float((4.0 * mu / (1.0 + mu) ** 2) ** (grains - 1))


def sweep_file(name: str, *, grains=None, duration=None, seeds=None, events=None, dt=None, trace_every=None) -> dict:
    """The shipped sweep ``name`` (taper or disorder) as data, with the given sizes, integrator settings and trace
    sampling in place of the shipped ones (None keeps the shipped value; ``seeds``: the seed axis' first ``seeds``
    values)."""
    data = tomllib.loads(resources.files("hertzian.sweeps").joinpath(f"{name}.toml").read_text())
    scene = data["scene"]
    if grains is not None:
        shift = grains - scene["chain"]["grains"]  # traced grains keep their distance from the bottom
        scene["record"]["traces"] = [g + shift for g in scene["record"].get("traces", [])]
        scene["chain"]["grains"] = grains
    for key, value in (("duration", duration), ("events", events), ("dt", dt)):
        if value is not None:
            scene["integrator"][key] = value
    if trace_every is not None:
        scene["record"]["trace_every"] = trace_every
    every = scene["record"].get("trace_every")
    if (
        dt is not None
        and trace_every is None
        and every is not None
        and abs(every / dt - round(every / dt)) > 1e-9 * every / dt
    ):
        scene["record"]["trace_every"] = dt  # the shipped sampling is not a whole number of the new steps
    for axis in data["axis"]:
        if axis["name"] == "seed" and seeds is not None:
            axis.pop("linspace", None)
            axis["values"] = list(range(seeds))
    return data


def _run(data: dict, name: str, work: Path, device: str):
    import xarray as xr  # the study's stores are read back as labelled data
    from hertzian.sweeping.pipeline import sweep  # Warp and Zarr load only when the study runs

    path = work / f"{name}.toml"
    path.write_text(_to_toml(data))
    out = work / f"{name}.zarr"
    clock = time.perf_counter()
    sweep(path, out, device=device, notify=lambda line: None)
    return xr.open_zarr(out), time.perf_counter() - clock


def _to_toml(data: dict) -> str:
    """The few TOML shapes a sweep file uses (tables of scalars and inline tables, an array of axis tables)."""

    def value(v):
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + " }"
        return json.dumps(v)

    lines = []
    for section, table in data["scene"].items():
        lines.append(f"[scene.{section}]")
        lines += [f"{k} = {value(v)}" for k, v in table.items()]
    for axis in data["axis"]:
        lines.append("[[axis]]")
        lines += [f"{k} = {value(v)}" for k, v in axis.items()]
    return "\n".join(lines) + "\n"


SHIPPED_EVENTS = "off"
"""``integrator.events`` of the shipped-size run: plain Gear steps. These loose chains open contacts behind the
pulse, where event-aware steps cost a GPU many times a plain step. On the CPU at 200 grains the bottom grain's
statistics moved by far less than their uncertainty at 1000 realisations between ``auto`` and ``off`` and between dt
and dt/2, and the decay-length fit moved as much with dt as with the events (docs/heterogeneous.md)."""


CPU_TAPER_DT = 5e-5
"""Step of the CPU-sized taper sweep (40 grains: its smallest grain, 0.2 R0 at q = 0.04, passes `hertzian check`
at this step; the shipped 100-grain sweep's needs 2e-6)."""


def plan(
    *,
    shipped: bool = False,
    grains: int = 40,
    seeds: int | None = None,
    events: str | None = None,
    dt=None,
    trace_every=None,
) -> dict:
    """The two sweeps the study runs, as sweep-file data by name: ``shipped``, sweeps/taper.toml and
    sweeps/disorder.toml at their shipped sizes (9 tapers × 100 grains; 6 spreads × 1000 seeds × 200 grains, or the
    first ``seeds`` seeds) with ``events`` (default SHIPPED_EVENTS); else the CPU size, ``grains`` grains, shorter runs
    and ``seeds`` seeds per spread (default 20), with the shipped ``events`` unless given. ``dt`` [time]: None keeps
    the shipped step (the CPU-sized taper: :data:`CPU_TAPER_DT`); ``trace_every`` [time]: the bottom grain's trace
    sampling of both sweeps (None: the shipped one)."""
    if shipped:
        events = events or SHIPPED_EVENTS
        return {
            "taper": sweep_file("taper", events=events, dt=dt, trace_every=trace_every),
            "disorder": sweep_file("disorder", events=events, dt=dt, seeds=seeds, trace_every=trace_every),
        }
    seeds = 20 if seeds is None else seeds
    return {
        "taper": sweep_file(
            "taper", grains=grains, duration=6.0, events=events, dt=dt or CPU_TAPER_DT, trace_every=trace_every
        ),
        "disorder": sweep_file(
            "disorder", grains=grains, duration=4.0, seeds=seeds, events=events, dt=dt, trace_every=trace_every
        ),
    }


def study(grains: int = 40, seeds: int = 20, *, device: str = "cpu", sweeps: dict | None = None) -> dict:
    """The sweeps of ``sweeps`` (:func:`plan`'s, or some of them; default both at the CPU size, ``grains`` grains and
    ``seeds`` realisations per spread) on ``device``, and their observables; each sweep's wall time in seconds."""
    sweeps = sweeps or plan(grains=grains, seeds=seeds)
    record = {"device": device, "host": platform.node(), "date": date.today().isoformat()}
    with tempfile.TemporaryDirectory() as tmp:
        if "taper" in sweeps:
            record["grains"] = sweeps["taper"]["scene"]["chain"]["grains"]
            record["taper"] = _taper(sweeps["taper"], Path(tmp), device)
        if "disorder" in sweeps:
            record["disorder"] = _disorder(sweeps["disorder"], Path(tmp), device)
    return record


def _taper(data: dict, work: Path, device: str) -> dict:
    from hertzian.studies.realisations import observables

    taper, seconds = _run(data, "taper", work, device)
    found = observables(taper)
    q = taper.taper.values.tolist()
    uniform = found["bottom_fraction"][q.index(0.0)]
    n = data["scene"]["chain"]["grains"]
    return {
        "q": q,
        "bottom_fraction": found["bottom_fraction"].tolist(),
        "relative_to_uniform": (found["bottom_fraction"] / uniform).tolist(),
        "binary_collision_relative": [binary_collision_fraction(x, n) for x in q],
        "arrival_time": found["arrival_time"].tolist(),
        "bottom_peak_force": found["bottom_peak_force"].tolist(),
        "energy_error": taper.energy_error.values.tolist(),
        "status": taper.status.values.tolist(),
        **_integrator(data),
        "seconds": seconds,
    }


def _disorder(data: dict, work: Path, device: str) -> dict:
    from hertzian.studies.realisations import statistics

    disorder, seconds = _run(data, "disorder", work, device)
    stats = statistics(disorder, "seed")
    return {
        "grains": data["scene"]["chain"]["grains"],
        "spread": disorder.spread.values.tolist(),
        "realisations": disorder.sizes["seed"],
        **{
            f"{name}_{k}": np.asarray(stats[name][k]).tolist()
            for name in ("decay_length", "bottom_fraction", "arrival_time", "bottom_peak_force")
            for k in ("mean", "std", "q05", "q50", "q95")
        },
        **_integrator(data),
        "seconds": seconds,
    }


def _integrator(data: dict) -> dict:
    """The integrator settings and trace sampling a sweep ran with (the shipped defaults where its file leaves them
    out)."""
    integrator = data["scene"]["integrator"]
    return {
        "events": integrator.get("events", "auto"),
        "dt": integrator["dt"],
        "duration": integrator["duration"],
        "trace_every": data["scene"]["record"].get("trace_every"),
    }


def arguments(argv: list[str] | None = None) -> tuple[Path, dict, str, str | None]:
    """(output path, :func:`plan`'s sweeps, device, part) from the command line; the device is checked here
    (default: CUDA when present, else the CPU); a part's result goes under ``parts[PART]`` of the output record."""
    from hertzian.core.devices import check_device

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--grains", type=int, default=40, help="grains per chain at the CPU size")
    parser.add_argument("--seeds", type=int, default=None, help="realisations per spread (default 20; shipped: 1000)")
    parser.add_argument("--shipped", action="store_true", help="the sweeps' shipped sizes (a GPU's run)")
    parser.add_argument("--device", default=None, help="cpu, cuda or cuda:N (default: cuda if present, else cpu)")
    parser.add_argument("--events", choices=("auto", "off"), default=None, help="integrator.events for both sweeps")
    parser.add_argument("--dt", type=float, default=None, help="integrator.dt for both sweeps (default: shipped)")
    parser.add_argument("--trace-every", type=float, default=None, help="the bottom grain's trace sampling [time]")
    parser.add_argument("--only", choices=("taper", "disorder"), default=None, help="run one of the two sweeps")
    parser.add_argument("--part", default=None, help="store the result as parts[PART] of OUT, beside what it holds")
    args = parser.parse_args(argv)
    if args.seeds is not None and args.seeds < 1:
        parser.exit(2, f"error: --seeds = {args.seeds}: must be an integer ≥ 1\n")
    for name in ("dt", "trace_every"):
        if getattr(args, name) is not None and not getattr(args, name) > 0:
            parser.exit(2, f"error: --{name.replace('_', '-')} = {getattr(args, name)}: must be > 0\n")
    if args.grains < 2:
        parser.exit(2, f"error: --grains = {args.grains}: must be an integer ≥ 2\n")
    sweeps = plan(
        shipped=args.shipped,
        grains=args.grains,
        seeds=args.seeds,
        events=args.events,
        dt=args.dt,
        trace_every=args.trace_every,
    )
    if args.only:
        sweeps = {args.only: sweeps[args.only]}
    _refuse_unless_valid(sweeps, parser)
    return args.out, sweeps, check_device(args.device), args.part


def _refuse_unless_valid(sweeps: dict, parser: argparse.ArgumentParser) -> None:
    """Exit 2 with the sweep's one-line refusal when a sweep the options made cannot run, before any runs."""
    from hertzian.core.errors import SceneError
    from hertzian.sweeping.spec import expand, sweep_from_dict

    for name, data in sweeps.items():
        try:
            expand(sweep_from_dict(data))
        except SceneError as err:
            parser.exit(2, f"error: the {name} sweep: {err}\n")


def main() -> None:
    import shlex
    import sys

    from hertzian.core.outputs import exit_unless_replaceable, write_part

    out, sweeps, device, part = arguments()
    exit_unless_replaceable(out, "OUT")
    command = "python -m hertzian.studies.heterogeneous " + shlex.join(sys.argv[1:])
    result = {"command": command, **study(device=device, sweeps=sweeps)}
    if part:  # kept beside the record's own result, under "parts"
        write_part(out, part, result)
    else:
        out.write_text(json.dumps(result, indent=1) + "\n")
    print(f"wrote {out}" + (f" (part {part})" if part else ""))


if __name__ == "__main__":
    main()
