"""Time the fused tile kernel's event-aware steps on one device, variant by variant.

    python3 docs/gpu_logs/event_variants.py [--points 10000] [--steps 20000] [--chunk 5000] [--out FILE]

The workload is ``sweeps/gpu_10k.toml`` without traces (500-grain chains between walls, impact ×
precompression grid, gear4 float64, dt = 5e-5): all its points in one model, advanced ``--steps`` steps
from t = 0 in chunks of ``--chunk`` (so the time per chunk shows how the cost follows the motion:
event steps happen where contacts open). Variants: plain Gear steps (events off) and event-aware
steps with the event step inlined or out of line, at G = 8 and G = 4 grains per lane. Prints one JSON
object per variant as it finishes (compile seconds, seconds per chunk, grain-steps/s) and the largest
difference of the final state from the first event variant (the inline/call forms claim the same bits).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace

import numpy as np
import warp as wp

from hertzian.ensemble.solvers import make_solver
from hertzian.ensemble.solvers.tile import config_of
from hertzian.ensemble.model import build_model
from hertzian.ensemble.sweep import expand, load_sweep
from hertzian.kernels.tile import plan_tile


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--points", type=int, default=10000)
    parser.add_argument("--steps", type=int, default=20000)
    parser.add_argument("--chunk", type=int, default=5000)
    parser.add_argument("--device", default="cuda")
    parser.add_argument("--variants", default="off8,inline8,call8,inline4,call4")
    parser.add_argument("--out", default="")
    args = parser.parse_args()
    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    sweep = load_sweep("sweeps/gpu_10k.toml", {"record.traces": []})
    points = expand(sweep)
    chains = points.chains(np.arange(args.points))
    model = build_model(chains, args.device)
    f_events = model.features
    print(json.dumps({"device": str(model.device), "name": getattr(model.device, "name", ""),
                      "warp": wp.__version__, "features": repr(f_events), "chains": model.chain_count,
                      "grains": model.grain_count, "dt": model.dt}), flush=True)
    rows = time_variants(model, args.variants.split(","), args.steps, args.chunk, several_chains_per_block=True)
    if args.out:
        with open(args.out, "w") as handle:
            json.dump(rows, handle, indent=1)


def time_variants(model, variants: list[str], steps: int, chunk: int, *, several_chains_per_block: bool) -> list[dict]:
    """Time the tile kernel on ``model`` for each variant (``off``/``inline``/``call`` + G, e.g. ``call4``): plain Gear
    steps, or event-aware steps with the event step inlined or out of line, G grains per lane; ``steps`` steps from
    t = 0 in chunks of ``chunk``. Several short chains per block (up to 128 threads) or one chain per block. Prints
    and returns one row per variant; event variants are compared with the first one (``bitwise_equal``)."""
    f_events = model.features
    reference = None
    results = []
    for name in variants:
        kind, G = name.rstrip("0123456789"), int(name[len(name.rstrip("0123456789")):])
        f = replace(f_events, event_window=0.0) if kind == "off" else f_events
        lanes = -(-model.grain_count // G)
        per_block = 1
        while several_chains_per_block and per_block * 2 * lanes <= 128 and per_block * 2 <= model.chain_count:
            per_block *= 2
        plan = plan_tile(f, model.grain_count, model.chain_count, grains_per_lane=G, chains_per_block=per_block,
                         steps_per_launch=64, inline_event_step=(kind != "call"))
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
        while done < steps:
            k = min(chunk, steps - done)
            t0 = time.perf_counter()
            current = solver.advance(current, b if current is a else a, k)
            wp.synchronize_device(m.device)
            chunks.append(time.perf_counter() - t0)
            done += k
        x = current.x.numpy()
        row = {"variant": name, "plan": plan.describe(), "compile_s": compile_s, "chunk_steps": chunk,
               "chunk_s": chunks, "total_s": sum(chunks),
               "grain_steps_per_s": m.chain_count * m.grain_count * steps / sum(chunks),
               "status_nonzero": int(np.count_nonzero(current.status.numpy()))}
        if kind != "off":
            if reference is None:
                reference = x
            else:
                row["max_abs_diff_vs_first_event_variant"] = float(np.max(np.abs(x - reference)))
                row["bitwise_equal"] = bool(np.array_equal(x, reference))
        results.append(row)
        print(json.dumps(row), flush=True)
    return results


if __name__ == "__main__":
    sys.exit(main())
