"""Scale-out curves of ``hertzian sweep`` over several workers (``hertzian bench --scale-out``), end to end.

Every run is a fresh ``python -m hertzian.cli sweep … --json`` process, timed from its start to its exit (imports,
cluster start, planning, store creation and finalisation included):

* **strong scaling** — the sweep as given: serially (no Dask, the one-device baseline), then with ``--workers n``
  for each count; speed-up = baseline wall / wall, efficiency = speed-up / n;
* **weak scaling** — work in proportion to the workers: ``integrator.duration`` scaled by n / max(counts)
  (``--workers n``; n = 1 runs serially), so the largest count repeats the strong run's work; efficiency =
  wall(1) / wall(n);
* **busy fraction** of each worker: the seconds its batches took (build, integration, writes; from the store's
  completion records) over the batch phase;
* **bitwise**: every strong-scaling store against the serial store (``differing_arrays``); the weak runs of
  shorter durations have no reference of their own.
"""

from __future__ import annotations

import json
import platform
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from hertzian.studies.bench import today
from hertzian.sweeping.spec import load_sweep
from hertzian.sweeping.sweep_store import batch_records, differing_arrays


def sweep_command(sweep: Path, out: Path, workers: int | None, sets: list[str], device: str | None) -> list[str]:
    """The ``hertzian sweep`` command line of one run (``workers`` None: serial)."""
    command = [sys.executable, "-m", "hertzian.cli", "sweep", str(sweep), "--out", str(out), "--quiet", "--json"]
    command += ["--workers", str(workers)] if workers is not None else []
    command += ["--device", device] if device else []
    for item in sets:
        command += ["--set", item]
    return command


def busy_fractions(store: Path, batch_seconds: float) -> dict[str, float]:
    """Worker → seconds of its batches (build + integration + writes) / the batch phase's seconds."""
    busy: dict[str, float] = {}
    for r in batch_records(store):
        busy[r["worker"] or "main"] = busy.get(r["worker"] or "main", 0.0) + (
            r["build_seconds"] + r["wall_seconds"] + r["write_seconds"]
        )
    return {w: s / max(batch_seconds, 1e-12) for w, s in sorted(busy.items())}


def timed_sweep(sweep: Path, out: Path, workers: int | None, sets: list[str], device: str | None) -> dict[str, Any]:
    """Run one sweep process; its ``--json`` summary with ``process_seconds``, ``workers`` and ``busy``."""
    command = sweep_command(sweep, out, workers, sets, device)
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} exited {done.returncode}: {done.stderr.strip()[-2000:]}")
    record = json.loads(done.stdout)
    record.update(process_seconds=wall, workers=workers or 1, serial=workers is None, command=" ".join(command))
    record["busy"] = busy_fractions(out, record["seconds"]["batches"])
    return record


def scale_out(
    sweep: Path,
    counts: list[int],
    *,
    sets: list[str] | None = None,
    device: str | None = None,
    workdir: Path,
    keep_stores: bool = False,
    log: Callable[[str], None] = lambda message: None,
) -> dict[str, Any]:
    """Strong and weak scaling of ``sweep`` over ``counts`` workers (see the module docstring); stores go to
    ``workdir`` and are deleted once compared unless ``keep_stores``. Returns the whole record (JSON-ready)."""
    sets = list(sets or [])
    workdir.mkdir(parents=True, exist_ok=True)
    duration = load_sweep(sweep, _overrides(sets)).base.integrator.duration
    reference = workdir / "strong_serial.zarr"
    log(f"strong: serial baseline of {sweep}")
    baseline = timed_sweep(sweep, reference, None, sets, device)
    strong = [baseline]
    for n in counts:
        log(f"strong: --workers {n}")
        out = workdir / f"strong_{n}.zarr"
        run = timed_sweep(sweep, out, n, sets, device)
        run["differing_arrays"] = differing_arrays(out, reference)
        strong.append(run)
        _drop(out, keep_stores)
    for run in strong:
        run["speedup"] = baseline["process_seconds"] / run["process_seconds"]
        run["efficiency"] = run["speedup"] / run["workers"]
        run["batch_phase_speedup"] = baseline["seconds"]["batches"] / run["seconds"]["batches"]
    largest = max(counts)
    weak = []
    for n in sorted({1, *counts}):
        if n == largest:  # the strong run's work: that run is the point
            weak.append({**strong[1 + counts.index(n)], "duration": duration})
            continue
        scaled = duration * n / largest
        log(f"weak: {'serial' if n == 1 else f'--workers {n}'}, integrator.duration = {scaled:g}")
        out = workdir / f"weak_{n}.zarr"
        run = timed_sweep(sweep, out, None if n == 1 else n, [*sets, f"integrator.duration={scaled!r}"], device)
        run["duration"] = scaled
        weak.append(run)
        _drop(out, keep_stores)
    for run in weak:
        run["efficiency"] = weak[0]["process_seconds"] / run["process_seconds"]
    _drop(reference, keep_stores)
    return {
        "kind": "scale-out",
        "date": today(),
        "host": platform.node(),
        "sweep": str(sweep),
        "sets": sets,
        "device": device or "default",
        "counts": counts,
        "grain_steps": baseline["grain_steps"],
        "bitwise_equal": all(not r["differing_arrays"] for r in strong[1:]),
        "strong": strong,
        "weak": weak,
    }


def _overrides(sets: list[str]) -> dict:
    from hertzian.core.scene import parse_overrides

    return parse_overrides(sets)


def _drop(store: Path, keep: bool) -> None:
    if not keep:
        shutil.rmtree(store, ignore_errors=True)
