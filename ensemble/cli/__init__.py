"""The ``hertzian`` command line : one module per command, all registering on ``app.app``.

Command modules import ``.app`` (the typer app, shared options, ``fail``) and the library, never
each other; this file imports every module named in ``COMMANDS`` so that its commands register.
A new command is a module ``ensemble/cli/<name>.py`` with an ``@app.command()`` function, added to
``COMMANDS`` (or, from outside this package, a module passed to :func:`register`).

Bad input prints one line ``error: KEY = VALUE: what is allowed`` to stderr and exits with
code 2, writing nothing.
"""

from __future__ import annotations

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
    "estimates",
)
"""Command modules of this package, in help order."""


def register(module: str) -> None:
    """Import a command module (a dotted name, e.g. 'hertzian.cli_detect') so its commands register."""
    import_module(module)
    plain_helps()


for _name in COMMANDS:
    register(f"{__name__}.{_name}")


def main() -> None:
    """Entry point of the ``hertzian`` script."""
    app()


__all__ = ["COMMANDS", "EXIT_BAD_INPUT", "app", "fail", "main", "register", "resolve_device"]
