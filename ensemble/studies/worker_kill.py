"""A worker killed with SIGKILL mid-sweep (docs/scale-out.md): two local workers, one per GPU where there are GPUs,
the sweep sent to them with ``--scheduler``, worker 1 killed as soon as the store holds a completed batch. The sweep
must finish (the killed worker's nanny restarts it and its batch runs again) with a store equal, array by array and
bit for bit, to a serial run's.

``python -m hertzian.studies.worker_kill OUT.json [--sweep FILE] [--set KEY=VALUE ...] [--batch-size N]``
(default: sweeps/scale.toml cut to duration 50 in batches of 1000 points)."""

from __future__ import annotations

import argparse
import json
import os
import platform
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from hertzian.core.shipped import shipped_file
from hertzian.studies.bench import today
from hertzian.sweeping.distributed import local_cluster, visible_gpus
from hertzian.sweeping.sweep_store import batch_records, completed_batches, differing_arrays

DEFAULT_SETS = ("integrator.duration=50",)
DEFAULT_BATCH = 1000


def _sweep(sweep: Path, out: Path, flags: list[str]) -> tuple[subprocess.CompletedProcess, float]:
    """``hertzian sweep`` in a fresh process; its result and wall seconds."""
    command = [sys.executable, "-m", "hertzian.cli", "sweep", str(sweep), "--out", str(out), "--quiet", *flags]
    clock = time.perf_counter()
    result = subprocess.run(command, capture_output=True, text=True)
    return result, time.perf_counter() - clock


def _kill_after_first_batch(store: Path, pid: int, state: dict, timeout: float = 600.0) -> None:
    """SIGKILL ``pid`` as soon as ``store`` holds a completed batch; ``state`` gets when and how many were done."""
    start = time.monotonic()
    while time.monotonic() - start < timeout:
        try:
            done = completed_batches(store)
        except Exception:  # the store is not created yet
            done = set()
        if done:
            state.update(done_at_kill=len(done), seconds_to_kill=time.monotonic() - start)
            os.kill(pid, signal.SIGKILL)
            return
        time.sleep(0.02)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def kill_one_worker(sweep: Path, flags: list[str], workdir: Path, device: str | None = None) -> dict[str, Any]:
    """The measurement (module docstring) in ``workdir``; ``flags``: extra ``hertzian sweep`` options (``--set``,
    ``--batch-size``); ``device`` names the serial run's device (default: the sweep's default)."""
    serial_flags = flags + (["--device", device] if device else [])
    serial, serial_seconds = _sweep(sweep, workdir / "serial.zarr", serial_flags)
    if serial.returncode != 0:
        raise RuntimeError(f"the serial run failed: {serial.stderr.strip().splitlines()[-1:]}")
    gpus = visible_gpus() if device in (None, "cuda") else []
    state: dict[str, Any] = {}
    store = workdir / "killed.zarr"
    with local_cluster(2, gpus=gpus) as cluster:
        from distributed import Client  # Dask only for this measurement

        with Client(cluster) as client:
            workers = client.scheduler_info(n_workers=-1)["workers"]
            pids = client.run(os.getpid)
        victim = pids[next(address for address, w in workers.items() if w["name"] == 1)]
        killer = threading.Thread(target=_kill_after_first_batch, args=(store, victim, state))
        killer.start()
        result, seconds = _sweep(sweep, store, flags + ["--scheduler", cluster.scheduler_address])
        killer.join()
        alive = _alive(victim)  # while the cluster runs: a nanny's restart is a new process
    return {
        "gpus": gpus,
        "serial_seconds": serial_seconds,
        "killed_run_seconds": seconds,
        "returncode": result.returncode,
        "victim_alive_after": alive,
        **state,
        "batches_completed": len(completed_batches(store)) if store.exists() else 0,
        "workers_in_completion_records": sorted({str(r["worker"]) for r in batch_records(store)}),
        "differing_arrays": differing_arrays(store, workdir / "serial.zarr") if store.exists() else None,
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m hertzian.studies.worker_kill", description=__doc__.split("\n")[0])
    parser.add_argument("out", type=Path, help="the JSON record to write")
    parser.add_argument("--sweep", default="scale.toml", help="sweep file (a shipped name or a path)")
    parser.add_argument("--set", dest="sets", action="append", default=None, help="KEY=VALUE override (repeatable)")
    parser.add_argument("--batch-size", type=int, default=DEFAULT_BATCH)
    parser.add_argument("--device", default=None, help="cpu, cuda (default: cuda if present, else cpu)")
    args = parser.parse_args(argv)
    sweep = shipped_file(args.sweep)
    sets = list(DEFAULT_SETS) if args.sets is None else args.sets
    flags = [f for s in sets for f in ("--set", s)] + ["--batch-size", str(args.batch_size)]
    with tempfile.TemporaryDirectory(prefix="hertzian-kill-") as tmp:
        found = kill_one_worker(sweep, flags, Path(tmp), args.device)
    record = {
        "what": "a worker killed with SIGKILL mid-sweep; the store against a serial run's (docs/scale-out.md)",
        "date": today(),
        "host": platform.node(),
        "command": "python -m hertzian.studies.worker_kill " + " ".join(sys.argv[1:] if argv is None else argv),
        **found,
    }
    args.out.write_text(json.dumps(record, indent=1) + "\n")
    print(json.dumps(record, indent=1))


if __name__ == "__main__":
    main()
