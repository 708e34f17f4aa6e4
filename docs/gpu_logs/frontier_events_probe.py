"""Time the fused tile kernel with and without event-aware steps on issue 15's frontier workload.

    python3 docs/gpu_logs/frontier_events_probe.py [--method gear6] [--dt 1e-3] [--steps 20000] [--chunk 2000]
        [--variants off4,inline4,off8,inline8] [--chains 16384] [--out FILE]

The workload is ``sweeps/frontier_16384.toml`` (16 384 copies of the paper's 1000-grain impact, v_imp within
±1 %, l0 = 1e-4, to t = 20): all chains in one model, advanced ``--steps`` steps from t = 0 in chunks of
``--chunk`` (the time per chunk shows how the cost follows the motion). Variants: plain Gear steps (``off``)
and event-aware steps (``inline``: the event step inlined, the default; ``call``: out of line) at G grains per
lane, one chain per block. Prints one JSON object per variant (compile seconds, seconds per chunk, grain-steps/s, the largest
difference of the final state from the first event variant, how many chains ended not OK).
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np
import warp as wp

from event_variants import time_variants  # (this folder: the scripts run as files)
from hertzian.ensemble.model import build_model
from hertzian.ensemble.sweep import expand, load_sweep


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--method", default="gear6")
    parser.add_argument("--dt", type=float, default=1e-3)
    parser.add_argument("--chains", type=int, default=16384)
    parser.add_argument("--steps", type=int, default=20000)
    parser.add_argument("--chunk", type=int, default=2000)
    parser.add_argument("--device", default="cuda")
    parser.add_argument("--variants", default="off4,inline4,off8,inline8")
    parser.add_argument("--out", default="")
    args = parser.parse_args()
    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    sweep = load_sweep("sweeps/frontier_16384.toml", {"integrator.method": args.method, "integrator.dt": args.dt,
                                                       "integrator.events": "auto"})
    chains = expand(sweep).chains(np.arange(args.chains))
    model = build_model(chains, args.device)
    f_events = model.features
    print(json.dumps({"device": str(model.device), "name": getattr(model.device, "name", ""),
                      "warp": wp.__version__, "features": repr(f_events), "chains": model.chain_count,
                      "grains": model.grain_count, "dt": model.dt}), flush=True)
    rows = time_variants(model, args.variants.split(","), args.steps, args.chunk, several_chains_per_block=False)
    if args.out:
        with open(args.out, "w") as handle:
            json.dump(rows, handle, indent=1)


if __name__ == "__main__":
    sys.exit(main())
