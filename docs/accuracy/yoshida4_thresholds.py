"""Accuracy threshold of yoshida4 for `hertzian check` (ACCURATE_STEPS_PER_CONTACT_TIME), measured as the
other methods' were (docs/stability.md §3): energy error after 0.3 time units on 30 grains for the 13
extreme cases at T/dt = 50 … 3200 (T: check's contact time), worst case over the cases.

    python docs/accuracy/yoshida4_thresholds.py [methods...] > docs/accuracy/yoshida4_thresholds.json
"""

import datetime
import json
import math
import platform
import sys
import time

from hertzian.ensemble.check import check_scene
from hertzian.ensemble.runner import run_scene
from hertzian.ensemble.scene import scene_from_dict

IMPURITY = {"grains": [3], "contact": "own"}
CASES = {  # tests/test_stability.py EXTREMES, plus the paper's case (30 grains, l0 = 1e-4, v_imp = 1e-2)
    "paper": {},
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
STEPS_PER_CONTACT_TIME = [50, 100, 200, 300, 400, 600, 800, 1600, 3200]


def scene(case: str, method: str, steps_per_contact_time: float):
    spec = json.loads(json.dumps(CASES[case]))
    data = {"chain": {"grains": 30, "l0": 1e-4, **spec.pop("chain", {})},
            "excitation": spec.pop("excitation", {"impact": 1e-2}), **spec,
            "integrator": {"method": method, "duration": 0.3}, "record": {"every": 0.01, "fields": ["u"]}}
    base = scene_from_dict(data)
    step = check_scene(base).contact_time / steps_per_contact_time
    return base.with_overrides({"integrator.dt": 0.01 / math.ceil(0.01 / step - 1e-9)})  # divides the records


def main(methods):
    rows = []
    start = time.time()
    for method in methods:
        for k in STEPS_PER_CONTACT_TIME:
            for case in CASES:
                s = scene(case, method, k)
                r = run_scene(s, "cpu")
                rows.append({"method": method, "case": case, "steps_per_contact_time_target": k,
                             "dt": s.integrator.dt, "steps_per_contact_time": check_scene(s).steps_per_contact_time,
                             "energy_error": float(r.energy_error[0]), "status": int(r.status[0])})
                print(method, k, case, rows[-1]["energy_error"], file=sys.stderr)
    worst = {}
    for row in rows:
        key = f"{row['method']} {row['steps_per_contact_time_target']}"
        worst[key] = max(worst.get(key, 0.0), row["energy_error"])
    json.dump({"device": f"cpu ({platform.processor() or platform.machine()}, 2 cores shared)",
               "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
               "command": "python docs/accuracy/yoshida4_thresholds.py " + " ".join(methods),
               "seconds": time.time() - start, "worst_energy_error": worst, "runs": rows}, sys.stdout, indent=1)


if __name__ == "__main__":
    main(sys.argv[1:] or ["yoshida4"])
