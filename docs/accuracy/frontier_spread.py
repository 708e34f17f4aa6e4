"""Energy error across the impact speeds of issue 15's GPU workload, per method, events mode and step.

    python docs/accuracy/frontier_spread.py > docs/accuracy/frontier_spread_cpu.json

The timed workload (sweeps/frontier_16384.toml) runs 16 384 copies of the paper's 1000-grain impact with v_imp
spread evenly over [0.0099, 0.0101]. The energy error near a contact opening is erratic in dt and in v_imp, so a
step that meets a target at v_imp = 1e-2 alone may miss it a percent away. This runs 9 of the sweep's own points
(indices 0, 2048, …, 16 383) to t = 20 (energy every 0.16, as the sweep records it) on the CPU sweep kernel for
each configuration below, and prints the largest energy error over them next to the one at v_imp = 1e-2.
"""

from __future__ import annotations

import datetime
import json
import sys

import numpy as np

from hertzian.ensemble.devices import init_warp
from hertzian.ensemble.model import build_model
from hertzian.ensemble.runner import Runner
from hertzian.ensemble.scene import load_scene

CONFIGS = [  # (method, events, dt)
    ("gear4", "off", 2e-4), ("gear4", "off", 1.6e-4), ("gear4", "off", 1.25e-4), ("gear4", "off", 1e-4),
    ("gear4", "auto", 6.4e-4), ("gear4", "auto", 5e-4), ("gear4", "auto", 4e-4), ("gear4", "auto", 3.2e-4),
    ("gear6", "auto", 1.25e-3), ("gear6", "auto", 1e-3), ("gear6", "auto", 8e-4),
]
INDICES = [0, 2048, 4096, 6144, 8192, 10240, 12288, 14336, 16383]
SPEEDS = [float(v) for v in np.linspace(0.0099, 0.0101, 16384)[INDICES]]


def energy_errors(method: str, events: str, dt: float) -> list[float]:
    scenes = [load_scene("ensemble/examples/impact.toml", {
        "integrator.duration": 20.0, "integrator.method": method, "integrator.dt": dt, "integrator.events": events,
        "record.every": 0.16, "record.fields": [], "record.traces": [], "record.trace_every": None,
        "excitation.impact": v}) for v in SPEEDS + [1e-2]]
    result = Runner(build_model(scenes, "cpu"), kernel="sweep").run()
    return [float(e) for e in result.energy_error]


def main() -> None:
    init_warp()
    rows = []
    for method, events, dt in CONFIGS:
        errors = energy_errors(method, events, dt)
        rows.append({"method": method, "events": events, "dt": dt, "energy_error_at_1e-2": errors[-1],
                     "largest_energy_error": max(errors[:-1]), "energy_errors": errors[:-1]})
        print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    print(json.dumps({"device": "cpu", "date": datetime.date.today().isoformat(),
                      "command": "python docs/accuracy/frontier_spread.py", "v_imp": SPEEDS, "sweep_indices": INDICES,
                      "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
