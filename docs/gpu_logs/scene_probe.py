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
from pathlib import Path

import warp as wp

from hertzian.ensemble.model import build_model
from hertzian.ensemble.scene import load_scene
from hertzian.ensemble.solvers.calibrate import whole_chain_configs, window_configs
from window_probe import timed_configs  # this folder's window probe (the script's folder is on sys.path)

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
        configs = whole_chain_configs(model) + window_configs(model)
        for config, seconds, wall in timed_configs(model, configs, wanted, args.steps, name):
            row = {"scene": name, "config": config.describe(), "us_per_step": seconds * 1e6,
                   "wall_with_compile": wall}
            rows.append(row)
            print(f"{name}: {config.describe()}: {seconds * 1e6:.3f} us/step", flush=True)
    with open(args.out, "w") as f:
        json.dump({"device": str(wp.get_device(args.device)), "steps": args.steps, "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
