"""Where a fused window kernel's step waits: one 1000-grain bench scene's kernel under Nsight Compute.

    ncu --set full --kernel-name regex:fused --launch-skip 8 --launch-count 1 -o OUT \
        python3 docs/gpu_logs/stall_probe.py --scene driven_1000
    ncu --import OUT.ncu-rep --page source --csv --print-source sass > OUT_sass.csv

Runs the scene (events off, one chain) on the window shape the calibration picks for it (G = 4, 32 lanes, K = 32)
for a few launches without CUDA graphs, so that the profiler sees plain launches; the per-instruction warp-stall
samples then say where the driver's window spends its step, against the impact scene's.
"""

import argparse
from dataclasses import replace
from pathlib import Path

import warp as wp

from hertzian.ensemble.model import build_model
from hertzian.ensemble.scene import load_scene
from hertzian.ensemble.solvers.tile import TileSolver, config_of
from hertzian.kernels.tile import plan_tile

BENCH = Path(__file__).resolve().parent.parent / "bench"


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--scene", default="driven_1000")
    parser.add_argument("--launches", type=int, default=12)
    args = parser.parse_args()
    wp.init()
    scene = load_scene(BENCH / f"{args.scene}.toml").with_overrides({"integrator.events": "off"})
    model = build_model([scene], "cuda")
    plan = plan_tile(model.features, model.grain_count, 1, grains_per_lane=4, lanes_per_chain=32,
                     steps_per_launch=32, windowed=True)
    config = config_of(plan)
    solver = TileSolver(model, replace(config, use_graph=False))
    solver.load()
    a, b = model.state_pair()
    current = a
    for _ in range(args.launches):
        current = solver.advance(current, b if current is a else a, plan.steps_per_launch)
    wp.synchronize_device("cuda")
    print(args.scene, solver.describe())


if __name__ == "__main__":
    main()
