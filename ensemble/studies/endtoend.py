"""End-to-end benchmark: a whole ``run`` of a scene file or a whole ``sweep``, records and store included.

``hertzian bench --scene FILE`` / ``--sweep FILE`` time what a user runs, not a kernel in a loop, and
split the wall time into

* ``build``   — model arrays, the Taylor start (and, for a sweep: load, expand, plan);
* ``compile`` — kernel choice, calibration, Warp compile or load from Warp's kernel cache;
* ``kernel``  — host time inside the solvers' ``advance`` (on a CPU: the kernels themselves);
* ``record``  — device checks, host copies and unpacking of records;
* ``store``   — Zarr writes (a sweep's run in a background thread: a batch's records while it runs, the rest
  while the next batch runs);
* ``create_store_overlapped`` — (sweep) seconds creating the store, in that thread while the first batch runs;
* ``prepare_overlapped`` — (sweep on CUDA) host seconds spent preparing batch b + 1's arrays in a
  background thread while batch b ran (not part of ``total``'s critical path; the part the main
  thread still waited for is in ``build``);

and report ``device_busy`` = device seconds / end-to-end seconds (CUDA: summed event times of the
advances; CPU: the kernel seconds). ``--cold`` runs with empty Warp and calibration caches (a fresh
temporary directory), so a cold and a warm invocation show what compile and calibration cost.
"""

from __future__ import annotations

import platform
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import warp as wp
from hertzian.studies.bench import today


def _device_name(device: str) -> str:
    d = wp.get_device(device)
    return f"{d.name} ({platform.processor() or platform.machine()})" if d.is_cpu else d.name


def _summary(
    kind: str,
    source: str,
    device: str,
    *,
    chains: int,
    grains: int,
    steps: int,
    grain_steps: float,
    kernels: list[str],
    seconds: dict[str, float],
    device_seconds: float,
    notes: list[str],
) -> dict:
    total = seconds["total"]
    return {
        "workload": source,
        "kind": kind,
        "device": device,
        "device_name": _device_name(device),
        "date": today(),
        "chains": chains,
        "grains": grains,
        "steps": steps,
        "grain_steps": grain_steps,
        "kernel": ",".join(sorted(set(kernels))),
        "notes": notes,
        "seconds": {k: round(v, 6) for k, v in seconds.items()},
        "device_seconds": round(device_seconds, 6),
        "device_busy": device_seconds / total if total > 0 else 0.0,
        "grain_steps_per_second": grain_steps / total if total > 0 else 0.0,
        "kernel_grain_steps_per_second": grain_steps / seconds["kernel"] if seconds["kernel"] > 0 else 0.0,
    }


def start_device(device: str) -> float:
    """Make ``device`` ready before a bench's clock starts, as Warp's initialisation is before it: on CUDA the first use
    creates the context and its memory pool (0.11-0.14 s on the H100 hosts, docs/benchmarks.md, sixth session), once
    per process whatever runs after it. Returns its seconds (reported as ``startup``, outside ``total``)."""
    start = time.perf_counter()
    wp.synchronize_device(device)
    wp.zeros(1, device=device)
    wp.synchronize_device(device)
    return time.perf_counter() - start


def bench_scene(
    path: str | Path, device: str, *, kernel: str = "auto", overrides: dict[str, Any] | None = None, log=None
) -> dict:
    """Time ``hertzian run`` of one scene file end to end (store written to a temporary directory)."""
    from hertzian.core.model import build_model
    from hertzian.core.runner import Runner
    from hertzian.core.scene import load_scene
    from hertzian.sweeping.sweep_store import write_result

    startup = start_device(device)
    start = time.perf_counter()
    scene = load_scene(path, overrides)
    model = build_model([scene], device)
    build = time.perf_counter() - start
    runner = Runner(model, kernel=kernel)
    result = runner.run()
    clock = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="hertzian-bench-") as tmp:
        write_result(Path(tmp) / "run.zarr", result)
        store = time.perf_counter() - clock
    total = time.perf_counter() - start
    t = result.timing
    seconds = {
        "total": total,
        "build": build,
        "compile": t["setup"],
        "kernel": t["advance"],
        "record": t["record"],
        "store": store,
        "startup": startup,
    }
    if log:
        log(f"{path}: {result.kernel}, {total:.2f} s end to end")
    return _summary(
        "scene",
        str(path),
        device,
        chains=1,
        grains=model.grain_count,
        steps=result.steps,
        grain_steps=float(model.grain_count) * result.steps,
        kernels=[result.kernel],
        seconds=seconds,
        device_seconds=t["device"],
        notes=[runner.kernel_note] if runner.kernel_note else [],
    )


