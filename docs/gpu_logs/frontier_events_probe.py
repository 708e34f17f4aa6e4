"""Time the fused tile kernel with and without event-aware steps on issue 15's frontier workload.

    python3 docs/gpu_logs/frontier_events_probe.py [--method gear6] [--dt 1e-3] [--steps 20000] [--chunk 2000]
        [--variants off4,call4,off8,call8] [--chains 16384] [--out FILE]

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
import time
from dataclasses import replace

import numpy as np
import warp as wp

from hertzian.ensemble.model import build_model
from hertzian.ensemble.solvers import make_solver
from hertzian.ensemble.solvers.tile import config_of
from hertzian.ensemble.sweep import expand, load_sweep
from hertzian.kernels.tile import plan_tile


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--method", default="gear6")
    parser.add_argument("--dt", type=float, default=1e-3)
    parser.add_argument("--chains", type=int, default=16384)
    parser.add_argument("--steps", type=int, default=20000)
    parser.add_argument("--chunk", type=int, default=2000)
    parser.add_argument("--device", default="cuda")
    parser.add_argument("--variants", default="off4,call4,off8,call8")
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
    reference = None
    results = []
    for name in args.variants.split(","):
        kind, G = name.rstrip("0123456789"), int(name[len(name.rstrip("0123456789")):])
        f = replace(f_events, event_window=0.0) if kind == "off" else f_events
        plan = plan_tile(f, model.grain_count, model.chain_count, grains_per_lane=G, steps_per_launch=64,
                         inline_event_step=(kind != "call"))
        m = replace(model, features=f) if kind == "off" else model
        solver = make_solver(m, config_of(plan))
        t0 = time.perf_counter()
        solver.load()
        wp.synchronize_device(m.device)
        compile_s = time.perf_counter() - t0
        a, b = m.state_pair()
        current = a
        chunks = []
        done = 0
        while done < args.steps:
            k = min(args.chunk, args.steps - done)
            t0 = time.perf_counter()
            current = solver.advance(current, b if current is a else a, k)
            wp.synchronize_device(m.device)
            chunks.append(time.perf_counter() - t0)
            done += k
        x = current.x.numpy()
        row = {"variant": name, "plan": plan.describe(), "compile_s": compile_s, "chunk_steps": args.chunk,
               "chunk_s": chunks, "total_s": sum(chunks),
               "grain_steps_per_s": m.chain_count * m.grain_count * args.steps / sum(chunks),
               "status_nonzero": int(np.count_nonzero(current.status.numpy()))}
        if kind != "off":
            if reference is None:
                reference = x
            else:
                row["max_abs_diff_vs_first_event_variant"] = float(np.max(np.abs(x - reference)))
                row["bitwise_equal"] = bool(np.array_equal(x, reference))
        results.append(row)
        print(json.dumps(row), flush=True)
    if args.out:
        with open(args.out, "w") as handle:
            json.dump(results, handle, indent=1)


if __name__ == "__main__":
    sys.exit(main())
