"""float32 against float64 on one scene: energy error, position error and CPU wall time (issue 15).

For each method and step the scene runs three times on the same kernel: float64, float32 with the
plain update (``Features.compensated = False``, what ``precision = "float32"`` did before) and
compensated float32 (kernels/gear.py, what ``precision = "float32"`` does now). It prints one JSON
document: per run the energy error (SPEC §5, max over records and monitor checks), the position
error against the float64 run of the same method and step (max over records and grains of
|u − u_64| / max |u_64|), the status, wall seconds (compilation excluded) and the kernel.

    python docs/accuracy/float32_study.py [--scene FILE] [--set KEY=VALUE ...] \
        --runs gear4:1.25e-5,verlet:1.25e-5 [--kernel sweep] [--repeat N] > docs/accuracy/float32_paper.json

Run from the repository root with the package importable as ``hertzian``.
"""

from __future__ import annotations

import argparse
import datetime
import json
import platform
import sys
from dataclasses import replace

import numpy as np


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default=None, help="scene TOML (default: the built-in example)")
    parser.add_argument("--set", action="append", default=[], help="scene override KEY=VALUE (repeatable)")
    parser.add_argument("--runs", required=True, help="comma-separated METHOD:DT")
    parser.add_argument("--kernel", default="sweep", help="solver kind for every run (default sweep)")
    parser.add_argument("--repeat", type=int, default=1,
                        help="runs of each variant; wall_seconds is the smallest (the CPU is shared)")
    args = parser.parse_args(argv)

    import warp as wp

    from hertzian.ensemble.cli.app import example_path
    from hertzian.ensemble.devices import init_warp
    from hertzian.ensemble.model import build_model, features_of
    from hertzian.ensemble.runner import Runner
    from hertzian.ensemble.scene import load_scene, parse_overrides
    from hertzian.ensemble.status import Status

    init_warp()
    overrides = parse_overrides(args.set)
    records = []
    for item in args.runs.split(","):
        method, dt_text = item.split(":")
        dt = float(dt_text)
        u64 = None
        for precision, compensated, label in (("float64", False, "float64"), ("float32", False, "float32 plain"),
                                              ("float32", True, "float32 compensated")):
            scene = load_scene(args.scene or example_path(), {
                **overrides, "integrator.method": method, "integrator.dt": dt, "integrator.precision": precision,
                "record.fields": ["u"], "record.traces": [], "record.trace_every": None})
            features = replace(features_of([scene]), compensated=compensated)
            model = build_model([scene], "cpu", features=features)
            runs = [Runner(model, kernel=args.kernel).run() for _ in range(max(1, args.repeat))]
            result = runs[0]
            wall = min(r.wall_seconds for r in runs)
            u = np.asarray(result.fields["u"][0], dtype=np.float64)
            if u64 is None:
                u64 = u
            position_error = float(np.max(np.abs(u - u64)) / np.max(np.abs(u64))) if np.all(np.isfinite(u)) \
                else float("inf")
            status = int(result.status[0])
            record = {"method": method, "dt": dt, "variant": label, "precision": precision,
                      "compensated": compensated, "energy_error": float(result.energy_error[0]),
                      "position_error_vs_float64": position_error, "status": Status(status).name,
                      "wall_seconds": wall, "wall_seconds_all": [r.wall_seconds for r in runs],
                      "steps": result.steps, "grain_steps_per_second": result.steps * scene.chain.grains / wall,
                      "kernel": result.kernel, "event_window": result.features.event_window,
                      "state_rows": result.features.values}
            records.append(record)
            print(json.dumps(record), file=sys.stderr, flush=True)
    json.dump({"device": "cpu", "cpu": platform.processor() or platform.machine(),
               "warp": wp.config.version, "date": datetime.date.today().isoformat(),
               "command": "python docs/accuracy/float32_study.py " + " ".join(argv if argv is not None else sys.argv[1:]),
               "scene": args.scene or "built-in example (ensemble/examples/impact.toml)",
               "records": records}, sys.stdout, indent=1)
    print()


if __name__ == "__main__":
    main()
