"""The ``hertzian`` command line : one module per command, all registering on ``app.app``.

Command modules import ``.app`` (the typer app, shared options, ``fail``) and the library, never
each other; this file imports every module named in ``COMMANDS`` so that its commands register.
A new command is a module ``ensemble/cli/<name>.py`` with an ``@app.command()`` function, added to
``COMMANDS`` (or, from outside this package, a module passed to :func:`register`).

Bad input prints one line ``error: KEY = VALUE: what is allowed`` to stderr and exits with
code 2, writing nothing.
"""

from __future__ import annotations

import atexit
import os
import sys
import threading
from importlib import import_module

from hertzian.cli.app import EXIT_BAD_INPUT, app, fail, plain_helps, resolve_device

COMMANDS = (
    "run",
    "summarize",
    "verify",
    "check",
    "accuracy",
    "sweep",
    "bench",
    "plot",
    "reproduce",
    "detect",
    "warmup",
    "tune",
    "prebuild",
    "estimates",
    "design",
)
"""Command modules of this package, in help order."""


def register(module: str) -> None:
    """Import a command module (a dotted name, e.g. 'hertzian.cli_detect') so its commands register."""
    import_module(module)
    plain_helps()


for _name in COMMANDS:
    register(f"{__name__}.{_name}")


def main() -> None:
    """Entry point of the ``hertzian`` script.

    When the command leaves no other thread to wait for, the process ends as the interpreter would (streams flushed,
    exit handlers run: the timeline, Dask's, logging's) but without tearing down every module and Warp's runtime one
    object at a time: about 0.13 s of a 1.9 s ``hertzian run`` on the 2-core machine. Otherwise it exits as usual."""
    try:
        app()
        code = 0
    except SystemExit as done:
        code = done.code
    if "hertzian.core.solvers.chain" in sys.modules:  # the CPU chain kernel's idle threads: nothing left to run
        sys.modules["hertzian.core.solvers.chain"].close_pools()
    others = [t for t in threading.enumerate() if t is not threading.current_thread() and not t.daemon]
    if others or (code is not None and not isinstance(code, int)):
        sys.exit(code)  # the interpreter's own shutdown: it stops thread pools before joining their threads
    sys.stdout.flush()
    sys.stderr.flush()
    atexit._run_exitfuncs()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code or 0)


__all__ = ["COMMANDS", "EXIT_BAD_INPUT", "app", "fail", "main", "register", "resolve_device"]
