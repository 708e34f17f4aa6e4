"""Does the reference of the gpu10k studies favour event-aware steps? Where does gear4's error grow?

The studies (docs/accuracy/gpu10k_<point>.json) measure every run against gear6 float64 at dt = 6.25e-6
*with* event-aware steps. For each point of docs/accuracy/gpu10k_point.toml this script runs (CPU, ``sweep``
kernel, u every 0.5):

* gear6 at 6.25e-6 with events auto and with events off, and reports their difference
  max |u_auto − u_off| / max |u_auto| (``reference_auto_vs_off``): if it is far below the errors compared,
  the choice of reference cannot decide the comparison;
* gear4 at the sweep's dt = 5e-5, events auto and off, and reports per snapshot the error against the
  events-auto reference (``error_by_record``: max over grains |u − u_ref| / max |u_ref| at t = 0, 0.5, …, 5)
  and where the largest error sits (``worst_grain``, ``worst_time``).

Output: one JSON object (device, date, command, points) on stdout. Usage, from the repository root with the
package importable as ``hertzian``:

    python docs/accuracy/gpu10k_reference_check.py > docs/accuracy/gpu10k_reference_check.json
"""

from __future__ import annotations

import datetime
import json
import os
import sys
from pathlib import Path

import numpy as np

from hertzian.ensemble.devices import init_warp
from hertzian.ensemble.model import build_model
from hertzian.ensemble.runner import Runner
from hertzian.ensemble.scene import load_scene

sys.path.insert(0, str(Path(__file__).parent))
from gpu10k_openings import POINTS, SCENE, cpu_name  # noqa: E402

REFERENCE_DT = 6.25e-6
SWEEP_DT = 5e-5


def positions(impact: float, l0: float, method: str, dt: float, events: str) -> tuple[np.ndarray, np.ndarray]:
    """(record times, u of shape (records, grains)) of one run."""
    scene = load_scene(SCENE, {"excitation.impact": impact, "chain.l0": l0, "integrator.method": method,
                               "integrator.dt": dt, "integrator.events": events, "record.fields": ["u"],
                               "record.traces": [], "record.trace_every": None})
    result = Runner(build_model([scene], "cpu"), kernel="sweep").run()
    return result.t, result.fields["u"][0]


def check(name: str, impact: float, l0: float) -> dict:
    t, ref = positions(impact, l0, "gear6", REFERENCE_DT, "auto")
    _, ref_off = positions(impact, l0, "gear6", REFERENCE_DT, "off")
    scale = float(np.max(np.abs(ref)))
    out = {"name": name, "impact": impact, "l0": l0, "reference_dt": REFERENCE_DT,
           "reference_auto_vs_off": float(np.max(np.abs(ref - ref_off)) / scale), "dt": SWEEP_DT,
           "t": [float(x) for x in t]}
    for events in ("auto", "off"):
        _, u = positions(impact, l0, "gear4", SWEEP_DT, events)
        error = np.abs(u - ref) / scale
        record, grain = np.unravel_index(int(np.argmax(error)), error.shape)
        out[events] = {"error": float(error.max()),
                       "error_by_record": [float(x) for x in error.max(axis=1)],
                       "worst_grain": int(grain), "worst_time": float(t[record])}
    return out


def main() -> None:
    init_warp()
    import warp as wp

    points = [check(name, *p) for name, p in POINTS.items()]
    print(json.dumps({
        "device": f"cpu ({cpu_name()}, {os.cpu_count()} cores, shared with other jobs)",
        "warp": wp.config.version,
        "date": datetime.date.today().isoformat(),
        "command": "python docs/accuracy/gpu10k_reference_check.py " + " ".join(sys.argv[1:]),
        "points": points,
    }, indent=1))


if __name__ == "__main__":
    main()
