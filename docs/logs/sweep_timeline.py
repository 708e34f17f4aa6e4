"""Where a sweep's (or a detection's) wall time goes: a timeline of `hertzian bench --sweep FILE` (or `hertzian sweep`,
or a first detection) by thread.

Wraps the sweep's phases (load, expand, plan, store creation, kernel loading, batch preparation, model upload,
solver and recorder set-up, each record, the store writes, finalize) and Warp's module loads and device
synchronisations, and records CUDA events around every advance so the GPU's busy intervals sit on the same clock
as the host's (a reference event is recorded while the device is idle). Prints one line per interval, start and
end in ms from the first phase, with the thread, then the GPU-idle gaps.

    python3 docs/logs/sweep_timeline.py sweeps/gpu_10k.toml --device cuda [--cli]

``--cli`` times ``hertzian sweep FILE --out TMP --overwrite --quiet`` through the CLI instead of the bench.
``--detect`` takes FILE as a detection study (sweeps/detect_study_*.toml): it plants a light grain at half depth
(26 dB, as docs/logs/detection/profile_first.py), runs `detect` once untimed (compiles, in a library cache of its
own), then times a first detection on a new host chain (an empty cache) with the kernels compiled.
"""

from __future__ import annotations

import argparse
import functools
import importlib
import json
import os
import sys
import tempfile
import threading
import time
from pathlib import Path

INTERVALS: list[tuple[str, str, float, float]] = []
GPU: list[tuple[object, object]] = []
ORIGIN = [None]


def _wrap(owner, name: str, label: str) -> None:
    inner = getattr(owner, name)

    @functools.wraps(inner)
    def timed(*args, **kwargs):
        t0 = time.perf_counter()
        try:
            return inner(*args, **kwargs)
        finally:
            INTERVALS.append((label, threading.current_thread().name, t0, time.perf_counter()))

    setattr(owner, name, timed)


_GC_START = [0.0]


def _gc_interval(phase: str, info: dict) -> None:
    # the garbage collector's passes over the oldest generation (they stop every Python thread)
    if info["generation"] != 2:
        return
    if phase == "start":
        _GC_START[0] = time.perf_counter()
    else:
        INTERVALS.append(("gc (full pass)", threading.current_thread().name, _GC_START[0], time.perf_counter()))


