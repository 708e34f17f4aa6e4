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
from pathlib import Path
from typing import Any

import warp as wp
from hertzian.studies.bench import today
from hertzian.sweeping.pipeline import prepare_sweep, run_sweep


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
    creates the context and its memory pool (measured: docs/records/bench/h100_endtoend.json, ``startup``), once per
    process whatever runs after it. Returns its seconds (reported as ``startup``, outside ``total``)."""
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
    """Time ``hertzian sweep`` (serial, this process) end to end through the sweep pipeline: load, plan, store,
    batches, background writes, finalize (the store in a temporary directory)."""
    startup = start_device(device)
    notes: list[str] = []
    totals = dict.fromkeys(("compile", "kernel", "record", "device", "build"), 0.0)
    kernels = []

    def add(job, result, batch_build):
        t = result.timing
        totals["build"] += batch_build - t["setup_in_init"]
        totals["compile"] += t["setup"]
        totals["kernel"] += t["advance"]
        totals["record"] += t["record"]
        totals["device"] += t["device"]
        kernels.append(result.kernel)

    def note(line: str) -> None:
        if "per-step kernel" in line:
            notes.append(line.removeprefix("note: "))

    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="hertzian-bench-") as tmp:
        prepared = prepare_sweep(
            path, Path(tmp) / "sweep.zarr", device=device, kernel=kernel, overrides=overrides, notify=note
        )
        done = run_sweep(prepared, notify=note, on_result=add)
    total = time.perf_counter() - start
    t = done["seconds"]
    seconds = {
        "total": total,
        "build": sum(t[k] for k in ("load", "expand", "plan", "jobs")) + totals["build"] + t["prepare_wait"],
        "compile": t["warm_kernels"] + totals["compile"],  # the part of loading that nothing hid, then per batch
        "kernel": totals["kernel"],
        "record": totals["record"],
        "store": t["store"],
        "create_store_overlapped": t.get("create_store", 0.0),
        "prepare_overlapped": t["prepare"],
        "startup": startup,
    }
    first = prepared.points.templates[0]
    if log:
        log(f"{path}: {done['points']} points, {done['batches_run']} batches, {total:.2f} s end to end")
    return _summary(
        "sweep",
        str(path),
        device,
        chains=done["points"],
        grains=first.chain.grains,
        steps=first.step_count,
        grain_steps=float(done["grain_steps"]),
        kernels=kernels,
        seconds=seconds,
        device_seconds=totals["device"],
        notes=notes,
    )
