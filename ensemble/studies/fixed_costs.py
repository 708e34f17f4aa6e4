"""Fixed costs on this machine: ``hertzian run`` wall time with the per-step and the chain kernel, cold (an empty
Warp kernel cache) and warm, compile concurrency (``prepare_kernels`` with 1, 2 workers on a cold cache), and what
the CPU ``auto`` rule reads (hertzian.core.solvers.calibrate.CPU_COSTS): each stepping kernel's compile seconds and
its warm rate [grain-steps/s], with the crossover they give.

Also process start (``import hertzian.cli``, ``hertzian run --help``, a tiny warm ``hertzian run``) and the host
stages of building the first batches of ``sweeps/million.toml`` (expand, plan, jobs, prepare_model, uploads,
state buffers).

And the README's first command (``hertzian run --out impact.zarr``) cold and warm, back to back, with each run's
timeline (part ``readme``; ``--device`` picks the device, a GPU included), the same after ``hertzian prebuild``
(part ``readme_prebuilt``), and the same from a package that ``pip install .`` built, with the default family it
compiled at install (part ``readme_installed``, measured only when named in ``--only``: run it from such an
install, not an editable one). And how many kernel modules the test suite loads (part ``suite_modules``, only when
named in ``--only``: it runs the README's test command from the repository's root on an empty kernel cache).

``python -m hertzian.studies.fixed_costs --out docs/records/bench/cpu_auto_rule.json`` regenerates the record
(``--only start,build`` re-measures those parts into the existing file;
``--only readme --device cuda --repeats 3 --out FILE`` measures the README command on a GPU).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

from hertzian.core.outputs import why_not_replaceable

CASES = ((20, 1.0), (200, 5.0), (1000, 5.0))
"""(grains, duration) of the timed runs: the example impact scene with these keys set."""

COMPILE_PROBE = """
import sys, time
import warp as wp
wp.config.quiet = True
from hertzian.kernels.features import Features
from hertzian.core.solvers.prepare import Need, prepare_kernels
needs = [Need(Features(method=m, static=s), 200, 1, 10**6, k) for m in ("gear4", "gear5")
         for s in ("none", "uniform") for k in ("step", "chain")]
print(prepare_kernels(needs, "cpu", max_workers=int(sys.argv[1]))["seconds"])
"""


KERNEL_PROBE = """
import json, sys, time
import warp as wp
wp.config.quiet = True
from hertzian.core.model import build_model
from hertzian.core.runner import Runner
from hertzian.core.scene import load_scene
from hertzian.core.shipped import example_path
from hertzian.core.solvers.calibrate import cpu_kernel_config
from hertzian.core.solvers.compile import load_variants, solver_variants
kind, grains, steps = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
scene = load_scene(example_path(), {"chain.grains": grains, "integrator.duration": steps * 5e-5,
                                    "record.traces": [], "record.every": steps * 5e-5})
model = build_model([scene], "cpu")
config = cpu_kernel_config(kind)
start = time.perf_counter()
load_variants(solver_variants(config, model.features, model.grain_count, 1), "cpu")
compile_s = time.perf_counter() - start
Runner(model, kernel=config).run()  # warm-up: record kernels, first launch
runner = Runner(model, kernel=config)
start = time.perf_counter()
runner.run()
run_s = time.perf_counter() - start
print(json.dumps({"compile_s": compile_s, "rate": grains * steps / run_s}))
"""
"""A cold process (its own empty Warp cache): compile seconds of one stepping kernel (``step`` or ``chain``) for the
example scene at the given grains, then its warm rate over the given steps [grain-steps/s]."""


def _wall(args: list[str], cache: str, **env) -> float:
    """Process wall [s] of ``hertzian ARGS`` with Warp's kernel cache in ``cache`` and ``env`` set (a value of None
    unsets it; a command that fails ends this process with its message and exit code). Python's bytecode cache is on, as for an installed
    package (pip compiles it): ``PYTHONDONTWRITEBYTECODE`` would recompile an editable install's modules each start."""
    unset = {"PYTHONDONTWRITEBYTECODE"} | {k for k, v in env.items() if v is None}
    inherited = {k: v for k, v in os.environ.items() if k not in unset}
    env = {**inherited, "WARP_CACHE_PATH": cache, **{k: v for k, v in env.items() if v is not None}}
    start = time.perf_counter()
    result = subprocess.run([sys.executable, "-m", "hertzian.cli", *args], env=env, capture_output=True, text=True)
    if result.returncode:
        print(result.stderr.strip().splitlines()[-1] if result.stderr.strip() else "error", file=sys.stderr)
        raise SystemExit(result.returncode)
    return time.perf_counter() - start


