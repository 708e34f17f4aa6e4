"""Scale-out curves of ``hertzian sweep`` over several workers (``hertzian bench --scale-out``), end to end.

Every run is a fresh ``python -m hertzian.cli sweep … --json`` process, timed from its start to its exit (imports,
cluster start, planning, store creation and finalisation included):

* **strong scaling** — the sweep as given: serially (no Dask, the one-device baseline), then with ``--workers n``
  for each count; speed-up = baseline wall / wall, efficiency = speed-up / n;
* **weak scaling** (on request) — work in proportion to the workers: ``integrator.duration`` scaled by
  n / max(counts) (``--workers n``; n = 1 runs serially), so the largest count repeats the strong run's work;
  efficiency = wall(1) / wall(n);
* **busy fraction** of each worker: the seconds its batches took (build, integration, writes; from the store's
  completion records) over the batch phase;
* **bitwise**: every strong-scaling store against the serial store (``differing_arrays``), as soon as its run
  ends; the weak runs of shorter durations have no reference of their own.

The record is complete after every run (:class:`Measurement`): a measurement killed by a time limit keeps every
finished run, and a time budget skips the runs that would not fit."""

from __future__ import annotations

import json
import os
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


class Measurement:
    """The record of a scale-out measurement as it grows: derived figures refreshed, the record rewritten to
    ``path`` (when given, atomically) and one line logged after every run, so a killed measurement keeps every
    finished run's numbers."""

    def __init__(self, header: dict[str, Any], budget: float | None, path: Path | None, log: Callable[[str], None]):
        self.record = {**header, "budget_seconds": budget, "complete": False, "strong": [], "weak": [], "skipped": []}
        self.budget, self.path, self.log = budget, path, log
        self.start = time.perf_counter()

    def elapsed(self) -> float:
        """Seconds since the measurement started [s]."""
        return time.perf_counter() - self.start

    def fits(self, label: str, estimate: float) -> bool:
        """Whether a run estimated at ``estimate`` seconds fits what is left of the budget; a skipped run is
        recorded and logged."""
        if self.budget is None or estimate <= self.budget - self.elapsed():
            return True
        left = max(self.budget - self.elapsed(), 0.0)
        self.record["skipped"].append({"run": label, "estimated_seconds": estimate, "seconds_left": left})
        self.log(f"skipped {label}: estimated {estimate:.1f} s, {left:.1f} s left of the {self.budget:g} s budget")
        self.save()
        return False

    def add(self, kind: str, label: str, run: dict[str, Any]) -> None:
        """Append a finished run to ``kind`` (strong | weak), refresh the figures, save and log it."""
        run["label"] = label
        self.record[kind].append(run)
        self.refresh()
        self.save()
        figures = (
            f"speed-up {run['speedup']:.2f}, efficiency {run['efficiency']:.0%}"
            if kind == "strong"
            else f"duration {run['duration']:g}, efficiency {_percent(run['efficiency'])}"
        )
        busy = ", ".join(f"{w} {b:.0%}" for w, b in run["busy"].items())
        bits = (
            "" if "differing_arrays" not in run else f"; store {'equal' if not run['differing_arrays'] else 'DIFFERS'}"
        )
        self.log(
            f"{kind} {label}: {run['process_seconds']:.2f} s, {figures}, batch phase {run['seconds']['batches']:.2f} s, "
            f"busy {busy}{bits} ({self.elapsed():.0f} s so far)"
        )

    def refresh(self) -> None:
        """Speed-ups and efficiencies against the serial runs measured so far; the bitwise verdict so far."""
        strong, weak = self.record["strong"], self.record["weak"]
        for run in strong:
            run["speedup"] = strong[0]["process_seconds"] / run["process_seconds"]
            run["efficiency"] = run["speedup"] / run["workers"]
            run["batch_phase_speedup"] = strong[0]["seconds"]["batches"] / run["seconds"]["batches"]
        for run in weak:
            one = weak[0] if weak[0]["workers"] == 1 else None
            run["efficiency"] = one["process_seconds"] / run["process_seconds"] if one else None
        self.record["bitwise_equal"] = all(not r.get("differing_arrays") for r in strong)

    def save(self) -> None:
        """Rewrite the record file (a temporary file renamed over it: never half-written)."""
        if self.path is None:
            return
        partial = self.path.with_name(self.path.name + ".partial")
        partial.write_text(json.dumps(self.record, indent=1))
        os.replace(partial, self.path)


