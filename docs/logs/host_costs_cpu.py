"""Host cost of one sweep batch's build, piece by piece (issue 17), on any device; no integration.

    PYTHONPATH=... python docs/logs/host_costs_cpu.py [--device cpu] [--batches 3]

For sweeps/million.toml (40 000-point batches of 100-grain chains with an impurity) it times, per
batch: the ChainSet, ``static_arrays``, ``prepare_model`` (the host half of build_model, where this
version has it), ``build_model`` and ``Runner(...)``. Used for docs/logs/host_costs_cpu.txt.
"""

import argparse
import time

import numpy as np
import warp as wp

from hertzian.ensemble.model import build_model
from hertzian.ensemble.runner import Runner
from hertzian.ensemble.static import static_arrays
from hertzian.ensemble.sweep import expand, load_sweep

try:
    from hertzian.ensemble.model import prepare_model
except ImportError:  # a version before the split
    prepare_model = None


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--batches", type=int, default=3)
    args = parser.parse_args()
    wp.config.quiet = True
    wp.init()
    points = expand(load_sweep("sweeps/million.toml", {"integrator.duration": 1e-3}))
    size = 40000
    for b in range(args.batches):
        t0 = time.perf_counter()
        chains = points.chains(np.arange(b * size, (b + 1) * size))
        t1 = time.perf_counter()
        static_arrays(chains)
        t2 = time.perf_counter()
        if prepare_model is not None:
            prepare_model(chains)
        t3 = time.perf_counter()
        model = build_model(chains, args.device)
        wp.synchronize_device(model.device)
        t4 = time.perf_counter()
        runner = Runner(model, kernel="step")
        wp.synchronize_device(model.device)
        t5 = time.perf_counter()
        del runner, model
        print(f"batch {b}: chains {t1 - t0:.3f} s, static_arrays {t2 - t1:.3f} s, prepare_model "
              f"{(t3 - t2) if prepare_model else float('nan'):.3f} s, build_model {t4 - t3:.3f} s, "
              f"Runner() {t5 - t4:.3f} s", flush=True)


if __name__ == "__main__":
    main()
