"""Host cost of a cached detection's library phase, before and after the library's scores were vectorised:
loading the cached library, and scoring it against a signal (per class the library quadratics of every depth and
the first-echo scores, as ``detect`` does with refine > 0).

    python docs/logs/detection/host_cost_bench.py [--old-rev 21dfb43] [--depths 950] [--samples 13000] [--repeats 5]

Old: ensemble/detect.py as of ``--old-rev`` (git show): the library as one ``.npz`` read by ``np.load``, scored depth
by depth. New: the working tree's: a directory of ``.npy`` files memory-mapped, scored for all depths at once from
the echoes' projections and cached Gram matrices. A synthetic library of the 1000-grain host's size (950 depths ×
14 mass ratios × 13 000 samples, float64, 1.4 GB; smooth echoes plus noise, 3 candidates not OK) is written in both
formats to a temporary directory (page cache warm, as right after a build), then each is loaded through its own
``build_library`` (no simulation: the cache is there) and scored; seconds are the median (and min) of ``--repeats``
fresh loads and scorings. Both answers are compared at the end.
"""

import argparse
import importlib.util
import math
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import hertzian.ensemble.detect as new
from hertzian.ensemble.scene import scene_from_dict

ROOT = Path(__file__).resolve().parents[3]


def load_old(rev: str):
    source = subprocess.run(["git", "-C", str(ROOT), "show", f"{rev}:ensemble/detect.py"], check=True,
                            capture_output=True, text=True).stdout
    path = Path(tempfile.mkdtemp()) / "detect_old.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location("hertzian.ensemble.detect_old", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def timed(function, repeats):
    seconds, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        result = function()
        seconds.append(time.perf_counter() - start)
    return result, statistics.median(seconds), min(seconds)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--old-rev", default="21dfb43")
    parser.add_argument("--depths", type=int, default=950)
    parser.add_argument("--samples", type=int, default=13000)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    old = load_old(args.old_rev)
    print(f"numpy {np.__version__}, python {platform.python_version()}, {os.cpu_count()} CPUs; "
          f"old: ensemble/detect.py at {args.old_rev}, new: the working tree's")

    grains, spacing, samples = args.depths + 50, 0.01, args.samples
    base = scene_from_dict({"chain": {"grains": grains, "l0": 1e-4}, "excitation": {"impact": 1e-2},
                            "integrator": {"method": "gear4", "dt": 1e-3, "duration": 1.0}})
    forward = new.forward_scene(base, spacing, samples)
    grid = new.make_grid(np.arange(50, 50 + args.depths), mass_steps=7)
    t = np.arange(samples) * spacing
    fronts = np.arange(grains) * (0.5 * t[-1] / (grains - 1))      # the bottom's echo returns at the window's end
    rng = np.random.default_rng(2026)
    clean = 1e-2 * np.exp(-0.05 * t) * np.sin(0.7 * t)
    delay = 2 * fronts[grid.depths][:, None]
    shape = np.exp(-(((t - delay) / 2.0) ** 2)) * np.cos(1.3 * (t - delay))      # (D, S): each depth's echo
    x = grid.log_mass_ratio
    traces = clean + 1e-3 * (x + 0.3 * x**2)[None, :, None] * shape[:, None, :]
    traces += 1e-6 * rng.normal(size=traces.shape)
    ok = np.ones(traces.shape[:2], dtype=bool)
    for k, m in [(len(grid.depths) // 10, 3), (len(grid.depths) // 3, 0), (2 * len(grid.depths) // 3, 13)]:
        ok[k, m], traces[k, m] = False, np.nan
    truth = len(grid.depths) // 2
    x_truth = math.log(0.6)
    signal = clean + 1e-3 * (x_truth + 0.3 * x_truth**2) * shape[truth] + 5e-5 * rng.normal(size=samples)
    del shape
    print(f"library: {len(grid.depths)} depths × {len(x)} mass ratios × {samples} samples = "
          f"{traces.nbytes / 1e9:.2f} GB")

    root = Path(tempfile.mkdtemp(prefix="host-cost-"))
    old_cache, new_cache = root / "old", root / "new"
    old_cache.mkdir()
    start = time.perf_counter()
    np.savez(old_cache / f"{old.library_key(forward, grid)}.npz", clean=clean, traces=traces, ok=ok, fronts=fronts)
    print(f"old: save .npz {time.perf_counter() - start:.2f} s")
    start = time.perf_counter()
    assembled = new.assemble_library(new.library_key(forward, grid), grid, forward, clean, traces, ok, fronts)
    assemble_seconds = time.perf_counter() - start
    start = time.perf_counter()
    new.save_library(new_cache / assembled.key, assembled)
    print(f"new: echoes and Gram matrices {assemble_seconds:.2f} s, save .npy directory "
          f"{time.perf_counter() - start:.2f} s (once per library, after its simulation)")
    del traces, assembled

    def old_scores():
        os.environ["HERTZIAN_DETECT_CACHE"] = str(old_cache)
        library = old.build_library(forward, grid, "cpu", fronts=fronts)
        assert library.from_cache
        loaded = time.perf_counter()
        scores = {kind: (old._library_quadratics(signal, library, kind),
                         old._first_echo_scores(signal, t, library, kind)) for kind in ("light", "heavy")}
        return scores, loaded

    def new_scores():
        os.environ["HERTZIAN_DETECT_CACHE"] = str(new_cache)
        library = new.build_library(forward, grid, "cpu", fronts=fronts)
        assert library.from_cache
        loaded = time.perf_counter()
        residual = signal - library.clean
        rss_clean = float(residual @ residual)
        projections, first_echo = new._echo_projections(residual, library)
        scores = {kind: (new._library_quadratics(rss_clean, projections, library, kind),
                         new._first_echo_scores(first_echo, library, kind)) for kind in ("light", "heavy")}
        return scores, loaded

    answers = {}
    for name, function in (("old", old_scores), ("new", new_scores)):
        loads, scorings, totals = [], [], []
        for _ in range(args.repeats):
            start = time.perf_counter()
            answers[name], loaded = function()
            end = time.perf_counter()
            loads.append(loaded - start)
            scorings.append(end - loaded)
            totals.append(end - start)
        print(f"{name}: load {statistics.median(loads):.3f} s (min {min(loads):.3f}), "
              f"scoring {statistics.median(scorings):.3f} s (min {min(scorings):.3f}), "
              f"load + scoring {statistics.median(totals):.3f} s (min {min(totals):.3f}); "
              f"median (min) of {args.repeats}")

    for kind in ("light", "heavy"):
        (q_old, (gain_old, x_old)), (q_new, (gain_new, x_new)) = answers["old"][kind], answers["new"][kind]
        a = np.array([(q.x0, q.rss0, q.g, q.H) for q in q_old])
        b = np.array([(q.x0, q.rss0, q.g, q.H) for q in q_new])
        nonzero = np.isfinite(gain_old) & (gain_old != 0)
        same_zeros = np.array_equal(gain_old == 0, gain_new == 0) and np.array_equal(np.isinf(gain_old),
                                                                                      np.isinf(gain_new))
        differences = {"rss0": np.abs(a[:, 1] - b[:, 1]) / a[:, 1], "H": np.abs(a[:, 3] - b[:, 3]) / a[:, 3],
                       "g / √(H rss0)": np.abs(a[:, 2] - b[:, 2]) / np.sqrt(a[:, 3] * a[:, 1]),
                       "first-echo gain": np.abs(gain_old - gain_new)[nonzero] / np.abs(gain_old[nonzero])}
        print(f"{kind}: x0 equal at {np.sum(a[:, 0] == b[:, 0])}/{len(a)} depths, first-echo best x at "
              f"{np.sum(x_old == x_new)}/{len(x_old)}; max relative difference "
              + ", ".join(f"{name} {np.max(d):.1e}" for name, d in differences.items())
              + f" (gains 0 and -inf at the same depths: {same_zeros}); best depth "
              f"{grid.depths[int(np.argmin(a[:, 1]))]} (old) {grid.depths[int(np.argmin(b[:, 1]))]} (new)")
    shutil.rmtree(root)


if __name__ == "__main__":
    main()
