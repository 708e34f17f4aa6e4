"""Which feature makes the window kernel slow on a driven 10 000-grain column (issue 11, Figs. 9-10)?

    python3 docs/gpu_logs/window_probe.py [--device cuda] [--steps 4096] [--chains 2,64] [--variants 0,4] [--out probe.json]

Times the fused window kernel alone (hertzian.ensemble.solvers.calibrate.time_solver: graph replays, no
records) on 10 000-grain columns that differ in one feature at a time from sweeps/paper_fig9_10.toml
(driven surface, g = 1, fixed bottom, events off), for the shapes the calibration considers, and prints
microseconds per step and grain-steps per second for 2 and 64 chains.
"""

import argparse
import json
import time

import warp as wp

from hertzian.ensemble.model import build_model
from hertzian.ensemble.scene import scene_from_dict
from hertzian.ensemble.solvers.calibrate import time_solver, window_configs
from hertzian.ensemble.solvers.tile import TileSolver

BASE = {
    "chain": {"grains": 10000, "gravity": 1.0},
    "boundary": {"surface": "driven", "bottom": "fixed"},
    "excitation": {"drive_amplitude": 2.0, "drive_period": 10.0},
    "integrator": {"method": "gear4", "events": "off", "dt": 1.25e-4, "duration": 1.0},
    "record": {"every": 1.0, "fields": ["v"]},
}
VARIANTS = {
    "fig9_10 (driven, g=1, fixed)": {},
    "driven A=1e-4, g=1, fixed": {"excitation": {"drive_amplitude": 1e-4, "drive_period": 10.0}},
    "driven, g=0 l0=1e-4, fixed": {"chain": {"grains": 10000, "gravity": 0.0, "l0": 1e-4}},
    "impact, g=1, fixed": {"boundary": {"surface": "free", "bottom": "fixed"},
                           "excitation": {"impact": 1e-2}},
    "impact, g=0 l0=1e-4, walls": {"chain": {"grains": 10000, "gravity": 0.0, "l0": 1e-4},
                                   "boundary": {"surface": "wall", "bottom": "wall"},
                                   "excitation": {"impact": 1e-2}},
}


def scene(variant: dict):
    data = {k: dict(v) for k, v in BASE.items()}
    for key, value in variant.items():
        data[key] = dict(value)
    if "impact" in data["excitation"]:
        data["excitation"] = {"impact": data["excitation"]["impact"]}
    return scene_from_dict(data)


def timed_configs(model, configs, wanted: list[str], steps: int, label: str):
    """(config, seconds per step, wall seconds with the compile) for each of ``configs`` whose description contains
    one of ``wanted`` (all when empty), timed by calibrate.time_solver; a shape the device refuses is printed and
    skipped."""
    for config in configs:
        if wanted and not any(text in config.describe() for text in wanted):
            continue
        t0 = time.perf_counter()
        try:
            seconds = time_solver(TileSolver(model, config), steps=steps)
        except Exception as err:  # a shape the device refuses
            print(f"{label}: {config.describe()}: {type(err).__name__}: {err}", flush=True)
            continue
        yield config, seconds, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default="cuda")
    parser.add_argument("--steps", type=int, default=4096)
    parser.add_argument("--chains", default="2,64")
    parser.add_argument("--variants", default="", help="indices into VARIANTS, comma-separated (default: all)")
    parser.add_argument("--configs", default="", help="only shapes whose description contains one of these "
                        "comma-separated texts (e.g. 'lanes=32 K=32')")
    parser.add_argument("--out", default="window_probe.json")
    args = parser.parse_args()
    wp.init()
    rows = []
    for chains in [int(c) for c in args.chains.split(",")]:
        picked = [int(i) for i in args.variants.split(",")] if args.variants else range(len(VARIANTS))
        for name, variant in [list(VARIANTS.items())[i] for i in picked]:
            s = scene(variant)
            model = build_model([s] * chains, args.device)
            wanted = [text.strip() for text in args.configs.split(",") if text.strip()]
            for config, seconds, wall in timed_configs(model, window_configs(model), wanted, args.steps,
                                                       f"{chains} x {name}"):
                row = {"chains": chains, "variant": name, "config": config.describe(),
                       "us_per_step": seconds * 1e6, "grain_steps_per_second": chains * 10000 / seconds,
                       "wall_with_compile": wall}
                rows.append(row)
                print(f"{chains} x {name}: {config.describe()}: {seconds * 1e6:.3f} us/step, "
                      f"{row['grain_steps_per_second']:.3g} GS/s", flush=True)
    with open(args.out, "w") as f:
        json.dump({"device": str(wp.get_device(args.device)), "steps": args.steps, "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