README_COMMAND = ["run", "--out", "impact.zarr"]
"""The README's first command: the built-in example (1000 grains, 200 000 steps) to a store."""


def _timeline_summary(path: Path) -> dict:
    """Phase → seconds since process start, and the kernel loads, of one HERTZIAN_TIMELINE file."""
    phases = json.loads(path.read_text())["phases"]
    loads = next((p.get("variants", []) for p in phases if p["phase"] == "kernels_loaded"), [])
    return {
        "phases": {p["phase"]: round(p["seconds"], 4) for p in phases},
        "kernel": next((p.get("kernel") for p in phases if p["phase"] == "integrated"), None),
        "compiled": {load["module"]: round(load["seconds"], 4) for load in loads if not load["cached"]},
    }


def time_readme(device: str, repeats: int = 3, prebuilt: bool | str = False) -> dict:
    """Process wall [s] of the README's first command on ``device``, cold then warm, back to back ``repeats`` times.

    Cold: a new empty Warp kernel cache (``WARP_CACHE_PATH``) and calibration cache (``HERTZIAN_CACHE``); warm: the
    same command again with those caches. Each run's timeline (``HERTZIAN_TIMELINE``) is kept in the record.
    ``prebuilt``: first ``hertzian prebuild`` (the default family, its seconds and size recorded) into a folder every
    run reads (``HERTZIAN_PREBUILT``); ``"package"``: the installed package's own folder, as ``pip install .`` built
    it (``HERTZIAN_PREBUILT`` unset); else no prebuilt folder is read."""
    pairs = []
    with tempfile.TemporaryDirectory() as tmp:
        args = [*README_COMMAND[:-1], f"{tmp}/impact.zarr", "--device", device, "--quiet", "--overwrite"]
        folder = {True: f"{tmp}/prebuilt", False: "off", "package": None}[prebuilt]
        built = _package_family() if prebuilt == "package" else {}
        if prebuilt is True:
            build_args = ["prebuild", "--device", device, "--out", folder]
            built = {"prebuild_s": _wall(build_args, f"{tmp}/build-cache", HERTZIAN_PREBUILT="off")}
            built["prebuilt_bytes"] = sum(p.stat().st_size for p in Path(folder).rglob("*") if p.is_file())
        for repeat in range(repeats):
            cache = f"{tmp}/cache-{repeat}"
            pair = {}
            for state in ("cold", "warm"):
                timeline = Path(tmp) / f"{state}-{repeat}.json"
                env = dict(HERTZIAN_CACHE=f"{cache}/calibration.json", HERTZIAN_TIMELINE=str(timeline))
                pair[f"{state}_s"] = _wall(args, f"{cache}/warp", HERTZIAN_PREBUILT=folder, **env)
                pair[f"{state}_timeline"] = _timeline_summary(timeline)
            pairs.append(pair)
    cold = statistics.median(p["cold_s"] for p in pairs)
    warm = statistics.median(p["warm_s"] for p in pairs)
    return {
        "command": "hertzian " + " ".join(README_COMMAND) + f" --device {device}",
        "device": device,
        "prebuilt": prebuilt,
        **built,
        "median_cold_s": cold,
        "median_warm_s": warm,
        "cold_over_warm": cold / warm,
        "pairs": pairs,
    }


def _package_family() -> dict:
    """The installed package's prebuilt folder and its module count; refuses an install without one (editable)."""
    from hertzian.core.solvers import prebuilt

    index = prebuilt.PACKAGE_FOLDER / prebuilt.INDEX
    if not index.is_file():
        raise SystemExit(
            f"error: {prebuilt.PACKAGE_FOLDER} holds no prebuilt kernels: measure readme_installed from a package "
            "that `pip install .` built (not an editable install)"
        )
    return {"package_folder_modules": len(json.loads(index.read_text())["modules"])}


