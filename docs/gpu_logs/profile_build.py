"""Where a million-point sweep's host-side batch build goes (docs/sweeps.md, issue 17).

    python3 docs/gpu_logs/profile_build.py [--device cuda] [--batches 2]

For sweeps/million.toml (40 000-point batches of 100-grain chains) it times, per batch: the ChainSet,
``static_arrays``, ``build_model``, ``Runner(...)`` (kernel choice, state buffers, initial state,
recorder) and ``runner.run()``; then prints cProfile's top functions of one batch's build + Runner.
"""

import argparse
import cProfile
import io
import pstats
import time

import numpy as np
import warp as wp

from hertzian.ensemble.model import build_model
from hertzian.ensemble.runner import Runner
from hertzian.ensemble.static import static_arrays
from hertzian.ensemble.sweep import expand, load_sweep


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default="cuda")
    parser.add_argument("--batches", type=int, default=2)
    args = parser.parse_args()
    wp.config.quiet = True
    wp.init()
    points = expand(load_sweep("sweeps/million.toml"))
    size = 40000
    for b in range(args.batches):
        t0 = time.perf_counter()
        chains = points.chains(np.arange(b * size, (b + 1) * size))
        t1 = time.perf_counter()
        static_arrays(chains)
        t2 = time.perf_counter()
        model = build_model(chains, args.device)
        wp.synchronize_device(model.device)
        t3 = time.perf_counter()
        runner = Runner(model)
        wp.synchronize_device(model.device)
        t4 = time.perf_counter()
        runner.run()
        t5 = time.perf_counter()
        print(f"batch {b}: chains {t1 - t0:.3f} s, static_arrays {t2 - t1:.3f} s, build_model {t3 - t2:.3f} s, "
              f"Runner() {t4 - t3:.3f} s, run() {t5 - t4:.3f} s ({runner.solver.describe()})", flush=True)
    chains = points.chains(np.arange(size))
    profile = cProfile.Profile()
    profile.enable()
    model = build_model(chains, args.device)
    Runner(model)
    wp.synchronize_device(model.device)
    profile.disable()
    text = io.StringIO()
    pstats.Stats(profile, stream=text).sort_stats("cumulative").print_stats(30)
    print(text.getvalue())


if __name__ == "__main__":
    main()
