"""Detections before and after the library's scores were vectorised (docs/logs/detection/host_cost_bench.py): same
answers on the planted signals of tests/test_detect.py?

    python docs/logs/detection/host_cost_answers.py [--old-rev 21dfb43]

Loads ensemble/detect.py as of ``--old-rev`` (git show) beside the working tree's, runs both on the tests' planted
cases (CASES, the clean chain, the --fit-a truth, the shallow light needle of an 80-grain host), each with its own
empty cache, and prints per case: class, depth, depth interval and refined depths (must be equal), and the largest
relative difference of the mass ratio, its interval, the log evidences and the best fit.
"""

import argparse
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "tests"))

import hertzian.ensemble.detect as new  # noqa: E402
from hertzian.ensemble.runner import run_scene  # noqa: E402
from hertzian.ensemble.scene import scene_from_dict  # noqa: E402
from test_detect import BASE, CASES, SNR_DB, SPACING, noisy_signal, planted_with_a, truth_velocity  # noqa: E402

from host_cost_bench import load_old  # noqa: E402  (this folder is on sys.path when run as a script)


def cases():
    clean = truth_velocity(None)
    for depth, block, mu in CASES:
        velocity = truth_velocity({"grains": list(range(depth, depth + block)), "mass": mu})
        yield f"planted d={depth} block={block} mu={mu}", noisy_signal(velocity, clean, seed=1000 + depth)[0], BASE, \
            {"block": block}
    echo = truth_velocity({"grains": [20], "mass": 0.75})
    sigma = float(np.max(np.abs(echo - clean))) / 10 ** (SNR_DB / 20)
    yield "clean chain seed 1", noisy_signal(clean, clean, seed=1, sigma=sigma)[0], BASE, {}
    yield "fit-a truth (plain)", planted_with_a(clean)[0], BASE, {}
    yield "fit-a truth (--fit-a)", planted_with_a(clean)[0], BASE, {"fit_a": True}
    base80 = {**BASE, "chain": {"grains": 80, "l0": 1e-4}}
    samples = 875

    def planted(impurity):
        data = {**base80, "integrator": {"method": "gear4", "dt": 5e-4, "duration": SPACING * (samples - 1)},
                "record": {"traces": [0], "trace_every": SPACING}}
        if impurity:
            data["impurities"] = [impurity]
        return run_scene(scene_from_dict(data), "cpu").traces["v"][0, :, 0]

    velocity, clean80 = planted({"grains": [4], "mass": 0.3}), planted(None)
    sigma = float(np.max(np.abs(velocity - clean80))) / 10 ** (SNR_DB / 20)
    signal = new.signal_from_arrays(np.arange(samples) * SPACING,
                                    velocity + np.random.default_rng(5).normal(scale=sigma, size=samples))
    yield "needle 80 grains d=4 mu=0.3", signal, base80, {"depth_range": (3, 6)}


def relative(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    scale = np.maximum(np.abs(a), np.abs(b))
    return float(np.max(np.where(scale > 0, np.abs(a - b) / np.where(scale > 0, scale, 1), 0.0)))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--old-rev", default="21dfb43")
    args = parser.parse_args()
    old = load_old(args.old_rev)
    print(f"old: ensemble/detect.py at {args.old_rev}; new: the working tree's")
    unchanged = True
    for label, signal, base, options in cases():
        results = {}
        for name, module in (("old", old), ("new", new)):
            os.environ["HERTZIAN_DETECT_CACHE"] = tempfile.mkdtemp(prefix=f"detect-{name}-")
            results[name] = module.detect(signal, scene_from_dict(base), device="cpu", **options)[0]
        a, b = results["old"], results["new"]
        same = (a.kind, a.depth, a.depth_interval, a.refined_depths) == (b.kind, b.depth, b.depth_interval,
                                                                         b.refined_depths)
        unchanged &= same
        floats = {"mass_ratio": relative(a.mass_ratio, b.mass_ratio),
                  "mass_interval": relative(a.mass_ratio_interval or (1, 1), b.mass_ratio_interval or (1, 1)),
                  "log_evidence": relative(list(a.log_evidence.values()), list(b.log_evidence.values())),
                  "noise": relative(a.noise, b.noise), "best_fit": relative(a.best_fit, b.best_fit)}
        print(f"{label}: {b.kind} depth {b.depth} {b.depth_interval} mu {b.mass_ratio:.6g} "
              f"[{', '.join(f'{m:.6g}' for m in b.mass_ratio_interval or ())}] refined {b.refined_depths} "
              f"fine scan {'yes' if b.fine_scan else 'no'}: discrete {'equal' if same else 'DIFFERENT'}; "
              + ", ".join(f"{k} {v:.1e}" for k, v in floats.items()), flush=True)
        if not same:
            print(f"  old: {a.kind} depth {a.depth} {a.depth_interval} refined {a.refined_depths}")
    print("all discrete answers equal" if unchanged else "SOME ANSWERS DIFFER")


if __name__ == "__main__":
    main()
