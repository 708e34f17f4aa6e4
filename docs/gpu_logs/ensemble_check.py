# Re-check after the kernels/gear.py refactor: the per-step kernel's rate, and the issue-2 ensemble.
import time, json, os, sys
import numpy as np
import warp as wp
wp.config.log_level = wp.LOG_WARNING
wp.init()
from ensemble.scene import scene_from_dict
from ensemble.model import build_model
from ensemble.runner import Runner
base = {"chain": {"grains": 1000, "l0": 1e-4}, "excitation": {"impact": 1e-2},
        "integrator": {"dt": 1.25e-5, "duration": 1.0}, "record": {"every": 0.5}}
scenes = [scene_from_dict({**base, "excitation": {"impact": 1e-2 * (1 + c / 1024)}}) for c in range(1024)]
out = {}
for kernel in ("auto", "step"):
    t = time.perf_counter()
    r = Runner(build_model(scenes, "cuda"), kernel=kernel).run()
    out[kernel] = dict(wall=r.wall_seconds, gsps=r.grain_steps_per_second, kernel=r.kernel, steps=r.steps,
                       energy_error=float(r.energy_error.max()), status_max=int(r.status.max()),
                       total=time.perf_counter() - t)
    out[kernel + "_u"] = r.u
print(json.dumps({k: v for k, v in out.items() if not k.endswith("_u")}, indent=1))
print("max |u_auto - u_step|", float(np.abs(out["auto_u"] - out["step_u"]).max()), "of", float(np.abs(out["step_u"]).max()))
