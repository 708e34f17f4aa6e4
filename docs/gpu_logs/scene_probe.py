"""The fused kernel alone on the 1000-grain bench scenes (issue 11's "traced or driven at >= 0.8x the impact rate").

    python3 docs/gpu_logs/scene_probe.py [--device cuda] [--steps 4096] [--scenes impact_1000,driven_1000]
                                         [--configs 'lanes=66'] [--out scene_probe.json]

For each scene of docs/bench/ (events off, one chain) times every shape the calibration considers
(hertzian.ensemble.solvers.calibrate: whole-chain and windowed) with calibrate.time_solver (graph replays, no
records) and prints microseconds per step, so a traced or driven scene can be compared with the impact on the
same shape, and the calibration's choice for each seen against the others.
"""

import argparse
import json
import time
from pathlib import Path

import warp as wp

from hertzian.ensemble.model import build_model
from hertzian.ensemble.scene import load_scene
from hertzian.ensemble.solvers.calibrate import time_solver, whole_chain_configs, window_configs
from hertzian.ensemble.solvers.tile import TileSolver

BENCH = Path(__file__).resolve().parent.parent / "bench"


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default="cuda")
    parser.add_argument("--steps", type=int, default=4096)
    parser.add_argument("--scenes", default="impact_1000,impact_1000_traces,driven_1000")
    parser.add_argument("--configs", default="", help="only shapes whose description contains one of these "
                        "comma-separated texts")
    parser.add_argument("--out", default="scene_probe.json")
    args = parser.parse_args()
    wp.init()
    rows = []
    wanted = [text.strip() for text in args.configs.split(",") if text.strip()]
    for name in args.scenes.split(","):
        scene = load_scene(BENCH / f"{name}.toml").with_overrides({"integrator.events": "off"})
        model = build_model([scene], args.device)
        for config in whole_chain_configs(model) + window_configs(model):
            if wanted and not any(text in config.describe() for text in wanted):
                continue
            t0 = time.perf_counter()
            try:
                seconds = time_solver(TileSolver(model, config), steps=args.steps)
            except Exception as err:  # a shape the device refuses
                print(f"{name}: {config.describe()}: {type(err).__name__}: {err}", flush=True)
                continue
            row = {"scene": name, "config": config.describe(), "us_per_step": seconds * 1e6,
                   "wall_with_compile": time.perf_counter() - t0}
            rows.append(row)
            print(f"{name}: {config.describe()}: {seconds * 1e6:.3f} us/step", flush=True)
    with open(args.out, "w") as f:
        json.dump({"device": str(wp.get_device(args.device)), "steps": args.steps, "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
