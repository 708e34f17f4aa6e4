"""Do contacts open at the studied points of the GPU sweep (sweeps/gpu_10k.toml)? How often are event steps due?

For each point (impact speed v_imp, precompression l0) of docs/accuracy/gpu10k_point.toml this runs the
scene once (gear4, float64, events auto, dt = 2.5e-5, u and v every 0.0025 program time units, CPU) and
reports, from those snapshots:

* ``event_code``: whether event-aware steps are compiled at all (``ensemble/model.py`` ``contact_can_open``:
  an energy bound; False means events = auto runs exactly the plain steps);
* ``contacts_opened``: how many of the chain's contacts (walls included) have total overlap
  δ = δ0 + u_i − u_{i+1} ≤ 0 at some snapshot (sampled: an opening shorter than 0.0025 can be missed);
* ``flagged_fraction``: the fraction of (grain, snapshot) pairs where the grain touches a contact that the
  kernels' event test flags, |δ| < |δ̇|·window (window = ``hertzian.kernels.features.EVENT_WINDOW``), or
  that is open and closing/opening (the sign-change half of the test needs the prediction, so it is
  approximated by δ ≤ 0 with δ̇ ≠ 0). A flagged grain takes an event step (8 Runge–Kutta substeps) instead
  of a Gear step; this fraction is a sampled estimate of the share of grain-steps that do so.

Output: one JSON object (device, date, command, points) on stdout. Usage, from the repository root with the
package importable as ``hertzian``:

    python docs/accuracy/gpu10k_openings.py > docs/accuracy/gpu10k_openings.json
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import sys
from pathlib import Path

import numpy as np

from hertzian.ensemble.devices import init_warp
from hertzian.ensemble.model import build_model, contact_can_open
from hertzian.ensemble.runner import Runner
from hertzian.ensemble.scene import load_scene
from hertzian.ensemble.static import static_state
from hertzian.kernels.features import EVENT_WINDOW

SCENE = Path(__file__).with_name("gpu10k_point.toml")
L0_CENTRE = float(np.logspace(-6, -3, 100)[49])  # the grid value nearest the logspace midpoint 10^-4.5
POINTS = {
    "vimp1e-3_l01e-6": (1e-3, 1e-6),
    "vimp1e-3_l01e-3": (1e-3, 1e-3),
    "vimp1e-1_l01e-6": (1e-1, 1e-6),
    "vimp1e-1_l01e-3": (1e-1, 1e-3),
    "vimp1e-2_l03.05e-5": (1e-2, L0_CENTRE),
}
DT = 2.5e-5
EVERY = 2.5e-3


def overlaps(u: np.ndarray, v: np.ndarray, delta0: np.ndarray, surface_wall: bool, bottom_wall: bool):
    """Total overlaps and their rates of the padded contacts (R, N + 1); NaN where there is no contact."""
    records, grains = u.shape
    delta = np.full((records, grains + 1), np.nan)
    rate = np.full((records, grains + 1), np.nan)
    delta[:, 1:grains] = delta0[1:grains] + u[:, :-1] - u[:, 1:]
    rate[:, 1:grains] = v[:, :-1] - v[:, 1:]
    if surface_wall:
        delta[:, 0] = delta0[0] - u[:, 0]
        rate[:, 0] = -v[:, 0]
    if bottom_wall:
        delta[:, grains] = delta0[grains] + u[:, -1]
        rate[:, grains] = v[:, -1]
    return delta, rate


def study(name: str, impact: float, l0: float) -> dict:
    scene = load_scene(SCENE, {"excitation.impact": impact, "chain.l0": l0, "integrator.dt": DT,
                               "integrator.events": "auto", "record.every": EVERY, "record.fields": ["u", "v"],
                               "record.traces": [], "record.trace_every": None})
    static = static_state(scene)
    result = Runner(build_model([scene], "cpu"), kernel="sweep").run()
    u, v = result.fields["u"][0], result.fields["v"][0]
    delta, rate = overlaps(u, v, static.static_overlap, scene.boundary.surface == "wall",
                           scene.boundary.bottom == "wall")
    present = ~np.isnan(delta[0])
    opened = np.any(delta[:, present] <= 0.0, axis=0)
    flagged_contact = np.zeros_like(delta, dtype=bool)
    flagged_contact[:, present] = ((np.abs(delta[:, present]) < np.abs(rate[:, present]) * EVENT_WINDOW)
                                   | ((delta[:, present] <= 0.0) & (rate[:, present] != 0.0)))
    # grain i touches padded contacts i (above) and i + 1 (below)
    flagged_grain = flagged_contact[:, :-1] | flagged_contact[:, 1:]
    return {
        "name": name, "impact": impact, "l0": l0, "dt": DT, "snapshot_every": EVERY,
        "event_code": bool(contact_can_open(scene, static)), "kernel": result.kernel,
        "status": int(result.status[0]), "energy_error": float(result.energy_error[0]),
        "contacts": int(present.sum()), "contacts_opened": int(opened.sum()),
        "first_opened": int(np.argmax(opened)) if opened.any() else None,
        "last_opened": int(len(opened) - 1 - np.argmax(opened[::-1])) if opened.any() else None,
        "flagged_fraction": float(flagged_grain[1:].mean()),
        "grains_ever_flagged": int(np.any(flagged_grain[1:], axis=0).sum()),
        "grains_moved": int(np.any(np.abs(u) > 1e-3 * np.max(np.abs(u)), axis=0).sum()),
    }


def cpu_name() -> str:
    """The CPU's model name (Linux), else the machine type."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.machine()


def main() -> None:
    init_warp()
    import warp as wp

    points = [study(name, *p) for name, p in POINTS.items()]
    print(json.dumps({
        "device": f"cpu ({cpu_name()}, {os.cpu_count()} cores, shared with other jobs)",
        "warp": wp.config.version,
        "date": datetime.date.today().isoformat(),
        "command": "python docs/accuracy/gpu10k_openings.py " + " ".join(sys.argv[1:]),
        "event_window": EVENT_WINDOW,
        "points": points,
    }, indent=1))


if __name__ == "__main__":
    main()
