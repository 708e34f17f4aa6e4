"""How far the detector's forward model (BASE step, plain Gear steps) is from the planted signals of detect-study (half
the step, event-aware steps) on the 1000-grain host: the rms and largest difference of grain 0's velocity over the
window, against the noise σ at 40 and 26 dB. CPU, about 15 s per step:

    python docs/logs/detection/model_error_1000_cpu.py > docs/logs/detection/model_error_1000_cpu.txt
    python docs/logs/detection/model_error_1000_cpu.py --dt 2e-3 > docs/logs/detection/model_error_1000_dt2e-3_cpu.txt
    python docs/logs/detection/model_error_1000_cpu.py --dt 1e-3 --gravity 1 > docs/logs/detection/model_error_1000_g1_dt1e-3_cpu.txt
"""

import argparse
import time

import numpy as np

from hertzian.ensemble.detect import forward_scene, run_candidates
from hertzian.ensemble.detect_study import _truth_velocities
from hertzian.ensemble.scene import scene_from_dict
parser = argparse.ArgumentParser()
parser.add_argument("--dt", type=float, default=1e-3, help="BASE's step (the planted truth runs at half of it)")
parser.add_argument("--gravity", type=float, default=0.0)
args = parser.parse_args()
dt = args.dt
base = scene_from_dict({"chain": {"grains": 1000, "l0": 1e-4, "gravity": args.gravity}, "excitation": {"impact": 1e-2},
                        "integrator": {"method": "gear4", "dt": dt, "duration": 1.0, "events": "off"}})
print(f"BASE dt {dt:g} (truth at {dt / 2:g}, event-aware steps), gravity {args.gravity:g}")
S = 11661
fwd = forward_scene(base, 0.01, S)
t0 = time.perf_counter()
cases = [(500, 0.5), (250, 3.0), (50, 0.3)]
model, _ = run_candidates(fwd, [(-1, 1.0)] + cases, 1, "cpu")
tr = _truth_velocities(fwd, [(None, 1.0)] + [(d, m) for d, m in cases], 1, "cpu")
print("seconds", time.perf_counter() - t0)
clean_t = tr[0]
for k, (d, m) in enumerate(cases):
    echo_t = tr[k + 1] - clean_t
    peak = np.max(np.abs(echo_t))
    err = model[k + 1] - tr[k + 1]
    print(f"depth {d} mu {m}: echo peak {peak:.3e}; model (dt, events off) - truth (dt/2, events auto): rms {np.sqrt(np.mean(err**2)):.3e}, max {np.max(np.abs(err)):.3e}; sigma at 40 dB {peak/100:.3e}, 26 dB {peak/10**1.3:.3e}")