def time_runs(out_dir: str) -> list[dict]:
    """Process wall time [s] of ``hertzian run`` per case, kernel and cache state (cold first, then warm)."""
    rows = []
    for grains, duration in CASES:
        for kernel in ("step", "chain"):
            cache = tempfile.mkdtemp(prefix="warp-cache-")
            args = [
                "run",
                "--device",
                "cpu",
                "--quiet",
                "--overwrite",
                "--kernel",
                kernel,
                "--out",
                f"{out_dir}/o.zarr",
            ]
            args += ["--set", f"chain.grains={grains}", "--set", f"integrator.duration={duration}"]
            cold, warm = _wall(args, cache), _wall(args, cache)
            rows.append({"grains": grains, "duration": duration, "kernel": kernel, "cold_s": cold, "warm_s": warm})
    return rows


def time_compiles() -> dict[str, float]:
    """Seconds to prepare 8 variants on a cold cache with 1 and 2 compile threads (process wall time)."""
    out = {}
    for workers in (1, 2):
        cache = tempfile.mkdtemp(prefix="warp-cache-")
        env = {**os.environ, "WARP_CACHE_PATH": cache}
        result = subprocess.run(
            [sys.executable, "-c", COMPILE_PROBE, str(workers)], env=env, check=True, capture_output=True, text=True
        )
        out[f"workers_{workers}_s"] = float(result.stdout.strip().splitlines()[-1])
    return out


def time_kernel_costs(grains: int = 200, steps: int = 20000, repeats: int = 3) -> dict:
    """Compile seconds (cold cache, one process each) and warm rate [grain-steps/s] of the per-step and the chain
    kernel, each the median of ``repeats`` processes taken in turn, and the crossover [grain-steps] of the CPU
    ``auto`` rule they give (calibrate.cpu_crossovers)."""
    from hertzian.core.solvers.calibrate import cpu_crossovers

    runs = {"step": [], "chain": []}
    for _ in range(repeats):
        for kind, measured in runs.items():
            env = {**os.environ, "WARP_CACHE_PATH": tempfile.mkdtemp(prefix="warp-cache-")}
            result = subprocess.run(
                [sys.executable, "-c", KERNEL_PROBE, kind, str(grains), str(steps)],
                env=env,
                check=True,
                capture_output=True,
                text=True,
            )
            measured.append(json.loads(result.stdout.strip().splitlines()[-1]))
    out = {"grains": grains, "steps": steps, "repeats": repeats}
    for kind, measured in runs.items():
        out[kind] = {key: statistics.median(m[key] for m in measured) for key in ("compile_s", "rate")}
        out[kind]["runs"] = measured
    costs = {kind: (out[kind]["compile_s"], out[kind]["rate"]) for kind in runs}
    out["crossover_grain_steps"] = cpu_crossovers(costs)
    return out


BUILD_PROBE = """
import json, sys, time
import warp as wp
wp.config.quiet = True
from hertzian.core.model import build_model
from hertzian.core.shipped import shipped_file
from hertzian.sweeping.distributed import jobs_for, prepare_job
from hertzian.sweeping.planner import plan_sweep
from hertzian.sweeping.spec import expand, load_sweep
out, clock = {}, time.perf_counter()
def lap(name):
    global clock
    out[name] = time.perf_counter() - clock
    clock = time.perf_counter()
sweep = load_sweep(shipped_file("million.toml"), {}); points = expand(sweep); lap("expand")
plan = plan_sweep(sweep, points, "cpu"); lap("plan")
jobs = jobs_for("unused.zarr", plan, points, plan.batches[: int(sys.argv[1])]); lap("jobs")
prepared = [prepare_job(job) for job in jobs]; lap("prepare_model")
models = [build_model(j.chains, "cpu", features=j.features, prepared=p) for j, p in zip(jobs, prepared)]; lap("upload")
[model.state_pair() for model in models]; lap("state_pair")
print(json.dumps({"points": sum(len(j.chains) for j in jobs), "seconds": out}))
"""
"""Host stages [s] of building the first batches of the 10^6-point sweep on the CPU (no kernel runs)."""


def time_build(batches: int = 2) -> dict:
    """Seconds of each host stage of building the first ``batches`` batches of ``sweeps/million.toml``."""
    result = subprocess.run(
        [sys.executable, "-c", BUILD_PROBE, str(batches)], check=True, capture_output=True, text=True
    )
    return json.loads(result.stdout.strip().splitlines()[-1])


