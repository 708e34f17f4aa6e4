"""Where one cached detection's seconds go (issue 14: ≤ 1 s with the library cached).

    python docs/logs/detection/profile_detect.py [--device cuda] [--study sweeps/detect_study_1000_target.toml]

Plants a light grain (at half depth, μ 0.5, 26 dB) on the study's first host exactly as `detect-study` does, runs
`detect` once (library, fronts and kernels cached), then twice more under cProfile, and prints the wall seconds
of each call and the profile's top entries by cumulative and by own time.
"""

import argparse
import cProfile
import io
import json
import math
import pstats
import time

import numpy as np

from hertzian.ensemble.detect import _cached_fronts, detect, forward_scene, signal_from_arrays
from hertzian.ensemble.detect_study import _truth_velocities, load_study
from hertzian.ensemble.scene import apply_overrides, scene_from_dict


def planted_signal(study_path: str, device: str, *, depth_fraction: float = 0.5, fronts_cache: bool = True):
    """A light grain (μ 0.5) planted at ``depth_fraction`` of the study's first host, 26 dB, as `detect-study` plants
    it: (signal, BASE, the study's detect options)."""
    study = load_study(study_path)
    options, host = study["study"], study["hosts"][0]
    spacing = float(options.get("spacing", 0.01))
    base = scene_from_dict(apply_overrides(study["scene"], {"chain.gravity": float(host.get("gravity", 0.0))}))
    probe = forward_scene(base, spacing, int(round(options.get("probe_duration", 60.0) / spacing)) + 1)
    window = 2 * float(_cached_fronts(probe, device, fronts_cache)[-1])
    samples = int(math.ceil(1.1 * window / spacing)) + 1
    forward = forward_scene(base, spacing, samples)
    depth = int(round(depth_fraction * base.chain.grains))
    clean, planted = _truth_velocities(forward, [(None, 1.0), (depth, 0.5)], 1, device)
    peak = float(np.max(np.abs(planted - clean)))
    t = np.arange(samples) * spacing
    signal = signal_from_arrays(t, planted + np.random.default_rng(1).normal(scale=peak / 10 ** 1.3, size=samples))
    kwargs = {k: options[k] for k in ("mass_steps", "refine", "iterations") if k in options}
    return signal, base, kwargs


def timed_detect(label: str, signal, base, device: str, kwargs: dict, *, profiled: bool = False):
    """One ``detect`` call, its wall seconds and answer printed; returns the cProfile.Profile when ``profiled``."""
    profile = cProfile.Profile() if profiled else None
    t0 = time.perf_counter()
    if profile is not None:
        profile.enable()
    result, _ = detect(signal, base, device=device, **kwargs)
    if profile is not None:
        profile.disable()
    print(f"{label}: {time.perf_counter() - t0:.3f} s -> {result.kind} depth {result.depth} "
          f"mu {result.mass_ratio:.4g} seconds {json.dumps(result.seconds)}", flush=True)
    return profile


def print_profile(profile, rows: int) -> None:
    """The profile's top ``rows`` entries by cumulative and by own time."""
    for key in ("cumulative", "tottime"):
        out = io.StringIO()
        pstats.Stats(profile, stream=out).sort_stats(key).print_stats(rows)
        print(out.getvalue())


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default="cuda")
    parser.add_argument("--study", default="sweeps/detect_study_1000_target.toml")
    args = parser.parse_args()
    signal, base, kwargs = planted_signal(args.study, args.device)
    profile = None
    for label in ("first", "cached", "cached (profiled)"):
        profile = timed_detect(label, signal, base, args.device, kwargs, profiled=label.endswith("(profiled)")) or profile
    print_profile(profile, 35)


if __name__ == "__main__":
    main()
