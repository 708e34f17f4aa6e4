"""Fixed costs on this machine: ``hertzian run`` wall time with the per-step and the chain kernel, cold (an empty
Warp kernel cache) and warm, compile concurrency (``prepare_kernels`` with 1, 2 workers on a cold cache), and what
the CPU ``auto`` rule reads (hertzian.core.solvers.calibrate.CPU_COSTS): each stepping kernel's compile seconds and
its warm rate [grain-steps/s], with the crossover they give.

``python -m hertzian.studies.fixed_costs --out docs/records/bench/cpu_auto_rule.json`` regenerates the record.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

CASES = ((20, 1.0), (200, 5.0), (1000, 5.0))
"""(grains, duration) of the timed runs: the example impact scene with these keys set."""

COMPILE_PROBE = """
import sys, time
import warp as wp
wp.config.quiet = True
from hertzian.kernels.features import Features
from hertzian.core.solvers.prepare import Need, prepare_kernels
needs = [Need(Features(method=m, static=s), 200, 1, 10**6, k) for m in ("gear4", "gear5")
         for s in ("none", "uniform") for k in ("step", "chain")]
print(prepare_kernels(needs, "cpu", max_workers=int(sys.argv[1]))["seconds"])
"""


KERNEL_PROBE = """
import json, sys, time
import warp as wp
wp.config.quiet = True
from hertzian.core.model import build_model
from hertzian.core.runner import Runner
from hertzian.core.scene import load_scene
from hertzian.core.shipped import example_path
from hertzian.core.solvers.calibrate import cpu_kernel_config
from hertzian.core.solvers.compile import load_variants, solver_variants
kind, grains, steps = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
scene = load_scene(example_path(), {"chain.grains": grains, "integrator.duration": steps * 5e-5,
                                    "record.traces": [], "record.every": steps * 5e-5})
model = build_model([scene], "cpu")
config = cpu_kernel_config(kind)
start = time.perf_counter()
load_variants(solver_variants(config, model.features, model.grain_count, 1), "cpu")
compile_s = time.perf_counter() - start
Runner(model, kernel=config).run()  # warm-up: record kernels, first launch
runner = Runner(model, kernel=config)
start = time.perf_counter()
runner.run()
run_s = time.perf_counter() - start
print(json.dumps({"compile_s": compile_s, "rate": grains * steps / run_s}))
"""
"""A cold process (its own empty Warp cache): compile seconds of one stepping kernel (``step`` or ``chain``) for the
example scene at the given grains, then its warm rate over the given steps [grain-steps/s]."""


def _wall(args: list[str], cache: str) -> float:
    env = {**os.environ, "WARP_CACHE_PATH": cache}
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "hertzian.cli", *args], env=env, check=True, capture_output=True)
    return time.perf_counter() - start


def time_runs(out_dir: str) -> list[dict]:
    """Process wall time [s] of ``hertzian run`` per case, kernel and cache state (cold first, then warm)."""
    rows = []
    for grains, duration in CASES:
        for kernel in ("step", "chain"):
            cache = tempfile.mkdtemp(prefix="warp-cache-")
            args = [
                "run",
                "--device",
                "cpu",
                "--quiet",
                "--overwrite",
                "--kernel",
                kernel,
                "--out",
                f"{out_dir}/o.zarr",
            ]
            args += ["--set", f"chain.grains={grains}", "--set", f"integrator.duration={duration}"]
            cold, warm = _wall(args, cache), _wall(args, cache)
            rows.append({"grains": grains, "duration": duration, "kernel": kernel, "cold_s": cold, "warm_s": warm})
    return rows


def time_compiles() -> dict[str, float]:
    """Seconds to prepare 8 variants on a cold cache with 1 and 2 compile threads (process wall time)."""
    out = {}
    for workers in (1, 2):
        cache = tempfile.mkdtemp(prefix="warp-cache-")
        env = {**os.environ, "WARP_CACHE_PATH": cache}
        result = subprocess.run(
            [sys.executable, "-c", COMPILE_PROBE, str(workers)], env=env, check=True, capture_output=True, text=True
        )
        out[f"workers_{workers}_s"] = float(result.stdout.strip().splitlines()[-1])
    return out


def time_kernel_costs(grains: int = 200, steps: int = 20000) -> dict:
    """Compile seconds (cold cache, one process each) and warm rate [grain-steps/s] of the per-step and the chain
    kernel, and the crossover [grain-steps] of the CPU ``auto`` rule they give (calibrate.cpu_crossovers)."""
    from hertzian.core.solvers.calibrate import cpu_crossovers

    out = {"grains": grains, "steps": steps}
    for kind in ("step", "chain"):
        env = {**os.environ, "WARP_CACHE_PATH": tempfile.mkdtemp(prefix="warp-cache-")}
        result = subprocess.run(
            [sys.executable, "-c", KERNEL_PROBE, kind, str(grains), str(steps)],
            env=env,
            check=True,
            capture_output=True,
            text=True,
        )
        out[kind] = json.loads(result.stdout.strip().splitlines()[-1])
    costs = {kind: (out[kind]["compile_s"], out[kind]["rate"]) for kind in ("step", "chain")}
    out["crossover_grain_steps"] = cpu_crossovers(costs)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        record = {
            "command": f"python -m hertzian.studies.fixed_costs --out {args.out}",
            "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "device": "cpu",
            "cpu_count": os.cpu_count(),
            "platform": platform.platform(),
            "runs": time_runs(tmp),
            "compile_8_variants": time_compiles(),
            "kernel_costs": time_kernel_costs(),
        }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