def instrument() -> None:
    import gc

    import warp as wp

    gc.callbacks.append(_gc_interval)

    targets = {
        "hertzian.ensemble.sweep": ["load_sweep", "expand"],
        "hertzian.ensemble.planner": ["plan_sweep", "device_budget"],
        "hertzian.ensemble.sweep_store": ["create_sweep_store", "write_batch", "finalize"],
        "hertzian.ensemble.distributed": ["warm_kernels", "prepare_job", "integrate_job", "jobs_for"],
        "hertzian.ensemble.model": ["build_model"],
        "hertzian.ensemble.solvers": ["choose_config", "make_solver"],
    }
    for module, names in targets.items():
        mod = importlib.import_module(module)
        for name in names:
            _wrap(mod, name, name)
    from hertzian.ensemble import runner as runner_module
    from hertzian.ensemble.recorder import Recorder
    from hertzian.ensemble.runner import Runner

    # the runner module imported these names before the wrapping: wrap its own references too
    for name in ("choose_config", "make_solver", "build_model"):
        if hasattr(runner_module, name):
            _wrap(runner_module, name, name)
    _wrap(Runner, "__init__", "Runner.__init__")
    _wrap(Runner, "run", "Runner.run")
    for name in ("load", "record", "finish", "release", "check", "_unpack"):
        _wrap(Recorder, name, f"Recorder.{name}")
    from hertzian.ensemble import detect as detect_module

    for name in ("run_candidates", "_prepare_candidates", "assemble_library", "save_library", "_echo_projections",
                 "front_times", "fine_scan", "build_library"):
        _wrap(detect_module, name, name)
    _wrap(detect_module.Library, "finish_saving", "Library.finish_saving")
    from hertzian.ensemble import sweep_store as store_module

    _wrap(store_module, "_open_for_writing", "_open_for_writing")
    _wrap(store_module.RowWriter, "_write", "RowWriter._write")
    _wrap(store_module.RowWriter, "settle", "RowWriter.settle")
    _wrap(wp, "synchronize_event", "wp.synchronize_event")
    _wrap(wp, "load_module", "wp.load_module")
    _wrap(wp, "synchronize_device", "wp.synchronize_device")
    _wrap(wp, "synchronize", "wp.synchronize")

    advance = Runner.advance_monitored

    def advance_with_events(self, first_step, n_steps):
        device = self.model.device
        if device.is_cuda:
            a = wp.get_stream(device).record_event(wp.Event(device, enable_timing=True))
        t0 = time.perf_counter()
        advance(self, first_step, n_steps)
        INTERVALS.append(("advance (host)", threading.current_thread().name, t0, time.perf_counter()))
        if device.is_cuda:
            GPU.append((a, wp.get_stream(device).record_event(wp.Event(device, enable_timing=True))))

    Runner.advance_monitored = advance_with_events


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sweep")
    parser.add_argument("--device", default="cuda")
    parser.add_argument("--cli", action="store_true")
    parser.add_argument("--detect", action="store_true", help="FILE is a detection study: time a first detection")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()

    t_import = time.perf_counter()
    import warp as wp

    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    from hertzian.ensemble.endtoend import bench_sweep

    instrument()
    imported = time.perf_counter() - t_import
    if args.detect:
        import tempfile as tmp_module

        sys.path.insert(0, str(Path(__file__).resolve().parent / "detection"))
        from profile_detect import planted_signal

        from hertzian.ensemble.detect import detect

        signal, base, kwargs = planted_signal(args.sweep, args.device, depth_fraction=0.5, fronts_cache=False)
        os.environ["HERTZIAN_DETECT_CACHE"] = tmp_module.mkdtemp(prefix="hz-detect-")
        detect(signal, base, device=args.device, **kwargs)  # compiles and calibrates: not timed
        os.environ["HERTZIAN_DETECT_CACHE"] = tmp_module.mkdtemp(prefix="hz-detect-")
        INTERVALS.clear()
        GPU.clear()
    reference = None
    if wp.get_device(args.device).is_cuda:
        wp.synchronize_device(args.device)
        reference = wp.get_stream(args.device).record_event(wp.Event(args.device, enable_timing=True))
        wp.synchronize_device(args.device)
    origin = time.perf_counter()
    summary = None
    if args.detect:
        found, _ = detect(signal, base, device=args.device, **kwargs)
        print(f"first detection: {found.kind} depth {found.depth} mass ratio {found.mass_ratio:.4g}; "
              f"seconds {found.seconds}")
    elif args.cli:
        from hertzian.ensemble.cli import main as cli_main

        with tempfile.TemporaryDirectory() as tmp:
            sys.argv = ["hertzian", "sweep", args.sweep, "--out", f"{tmp}/s.zarr", "--overwrite", "--quiet",
                        "--device", args.device, "--json"]
            try:
                cli_main()
            except SystemExit as exit_:
                if exit_.code:
                    raise
    else:
        summary = bench_sweep(args.sweep, args.device)
    end = time.perf_counter()

    rows = [(label, thread, (t0 - origin) * 1e3, (t1 - origin) * 1e3) for label, thread, t0, t1 in INTERVALS]
    if reference is not None:
        for a, b in GPU:
            rows.append(("GPU busy", "device", wp.get_event_elapsed_time(reference, a),
                         wp.get_event_elapsed_time(reference, b)))
    rows.sort(key=lambda r: r[2])
    print(f"imports + Warp init before the clock: {imported * 1e3:.0f} ms; end to end {(end - origin) * 1e3:.0f} ms")
    print(f"{'start ms':>9} {'end ms':>9} {'ms':>8}  thread              interval")
    for label, thread, s, e in rows:
        print(f"{s:9.1f} {e:9.1f} {e - s:8.1f}  {thread[:18]:18s}  {label}")
    busy = sorted((s, e) for label, _, s, e in rows if label == "GPU busy")
    if busy:
        idle, last = [], 0.0
        for s, e in busy:
            if s > last:
                idle.append((last, s))
            last = max(last, e)
        idle.append((last, (end - origin) * 1e3))
        print("GPU idle gaps (ms): " + ", ".join(f"{a:.0f}-{b:.0f} ({b - a:.0f})" for a, b in idle))
        print(f"GPU busy {sum(e - s for s, e in busy):.0f} ms of {(end - origin) * 1e3:.0f} ms; "
              f"outside the GPU {sum(b - a for a, b in idle):.0f} ms")
    if args.json:
        args.json.write_text(json.dumps({"rows": rows, "summary": summary}, indent=1))


if __name__ == "__main__":
    main()
