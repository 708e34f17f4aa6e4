"""Is a batch's build slower beside the store-writing thread? (issue 17; docs/logs/host_costs_cpu.txt)

    PYTHONPATH=... python docs/logs/host_costs_writer.py [--device cpu] [--batches 8]

Runs the first batches of sweeps/million.toml (40 000 points, 10 steps) twice into fresh stores:
each write waited for before the next build ("serial"), and each write in a background thread beside
the next batch (``run_serial``, "overlapped"); prints the summed build seconds of each.
"""

import argparse
import tempfile
import time
from pathlib import Path

import warp as wp

from hertzian.ensemble.distributed import integrate_job, jobs_for, run_serial, write_job
from hertzian.ensemble.planner import plan_sweep
from hertzian.ensemble.sweep import expand, load_sweep
from hertzian.ensemble.sweep_store import batch_records, create_sweep_store


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--batches", type=int, default=8)
    args = parser.parse_args()
    wp.config.quiet = True
    wp.init()
    sweep = load_sweep("sweeps/million.toml", {"integrator.duration": 1e-3})
    points = expand(sweep)
    plan = plan_sweep(sweep, points, args.device, batch_size=40000)
    with tempfile.TemporaryDirectory() as tmp:
        for mode in ("serial", "overlapped", "serial", "overlapped"):
            out = Path(tmp) / f"{mode}.zarr"
            create_sweep_store(out, sweep, points.templates[0], plan, device=args.device, overwrite=True)
            jobs = jobs_for(out, plan, points, plan.batches[:args.batches], kernel="step")
            clock = time.perf_counter()
            if mode == "serial":
                for job in jobs:
                    result, build = integrate_job(job, args.device)
                    write_job(job, result, build)
            else:
                run_serial(jobs, args.device, overlap=False)
            wall = time.perf_counter() - clock
            records = batch_records(out)
            print(f"{mode:10s}: {len(records)} batches, wall {wall:.2f} s, build {sum(r['build_seconds'] for r in records):.2f} s, "
                  f"write {sum(r['write_seconds'] for r in records):.2f} s, runner {sum(r['wall_seconds'] for r in records):.2f} s",
                  flush=True)


if __name__ == "__main__":
    main()
