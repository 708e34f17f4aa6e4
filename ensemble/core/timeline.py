"""A process timeline: seconds since the process started at each phase of a command, written as JSON.

``HERTZIAN_TIMELINE=PATH`` makes the process write, when it exits, ``{"phases": [{"phase": name, "seconds": t,
...details}], "wall_seconds": t_exit, "pid": ..., "argv": [...]}`` to PATH (t: seconds since the process started,
as the operating system records it on Linux, else since ``hertzian`` was first imported). Marks are a list
append and cost nothing measurable when the variable is unset; nothing is written then.
"""

from __future__ import annotations

import atexit
import json
import os
import sys
import time
from pathlib import Path

ENV = "HERTZIAN_TIMELINE"
"""Environment variable naming the JSON file the timeline is written to."""


def _process_start() -> float:
    """The process's start on the ``time.time()`` clock [s]: /proc on Linux (10 ms ticks), else now."""
    try:
        fields = Path("/proc/self/stat").read_text().rsplit(")", 1)[1].split()
        ticks = int(fields[19])  # field 22, starttime, counted from after the command name
        uptime = float(Path("/proc/uptime").read_text().split()[0])
        return time.time() - uptime + ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, AttributeError):
        return time.time()


_START = _process_start()
_PHASES: list[dict] = []


def mark(phase: str, **details) -> None:
    """Record that ``phase`` ended now, with JSON-ready ``details`` (kernel names, cache hits, …)."""
    _PHASES.append({"phase": phase, "seconds": time.time() - _START, **details})


def phases() -> list[dict]:
    """The marks so far, in order (a copy)."""
    return [dict(p) for p in _PHASES]


def write(path: str | Path) -> None:
    """Mark ``exit`` and write the timeline to ``path`` as JSON."""
    mark("exit")
    record = {"phases": phases(), "wall_seconds": _PHASES[-1]["seconds"], "pid": os.getpid(), "argv": sys.argv}
    Path(path).write_text(json.dumps(record, indent=1) + "\n")


def _write_at_exit() -> None:
    target = os.environ.get(ENV, "").strip()
    if target and Path(target).parent.is_dir():  # a missing folder: the command refused it in its one line
        try:
            write(target)
        except OSError as err:  # an unwritable path must not turn a finished run into a traceback
            print(f"warning: {ENV} = {target!r}: {err.strerror or err}", file=sys.stderr)


atexit.register(_write_at_exit)