def scale_out(
    sweep: Path,
    counts: list[int],
    *,
    sets: list[str] | None = None,
    device: str | None = None,
    workdir: Path,
    weak: bool = False,
    budget: float | None = None,
    record_path: Path | None = None,
    keep_stores: bool = False,
    log: Callable[[str], None] = lambda message: None,
) -> dict[str, Any]:
    """Strong (and with ``weak``, weak) scaling of ``sweep`` over ``counts`` workers (see the module docstring);
    returns the whole record (JSON-ready), also written to ``record_path`` after every run.

    ``budget`` [s]: a run whose estimate does not fit the seconds left is skipped (listed under ``skipped``);
    the estimate of a run with n workers and work fraction f is f · (serial batch phase) / n + the fixed costs
    (process wall − batch phase) of the last run measured. Stores go to ``workdir``; each is compared with the
    serial store as soon as its run ends and deleted unless ``keep_stores`` (at most two on disk at once)."""
    sets = list(sets or [])
    workdir.mkdir(parents=True, exist_ok=True)
    duration = load_sweep(sweep, _overrides(sets)).base.integrator.duration
    header = {"kind": "scale-out", "date": today(), "host": platform.node(), "sweep": str(sweep), "sets": sets}
    header |= {"device": device or "default", "counts": counts, "weak_scaling": weak}
    m = Measurement(header, budget, record_path, log)
    reference = workdir / "strong_serial.zarr"
    log(f"strong: serial baseline of {sweep}")
    baseline = timed_sweep(sweep, reference, None, sets, device)
    m.record["grain_steps"] = baseline["grain_steps"]
    m.add("strong", "serial", baseline)
    last = [baseline]  # the run whose fixed costs estimate the next one's
    for n in counts:
        label = f"--workers {n}"
        if not m.fits(f"strong {label}", _estimate(baseline, last[0], 1.0, n)):
            continue
        out = workdir / f"strong_{n}.zarr"
        run = timed_sweep(sweep, out, n, sets, device)
        run["differing_arrays"] = differing_arrays(out, reference)
        _drop(out, keep_stores)
        last[0] = run
        m.add("strong", label, run)
    _drop(reference, keep_stores)
    if weak:
        _weak(sweep, counts, sets, device, workdir, duration, m, baseline, last, keep_stores)
    m.record["complete"] = True
    m.save()
    return m.record


def _weak(sweep, counts, sets, device, workdir, duration, m: Measurement, baseline, last, keep_stores) -> None:
    """The weak-scaling runs: ``integrator.duration`` × n / max(counts); the largest count is the strong run."""
    largest = max(counts)
    for n in sorted({1, *counts}):
        label = "serial" if n == 1 else f"--workers {n}"
        strong = next((r for r in m.record["strong"][1:] if r["workers"] == n), None)
        if n == largest and strong is not None:  # the strong run's work: that run is the point
            m.add("weak", strong["label"], {**strong, "duration": duration})
            continue
        scaled = duration * n / largest
        if not m.fits(f"weak {label}", _estimate(baseline, baseline if n == 1 else last[0], n / largest, n)):
            continue
        out = workdir / f"weak_{n}.zarr"
        run = timed_sweep(sweep, out, None if n == 1 else n, [*sets, f"integrator.duration={scaled!r}"], device)
        _drop(out, keep_stores)
        run["duration"] = scaled
        if n > 1:
            last[0] = run
        m.add("weak", label, run)


def _estimate(baseline: dict, last: dict, fraction: float, workers: int) -> float:
    """Seconds a run of ``fraction`` of the work on ``workers`` is expected to take: its share of the serial
    batch phase plus the fixed costs (process wall − batch phase) of ``last``."""
    fixed = last["process_seconds"] - last["seconds"]["batches"]
    return fraction * baseline["seconds"]["batches"] / workers + fixed


def _percent(value: float | None) -> str:
    return "–" if value is None else f"{value:.0%}"


def _overrides(sets: list[str]) -> dict:
    from hertzian.core.scene import parse_overrides

    return parse_overrides(sets)


def _drop(store: Path, keep: bool) -> None:
    if not keep:
        shutil.rmtree(store, ignore_errors=True)
