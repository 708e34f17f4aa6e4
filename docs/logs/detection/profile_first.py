"""Where a *first* detection's seconds go: a new host chain on a machine whose kernels are compiled (issue 14:
one detection ≤ 5 s on the H100).

    python docs/logs/detection/profile_first.py [--device cuda] [--study sweeps/detect_study_1000_target_off.toml]

Plants a light grain (half depth, μ 0.5, 26 dB) on the study's first host as `detect-study` does, then runs
`detect` three times, each with an empty library cache of its own: the first compiles and calibrates the kernels
(cold), the second is the first detection of a new host chain on a warm machine (profiled), the third the same
again with `--repeat`. A last call reuses the last cache (cached detection). Prints each call's wall seconds
and its `seconds` split, then the profile's top entries by cumulative and by own time.
"""

import argparse
import cProfile
import io
import json
import math
import os
import pstats
import tempfile
import time

import numpy as np

from hertzian.ensemble.detect import _cached_fronts, detect, forward_scene, signal_from_arrays
from hertzian.ensemble.detect_study import _truth_velocities, load_study
from hertzian.ensemble.scene import apply_overrides, scene_from_dict


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default="cuda")
    parser.add_argument("--study", default="sweeps/detect_study_1000_target_off.toml")
    parser.add_argument("--depth", type=float, default=0.5, help="planted depth as a fraction of the chain")
    parser.add_argument("--mass-steps", type=int, default=None, help="library ratios a side (default: the study's)")
    parser.add_argument("--repeat", action="store_true", help="a second first detection on a warm machine")
    args = parser.parse_args()
    study = load_study(args.study)
    options, host = study["study"], study["hosts"][0]
    spacing = float(options.get("spacing", 0.01))
    base = scene_from_dict(apply_overrides(study["scene"], {"chain.gravity": float(host.get("gravity", 0.0))}))
    probe = forward_scene(base, spacing, int(round(options.get("probe_duration", 60.0) / spacing)) + 1)
    window = 2 * float(_cached_fronts(probe, args.device, False)[-1])
    samples = int(math.ceil(1.1 * window / spacing)) + 1
    forward = forward_scene(base, spacing, samples)
    depth = int(round(args.depth * base.chain.grains))
    clean, planted = _truth_velocities(forward, [(None, 1.0), (depth, 0.5)], 1, args.device)
    peak = float(np.max(np.abs(planted - clean)))
    t = np.arange(samples) * spacing
    signal = signal_from_arrays(t, planted + np.random.default_rng(1).normal(scale=peak / 10 ** 1.3, size=samples))
    kwargs = {k: options[k] for k in ("mass_steps", "refine", "iterations") if k in options}
    if args.mass_steps is not None:
        kwargs["mass_steps"] = args.mass_steps
    print(f"detect options {kwargs}", flush=True)
    profile = None
    caches = [tempfile.mkdtemp(prefix="hz-detect-") for _ in range(3)]
    calls = [("cold (compiles)", caches[0]), ("first, warm kernels (profiled)", caches[1])]
    calls += [("first, warm kernels again", caches[2]), ("cached", caches[2])] if args.repeat else [("cached", caches[1])]
    for label, cache in calls:
        os.environ["HERTZIAN_DETECT_CACHE"] = cache
        t0 = time.perf_counter()
        if "profiled" in label:
            profile = cProfile.Profile()
            profile.enable()
        result, _ = detect(signal, base, device=args.device, **kwargs)
        if "profiled" in label:
            profile.disable()
        print(f"{label}: {time.perf_counter() - t0:.3f} s -> {result.kind} depth {result.depth} "
              f"mu {result.mass_ratio:.4g} seconds {json.dumps(result.seconds)}", flush=True)
    for key in ("cumulative", "tottime"):
        out = io.StringIO()
        pstats.Stats(profile, stream=out).sort_stats(key).print_stats(40)
        print(out.getvalue())


if __name__ == "__main__":
    main()