def bench_sweep(
    path: str | Path, device: str, *, kernel: str = "auto", overrides: dict[str, Any] | None = None, log=None
) -> dict:
    """Time ``hertzian sweep`` (serial, this process) end to end: plan, store, batches, background writes."""
    from hertzian.core.solvers.calibrate import step_reason_of
    from hertzian.sweeping.distributed import jobs_for, run_serial, runs_of, warm_kernels
    from hertzian.sweeping.planner import plan_sweep
    from hertzian.sweeping.spec import expand, load_sweep
    from hertzian.sweeping.sweep_store import create_sweep_store, finalize

    startup = start_device(device)
    start = time.perf_counter()
    definition = load_sweep(path, overrides)
    points = expand(definition)
    plan = plan_sweep(definition, points, device)
    notes = []
    for index, group in enumerate(plan.groups):
        batch = next((b for b in plan.batches if b.group == index), None)
        reason = (
            batch is not None
            and kernel == "auto"
            and step_reason_of(group.features, wp.get_device(device).is_cpu, plan.batch_grain_steps(batch))
        )
        if reason:
            notes.append(f"launch group {index}: per-step kernel: {reason}")
    with tempfile.TemporaryDirectory(prefix="hertzian-bench-") as tmp, ThreadPoolExecutor(max_workers=1) as loader:
        out = Path(tmp) / "sweep.zarr"
        # as `hertzian sweep`: the kernels load in a thread; the store thread creates the store while the first
        # batch's first records run
        warming = loader.submit(
            warm_kernels, [g.features for g in plan.groups], device, runs=runs_of(plan, points, plan.batches)
        )
        jobs = jobs_for(out, plan, points, plan.batches, kernel=kernel)
        build = time.perf_counter() - start
        clock = time.perf_counter()
        warming.result()
        compile_seconds = time.perf_counter() - clock  # the part of loading that nothing hid
        totals = {
            "compile": 0.0,
            "kernel": 0.0,
            "record": 0.0,
            "device": 0.0,
            "build": 0.0,
            "store": 0.0,
            "prepare": 0.0,
            "prepare_wait": 0.0,
        }
        kernels = []

        def add(job, result, batch_build):
            t = result.timing
            totals["build"] += batch_build - t["setup_in_init"]
            totals["compile"] += t["setup"]
            totals["kernel"] += t["advance"]
            totals["record"] += t["record"]
            totals["device"] += t["device"]
            kernels.append(result.kernel)

        # exactly `hertzian sweep`'s pipeline (serial): the next batch prepared and the store written in threads
        run_serial(
            jobs,
            device,
            on_result=add,
            timing=totals,
            create_store=lambda: create_sweep_store(out, definition, points.templates[0], plan, device=device),
        )
        finalize(out)
    total = time.perf_counter() - start
    seconds = {
        "total": total,
        "build": build + totals["build"] + totals["prepare_wait"],
        "compile": compile_seconds + totals["compile"],
        "kernel": totals["kernel"],
        "record": totals["record"],
        "store": totals["store"],
        "create_store_overlapped": totals.get("create_store", 0.0),
        "prepare_overlapped": totals["prepare"],
        "startup": startup,
    }
    grain_steps = float(sum(j.grain_steps for j in jobs))
    first = points.templates[0]
    if log:
        log(f"{path}: {plan.point_count} points, {len(jobs)} batches, {total:.2f} s end to end")
    return _summary(
        "sweep",
        str(path),
        device,
        chains=plan.point_count,
        grains=first.chain.grains,
        steps=first.step_count,
        grain_steps=grain_steps,
        kernels=kernels,
        seconds=seconds,
        device_seconds=totals["device"],
        notes=notes,
    )
