"""Misfit of a shallow light grain against its mass ratio: why detection misplaces μ = 0.3 at depth 4.

80-grain host of sweeps/detect_study.toml (g = 0), impurity μ = 0.3 at depth 4. The "signal" is the
noise-free trace at the detector's own step (no model error), the candidates are the same chain with
μ scanned over 0.25 … 0.42; printed: μ and RSS over the analysis window (t ≤ 8.74, 875 samples).
Then the detector itself on that noise-free signal.
Run from the repository root: PYTHONPATH=. python docs/logs/detection/scan_shallow_light.py
"""
import math
import platform
from datetime import datetime, timezone

import numpy as np

from hertzian.ensemble.detect import forward_scene, run_candidates
from hertzian.ensemble.scene import scene_from_dict

base = scene_from_dict({"chain": {"grains": 80, "l0": 1e-4}, "excitation": {"impact": 1e-2},
                        "integrator": {"method": "gear4", "dt": 1e-3, "duration": 1.0}})
forward = forward_scene(base, 0.01, 875)
ratios = np.exp(np.linspace(math.log(0.25), math.log(0.42), 35))
truth, _ = run_candidates(forward, [(4, 0.3)], 1, "cpu")
traces, ok = run_candidates(forward, [(4, float(m)) for m in ratios], 1, "cpu")
print(f"# {datetime.now(timezone.utc).isoformat(timespec='seconds')} cpu {platform.machine()}; "
      f"echo peak max|v - v_clean| not computed; all ok: {bool(ok.all())}")
print("# mass_ratio  RSS(signal at mu=0.3 - candidate)")
for m, trace in zip(ratios, traces):
    print(f"{m:.4f} {float(np.sum((trace - truth[0]) ** 2)):.3e}")

# the detector on this noise-free signal (963 samples as in the study; it analyses t ≤ 8.74)
from hertzian.ensemble.detect import detect, signal_from_arrays

long_forward = forward_scene(base, 0.01, 963)
signal_trace, _ = run_candidates(long_forward, [(4, 0.3)], 1, "cpu")
signal = signal_from_arrays(np.arange(963) * 0.01, signal_trace[0], source="noise-free, mu = 0.3 at depth 4")
result, _ = detect(signal, base, device="cpu", refine=1)
print(f"# detect (refine = 1): class {result.kind}, depth {result.depth}, mass ratio {result.mass_ratio:.4f}, "
      f"interval {result.mass_ratio_interval}, misfit ratio {result.misfit_ratio}")
