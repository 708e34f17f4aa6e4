"""The event treatment's constants against the energy error on issue 15's scene (docs/stability.md §7c).

    python docs/accuracy/event_treatment_variants.py WINDOW SUBSTEPS DT [METHOD] [FLAG_DURATION]

Runs the paper's 1000-grain impact (the built-in example, v_imp = 1e-2, l0 = 1e-4) to t = 20 with event-aware steps
(energy every 0.16) on the CPU sweep kernel, with the event window (kernels/features.py EVENT_WINDOW, time units) and
the Runge–Kutta substeps of an event step (kernels/events.py SUBSTEPS) set for this process, and prints one JSON line:
the energy error and, with FLAG_DURATION, how often grains are flagged, from u and v recorded every step over
[0, FLAG_DURATION] (the kernels' test with the sign change taken between consecutive snapshots): the share of
grain-steps, of steps with any flagged grain (per 2 time units), and which grains were ever flagged.
One configuration per process, so that the kernels are built with the constants given.
Example (the log next to this file): see event_treatment_variants.log.
"""

import json
import sys

import numpy as np

window, substeps, dt = float(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
method = sys.argv[4] if len(sys.argv) > 4 else "gear6"

import hertzian.kernels.events as events  # noqa: E402

events.SUBSTEPS = substeps
import hertzian.ensemble.model as model  # noqa: E402

model.EVENT_WINDOW = window
from hertzian.ensemble.devices import init_warp  # noqa: E402
from hertzian.ensemble.runner import Runner  # noqa: E402
from hertzian.ensemble.scene import load_scene  # noqa: E402
from hertzian.ensemble.static import static_state  # noqa: E402

init_warp()
scene = load_scene("ensemble/examples/impact.toml", {
    "integrator.duration": 20.0, "integrator.method": method, "integrator.dt": dt, "integrator.events": "auto",
    "record.every": 0.16, "record.fields": ["u"], "record.traces": [], "record.trace_every": None})
result = Runner(model.build_model([scene], "cpu"), kernel="sweep").run()
out = {"window": window, "substeps": substeps, "dt": dt, "method": method,
       "energy_error": float(result.energy_error[0])}
if len(sys.argv) > 5:
    duration = float(sys.argv[5])
    traced = scene.with_overrides({"integrator.duration": duration, "record.every": dt, "record.fields": ["u", "v"]})
    run = Runner(model.build_model([traced], "cpu"), kernel="sweep").run()
    u, v = run.fields["u"][0], run.fields["v"][0]
    n = u.shape[1]
    d0 = static_state(traced).static_overlap
    delta = np.full((u.shape[0], n + 1), np.nan)
    rate = np.full_like(delta, np.nan)
    delta[:, 1:n], rate[:, 1:n] = d0[1:n] + u[:, :-1] - u[:, 1:], v[:, :-1] - v[:, 1:]
    delta[:, 0], rate[:, 0] = d0[0] - u[:, 0], -v[:, 0]  # the surface wall
    delta[:, n], rate[:, n] = d0[n] + u[:, -1], v[:, -1]  # the bottom wall
    crossed = np.zeros_like(delta, dtype=bool)
    crossed[:-1] = (delta[:-1] > 0) != (delta[1:] > 0)
    flagged = (np.abs(delta) < np.abs(rate) * window) | crossed
    grains = flagged[:, :-1] | flagged[:, 1:]
    any_step = grains.any(axis=1)
    chunk = int(round(2.0 / dt))
    out.update({"flag_duration": duration, "flagged_grain_steps": float(grains.mean()),
                "steps_with_a_flagged_grain": float(any_step.mean()),
                "steps_with_a_flagged_grain_per_2_time_units": [round(float(any_step[i:i + chunk].mean()), 4)
                                                                for i in range(0, len(any_step), chunk)],
                "grains_ever_flagged": np.nonzero(grains.any(axis=0))[0].tolist()})
print(json.dumps(out))
