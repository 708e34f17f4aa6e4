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
import os
import tempfile

from profile_detect import planted_signal, print_profile, timed_detect  # this folder's profiler of a cached detection


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default="cuda")
    parser.add_argument("--study", default="sweeps/detect_study_1000_target_off.toml")
    parser.add_argument("--depth", type=float, default=0.5, help="planted depth as a fraction of the chain")
    parser.add_argument("--mass-steps", type=int, default=None, help="library ratios a side (default: the study's)")
    parser.add_argument("--repeat", action="store_true", help="a second first detection on a warm machine")
    args = parser.parse_args()
    signal, base, kwargs = planted_signal(args.study, args.device, depth_fraction=args.depth, fronts_cache=False)
    if args.mass_steps is not None:
        kwargs["mass_steps"] = args.mass_steps
    print(f"detect options {kwargs}", flush=True)
    profile = None
    caches = [tempfile.mkdtemp(prefix="hz-detect-") for _ in range(3)]
    calls = [("cold (compiles)", caches[0]), ("first, warm kernels (profiled)", caches[1])]
    calls += [("first, warm kernels again", caches[2]), ("cached", caches[2])] if args.repeat else [("cached", caches[1])]
    for label, cache in calls:
        os.environ["HERTZIAN_DETECT_CACHE"] = cache
        profile = timed_detect(label, signal, base, args.device, kwargs, profiled="profiled" in label) or profile
    print_profile(profile, 40)


if __name__ == "__main__":
    main()
