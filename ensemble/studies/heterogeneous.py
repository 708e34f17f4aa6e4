"""The shipped heterogeneous-chain study (docs/heterogeneous.md), CPU-sized: the taper sweep
(sweeps/taper.toml) and the disorder sweep (sweeps/disorder.toml) on fewer grains, a shorter run and fewer
seeds, reduced with :mod:`hertzian.studies.realisations` into one JSON record.

``python -m hertzian.studies.heterogeneous OUT.json [--grains 40] [--seeds 20]``
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


def _run(name: str, overrides: dict, work: Path):
    import xarray as xr  # the study's stores are read back as labelled data
    from hertzian.sweeping.pipeline import sweep  # Warp and Zarr load only when the study runs

    data = tomllib.loads(resources.files("hertzian.sweeps").joinpath(f"{name}.toml").read_text())
    scene = data["scene"]
    shift = overrides["grains"] - scene["chain"]["grains"]  # traced grains keep their distance from the bottom
    scene["record"]["traces"] = [g + shift for g in scene["record"].get("traces", [])]
    scene["chain"]["grains"] = overrides["grains"]
    scene["integrator"]["duration"] = overrides["duration"]
    for axis in data["axis"]:
        if axis["name"] == "seed":
            axis.pop("linspace", None)
            axis["values"] = list(range(overrides["seeds"]))
    path = work / f"{name}.toml"
    path.write_text(_to_toml(data))
    out = work / f"{name}.zarr"
    clock = time.perf_counter()
    sweep(path, out, device="cpu", notify=lambda line: None)
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


def study(grains: int = 40, seeds: int = 20) -> dict:
    """Both sweeps at ``grains`` grains (``seeds`` realisations per spread) and their observables."""
    from hertzian.studies.realisations import observables, statistics

    with tempfile.TemporaryDirectory() as tmp:
        taper, taper_s = _run("taper", {"grains": grains, "duration": 6.0, "seeds": 1}, Path(tmp))
        found = observables(taper)
        q = taper.taper.values.tolist()
        uniform = found["bottom_fraction"][q.index(0.0)]
        disorder, disorder_s = _run("disorder", {"grains": grains, "duration": 4.0, "seeds": seeds}, Path(tmp))
        stats = statistics(disorder, "seed")
    return {
        "device": "cpu",
        "host": platform.node(),
        "date": date.today().isoformat(),
        "grains": grains,
        "taper": {
            "q": q,
            "bottom_fraction": found["bottom_fraction"].tolist(),
            "relative_to_uniform": (found["bottom_fraction"] / uniform).tolist(),
            "binary_collision_relative": [binary_collision_fraction(x, grains) for x in q],
            "arrival_time": found["arrival_time"].tolist(),
            "bottom_peak_force": found["bottom_peak_force"].tolist(),
            "seconds": taper_s,
        },
        "disorder": {
            "spread": disorder.spread.values.tolist(),
            "realisations": seeds,
            **{
                f"{name}_{k}": np.asarray(stats[name][k]).tolist()
                for name in ("decay_length", "bottom_fraction", "arrival_time", "bottom_peak_force")
                for k in ("mean", "std", "q05", "q50", "q95")
            },
            "seconds": disorder_s,
        },
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--grains", type=int, default=40)
    parser.add_argument("--seeds", type=int, default=20)
    args = parser.parse_args()
    args.out.write_text(json.dumps(study(args.grains, args.seeds), indent=1) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
