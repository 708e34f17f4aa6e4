"""The extreme-case suite and the accuracy thresholds it sets (hertzian.core.check.ACCURATE_STEPS_PER_CONTACT_TIME).

Twelve extremes of the paper's chain (30 grains, l0 = 1e-4, v_imp = 1e-2, duration 0.3), one key changed each: the
slowest and fastest impacts, no precompression, strong precompression, impurity masses and contact constants 1e-3
and 1e3 (``contact = "own"``), exponents 2 and 3, gravity g = 100. A method's threshold is the fewest steps per
contact time T/dt, on a grid, at which every extreme run at the step ``hertzian check`` then suggests keeps its
energy error ≤ 1e-6 with status OK (docs/stability.md §5), with each event setting asked for (``--events``; the
threshold is then the largest of theirs, since ``hertzian check`` does not ask which one a run takes).

``python -m hertzian.studies.thresholds --methods yoshida4,yoshida6 --ratios 100,150,200,300,400 --out FILE``
writes each method's worst energy error and failing cases at each ratio (``--into KEY`` merges them into FILE's KEY).
"""

from __future__ import annotations

import argparse
import json
import math
import platform
from datetime import datetime, timezone
from pathlib import Path

from hertzian.core.outputs import exit_unless_replaceable
from hertzian.core.scene import Scene, scene_from_dict

IMPURITY = {"grains": [3], "contact": "own"}
EXTREMES = {
    "v_imp=1e-6": dict(excitation={"impact": 1e-6}),
    "v_imp=10": dict(excitation={"impact": 10.0}),
    "l0=0": dict(chain={"l0": 0.0}),
    "l0=0,v_imp=10": dict(chain={"l0": 0.0}, excitation={"impact": 10.0}),
    "l0=1e-2": dict(chain={"l0": 1e-2}),
    "mass=1e-3": dict(impurities=[{**IMPURITY, "mass": 1e-3}]),
    "mass=1e3": dict(impurities=[{**IMPURITY, "mass": 1e3}]),
    "a=1e-3": dict(impurities=[{**IMPURITY, "a": 5.657}]),
    "a=1e3": dict(impurities=[{**IMPURITY, "a": 5.657e6}]),
    "n=2": dict(chain={"exponent": 2.0}),
    "n=3": dict(chain={"exponent": 3.0}),
    "g=100": dict(chain={"gravity": 100.0}),
}
"""Each extreme: the sections it changes in the paper's chain."""

ENERGY_BOUND = 1e-6
"""The energy error every extreme must keep at a method's threshold."""


def extreme(case: str, method: str, events: str = "auto") -> Scene:
    """The extreme ``case`` for ``method`` with ``integrator.events = events``, at the step ``hertzian check``
    suggests (the largest dt dividing the record interval 0.01 at or below it)."""
    from hertzian.core.check import check_scene

    spec = json.loads(json.dumps(EXTREMES[case]))
    data = {
        "chain": {"grains": 30, "l0": 1e-4, **spec.pop("chain", {})},
        "excitation": spec.pop("excitation", {"impact": 1e-2}),
        **spec,
        "integrator": {"method": method, "duration": 0.3, "events": events},
        "record": {"every": 0.01, "fields": ["u"]},
    }
    scene = scene_from_dict(data)
    step = check_scene(scene).suggested_dt
    return scene.with_overrides({"integrator.dt": 0.01 / math.ceil(0.01 / step - 1e-9)})


def scan(methods: list[str], ratios: list[float], device: str = "cpu", events: tuple[str, ...] = ("auto",)) -> dict:
    """Per method, event setting and ratio T/dt (set as its threshold while the suite runs): the worst energy error
    over the extremes, those above ENERGY_BOUND or not OK, and the smallest ratio of the grid that all keep. With one
    event setting each method's entry is that setting's; with several, ``events`` holds each one's and
    ``threshold`` is the largest of theirs (None if one has none)."""
    from hertzian.core import check

    out: dict = {}
    saved = dict(check.ACCURATE_STEPS_PER_CONTACT_TIME)
    try:
        for method in methods:
            each = {setting: _scan_one(method, ratios, device, setting) for setting in events}
            if len(events) == 1:
                out[method] = each[events[0]]
                continue
            thresholds = [row["threshold"] for row in each.values()]
            out[method] = {"events": each, "threshold": None if None in thresholds else max(thresholds)}
    finally:
        check.ACCURATE_STEPS_PER_CONTACT_TIME.clear()
        check.ACCURATE_STEPS_PER_CONTACT_TIME.update(saved)
    return out


def _scan_one(method: str, ratios: list[float], device: str, events: str) -> dict:
    """One method and event setting of :func:`scan` (the caller restores the thresholds it sets)."""
    from hertzian.core import check
    from hertzian.core.runner import run_scene

    rows = {}
    for ratio in ratios:
        check.ACCURATE_STEPS_PER_CONTACT_TIME[method] = ratio
        errors, failing = {}, []
        for case in EXTREMES:
            result = run_scene(extreme(case, method, events), device)
            errors[case] = float(result.energy_error[0])
            if errors[case] > ENERGY_BOUND or result.status[0] != 0:
                failing.append(case)
        rows[f"{ratio:g}"] = {"worst_energy_error": max(errors.values()), "failing": failing}
    kept = [r for r in ratios if not rows[f"{r:g}"]["failing"]]
    return {"events": events, "ratios": rows, "threshold": min(kept) if kept else None}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", required=True, help="comma-separated integrator methods")
    parser.add_argument("--ratios", required=True, help="comma-separated steps per contact time")
    parser.add_argument("--out", required=True, type=Path)
    parser.add_argument("--into", help="merge into this key of an existing --out")
    parser.add_argument("--events", default="auto", help="comma-separated event settings: auto, off")
    parser.add_argument("--device", default="cpu")
    args = parser.parse_args()
    events = tuple(args.events.split(","))
    if not events or any(e not in ("auto", "off") for e in events) or len(set(events)) < len(events):
        parser.exit(2, f"error: --events = {args.events!r}: distinct ones of auto, off, comma-separated\n")
    exit_unless_replaceable(args.out, "--out")
    methods = args.methods.split(",")
    ratios = [float(r) for r in args.ratios.split(",")]
    record = {
        "command": "python -m hertzian.studies.thresholds "
        f"--methods {args.methods} --ratios {args.ratios}"
        + (f" --events {args.events}" if args.events != "auto" else "")
        + f" --out {args.out}"
        + (f" --into {args.into}" if args.into else ""),
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "device": args.device,
        "platform": platform.platform(),
        "energy_bound": ENERGY_BOUND,
        "methods": scan(methods, ratios, args.device, events),
    }
    if args.into:
        whole = json.loads(args.out.read_text()) if args.out.exists() else {}
        whole[args.into] = record
        record = whole
    args.out.write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