def time_start(repeats: int = 3) -> dict:
    """Median process wall [s] of ``import hertzian.cli``, ``hertzian run --help`` and a tiny warm CPU run
    (20 grains, 200 steps; its kernels compiled by a first run that is not counted)."""
    with tempfile.TemporaryDirectory() as tmp:
        cache = tempfile.mkdtemp(prefix="warp-cache-")
        tiny = ["run", "--device", "cpu", "--quiet", "--overwrite", "--out", f"{tmp}/t.zarr"]
        tiny += ["--set", "chain.grains=20", "--set", "integrator.duration=0.01", "--set", "record.every=0.01"]
        _wall(tiny, cache)
        walls = {"import_cli": [], "run_help": [], "tiny_run": []}
        for _ in range(repeats):
            start = time.perf_counter()
            subprocess.run([sys.executable, "-c", "import hertzian.cli"], check=True)
            walls["import_cli"].append(time.perf_counter() - start)
            walls["run_help"].append(_wall(["run", "--help"], cache))
            walls["tiny_run"].append(_wall(tiny, cache))
    return {name: sorted(values)[len(values) // 2] for name, values in walls.items()}


def time_gpu_family(out_dir: str, arch: int = 90, *, whole: bool = False) -> dict:
    """``hertzian prebuild [impact] --gpu-family ARCH --ptx ARCH``, planned and built on this machine: the README
    scene's GPU family at any length, or (``whole``) the whole default family and its companion wheel. Its JSON
    report, process wall and (whole) the wheel's size."""
    folder = Path(out_dir) / ("gpu_family_whole" if whole else "gpu_family")
    args = ["prebuild", *([] if whole else ["impact"]), "--gpu-family", str(arch), "--ptx", str(arch)]
    extra = ["--out", str(folder), *(["--wheel", str(folder.with_name(folder.name + "_wheel"))] if whole else [])]
    start = time.perf_counter()
    command = [sys.executable, "-m", "hertzian.cli", *args, *extra, "--json"]
    done = subprocess.run(command, capture_output=True, text=True, check=True)
    report = json.loads(done.stdout)
    out = {
        "command": "hertzian " + " ".join(args) + " --out DIR" + (" --wheel DIST" if whole else "") + " --json",
        "report": {k: v for k, v in report.items() if k not in ("out", "wheel")},
        "process_s": time.perf_counter() - start,
    }
    if whole:
        out["wheel_bytes"] = Path(report["wheel"]).stat().st_size
    return out


def family_counts(device: str = "cpu") -> dict:
    """How many kernel modules (distinct Warp module and block size) each shipped job loads on ``device``: one run of
    each shipped example scene, each shipped sweep file (every launch group and batch size; design files are left
    out, their kernels depend on what the optimizer draws), ``reproduce`` and ``reproduce --quick``, and all of them
    together (the default family ``hertzian prebuild`` compiles)."""
    from hertzian.core.scene import read_toml
    from hertzian.core.shipped import shipped_file, shipped_names
    from hertzian.core.solvers.prepare import kernel_variants
    from hertzian.studies.reproduce import paper_needs
    from hertzian.studies.warmup import family_needs, file_needs

    jobs: dict[str, int] = {}
    for name in shipped_names():
        table = read_toml(shipped_file(name))
        if "design" not in table and "study" not in table:
            jobs[name] = len(kernel_variants(file_needs(shipped_file(name), device), device))
    for quick in (False, True):
        jobs["reproduce" + (" --quick" if quick else "")] = len(
            kernel_variants(paper_needs(device, quick=quick), device)
        )
    return {"device": device, "jobs": jobs, "default_family": len(kernel_variants(family_needs(device), device))}


SUITE_COMMAND = ["-m", "pytest", "-q", "-n", "2", "tests"]
"""The README's test command (after ``python``), which part ``suite_modules`` runs on an empty kernel cache."""


def suite_modules(tmp: str) -> dict:
    """How many kernel modules the test suite loads on this machine: the README's test command, run from the
    repository's root on an empty Warp kernel cache (and calibration cache), no prebuilt kernels read; every module
    it compiles leaves one folder in the cache (one Warp module at one block size). Counted per kernel factory
    (the module name without its feature hash), with the suite's seconds and its closing line."""
    import re
    from collections import Counter

    if not Path("tests/reference.py").is_file():
        raise SystemExit("error: suite_modules runs the test suite: run it from the repository's root")
    cache = Path(tmp) / "suite-warp"
    env = {**os.environ, "WARP_CACHE_PATH": str(cache), "HERTZIAN_CACHE": f"{tmp}/suite-calibration.json"}
    env["HERTZIAN_PREBUILT"] = "off"
    start = time.perf_counter()
    done = subprocess.run([sys.executable, *SUITE_COMMAND], capture_output=True, text=True, env=env)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(
            f"error: the test suite failed (exit {done.returncode}): {done.stdout.strip().splitlines()[-1:]}"
        )
    modules = [d.name for d in cache.glob("*/wp_*") if d.is_dir()]  # Warp keeps a folder per version
    if not modules:
        raise SystemExit(f"error: the test suite left no kernel modules in {cache}: did Warp read WARP_CACHE_PATH?")
    factory = Counter(re.sub(r"(_[0-9a-f]{7,8})+$", "", name.removeprefix("wp_")) for name in modules)
    return {
        "command": "python " + " ".join(SUITE_COMMAND),
        "seconds": seconds,
        "summary": done.stdout.strip().splitlines()[-1],
        "modules": len(modules),
        "by_factory": dict(factory.most_common()),
    }


PARTS = {
    "suite_modules": lambda tmp, args: suite_modules(tmp),
    "family_counts": lambda tmp, args: family_counts(),
    "runs": lambda tmp, args: time_runs(tmp),
    "compile_8_variants": lambda tmp, args: time_compiles(),
    "kernel_costs": lambda tmp, args: time_kernel_costs(),
    "start": lambda tmp, args: time_start(),
    "build_million": lambda tmp, args: time_build(),
    "readme": lambda tmp, args: time_readme(args.device, args.repeats),
    "readme_prebuilt": lambda tmp, args: time_readme(args.device, args.repeats, prebuilt=True),
    "readme_installed": lambda tmp, args: time_readme(args.device, args.repeats, prebuilt="package"),
    "gpu_family": lambda tmp, args: time_gpu_family(tmp),
    "gpu_family_whole": lambda tmp, args: time_gpu_family(tmp, whole=True),
}
"""Each part of the record and how it is measured (``--only`` names them by key, or ``start``/``build``). Only
the readme parts take ``--device``; the others measure the CPU."""


def _arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--only", default="", help="comma-separated parts to re-measure into the existing --out")
    parser.add_argument("--device", default="cpu", help="device of the readme part: cpu | cuda | cuda:N")
    parser.add_argument("--repeats", type=int, default=3, help="cold/warm pairs of the readme part (≥ 1)")
    args = parser.parse_args()
    args.only = [{"build": "build_million"}.get(p, p) for p in args.only.split(",") if p]
    unknown = [p for p in args.only if p not in PARTS]
    if unknown:
        parser.exit(2, f"error: --only = {unknown[0]!r}: one of {', '.join(PARTS)}, start, build\n")
    if args.repeats < 1:
        parser.exit(2, f"error: --repeats = {args.repeats}: must be at least 1\n")
    why = why_not_replaceable(args.out)
    if why:
        parser.exit(2, f"error: --out = {str(args.out)!r}: {why}\n")
    readme_parts = {"readme", "readme_prebuilt", "readme_installed"}
    if args.device != "cpu" and (not args.only or not set(args.only) <= readme_parts):
        parser.exit(2, f"error: --device = {args.device!r}: only the readme parts take a device; add --only readme\n")
    return args


def main() -> None:
    args = _arguments()
    record = json.loads(args.out.read_text()) if args.only and args.out.is_file() else {}
    stamp = datetime.now(timezone.utc).isoformat(timespec="seconds")
    record |= {
        "command": " ".join(["python -m hertzian.studies.fixed_costs", *sys.argv[1:]]),
        "device": args.device,
        "cpu_count": os.cpu_count(),
        "platform": platform.platform(),
    }
    record.setdefault("dates", {})
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.only or [p for p in PARTS if p not in ("readme_installed", "suite_modules")]:
            record[name] = PARTS[name](tmp, args)
            record["dates"][name] = stamp
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
