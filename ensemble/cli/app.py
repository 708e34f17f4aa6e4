"""The typer ``app`` every command registers on, and what commands share: options, ``fail``, devices.

Bad input prints one line ``error: KEY = VALUE: what is allowed`` to stderr and exits with
code 2, writing nothing. This module imports no command module.
"""

from __future__ import annotations

import contextlib
import inspect
import os
import re
from pathlib import Path
from typing import Annotated, Optional

import typer
from hertzian.core import timeline
from hertzian.core.errors import OptionError, RefusedError
from hertzian.core.scene import SceneError, load_scene, parse_overrides
from hertzian.core.shipped import example_path, shipped_file

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
    help="Simulate many Hertzian granular chains at once (Warp kernels on GPU or CPU).",
)

EXIT_BAD_INPUT = 2
EXIT_FLAGGED = 3
"""Exit code of ``run`` and ``sweep`` when a chain ended NON_FINITE, beyond validity, with energy drift or above its
tolerance (``hertzian.core.status.FAILED``): the store is written, and the failure is not read as a result."""

DeviceOption = Annotated[
    Optional[str], typer.Option("--device", help="cpu | cuda | cuda:N (default: cuda if present, else cpu).")
]
SetOption = Annotated[
    Optional[list[str]], typer.Option("--set", help="Override a scene key, e.g. --set chain.l0=1e-4 (repeatable).")
]
SCENE_HELP = "Scene TOML file, or the name of a shipped example (e.g. impact). Default: the built-in example"
SceneArgument = Annotated[Optional[Path], typer.Argument(help=f"{SCENE_HELP}.")]
PrecisionOption = Annotated[
    Optional[str],
    typer.Option(
        "--precision",
        help="float64 | float32 (compensated float32, docs/stability.md §2b; overrides integrator.precision).",
    ),
]
KernelOption = Annotated[
    str,
    typer.Option(
        "--kernel",
        help="auto | fused | step | tile | window | chain: which "
        "solver steps the chains (ensemble/core/solvers; fused = auto, short runs "
        "included); results are the same.",
    ),
]


def plain_help(doc: str | None) -> str | None:
    """A command's docstring as help text: ``literal`` shown as 'literal' (the help is plain text, not reST)."""
    return None if doc is None else re.sub(r"``(.+?)``", r"'\1'", inspect.cleandoc(doc))


def plain_helps() -> None:
    """Give every registered command :func:`plain_help` of its docstring (typer would show it raw)."""
    for info in app.registered_commands:
        if info.help is None and info.callback is not None:
            info.help = plain_help(info.callback.__doc__)


def fail(message: str) -> None:
    """One clear line on stderr, exit code 2."""
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(EXIT_BAD_INPUT)


def check_output_file(option: str, path: Path | None) -> None:
    """Refuse (exit 2) an output file whose folder is missing or not writable, or where a file hertzian did not
    write (or a folder, or a link) is in the way (hertzian.core.outputs); nothing for ``None``."""
    if path is None:
        return
    from hertzian.core.outputs import why_not_replaceable
    from hertzian.sweeping.storage import check_writable_folder

    why = check_writable_folder(path) or why_not_replaceable(path)
    if why:
        fail(f"{option} = {str(path)!r}: {why}")


def command_line() -> str:
    """This process's command as a user typed it (what a JSON record names as its ``command``)."""
    import shlex
    import sys

    return "hertzian " + shlex.join(sys.argv[1:])


def check_timeline_path() -> None:
    """Refuse (exit 2) a ``HERTZIAN_TIMELINE`` whose folder does not exist, before anything runs."""
    target = os.environ.get(timeline.ENV, "").strip()
    if target and not Path(target).parent.is_dir():
        fail(f"{timeline.ENV} = {target!r}: its folder does not exist")


def check_store_out(out: Path, *, overwrite: bool) -> None:
    """``run``'s store path, refused (exit 2) as ``storage.check_out`` refuses it, before anything runs."""
    from hertzian.sweeping.storage import check_out

    with one_line_errors():
        check_out(out, overwrite=overwrite, hint="choose another path or pass --overwrite")


def open_dataset_or_fail(store: Path):
    """The store as a Dataset: a hertzian store checked first (a damaged one is refused in one line), an analysis
    store (a figure group's) as it is; anything unreadable is refused in one line."""
    from hertzian.sweeping.store import StoreDamagedError, open_any_dataset

    try:
        return open_any_dataset(store)
    except StoreDamagedError as err:
        fail(str(err))
    except Exception as err:  # noqa: BLE001  (any unreadable store is bad input)
        fail(f"store = {str(store)!r}: not a readable Zarr store ({type(err).__name__})")


def exit_if_flagged(status) -> None:
    """After a run or sweep is written: one ``error:`` line and exit code 3 when a chain ended with a FAILED code."""
    from hertzian.core.status import failure_line

    line = failure_line(status)
    if line:
        typer.echo(f"error: {line}", err=True)
        raise typer.Exit(EXIT_FLAGGED)


def resolve_device(device: str | None) -> str:
    """``device`` if Warp has it here (None: cuda if present, else cpu); else one line and exit 2."""
    # Warp starts only once a command runs: importing it would slow `hertzian --help`
    from hertzian.core.devices import check_device

    with one_line_errors():
        return check_device(device)


@contextlib.contextmanager
def one_line_errors():
    """Bad input the library refuses (OptionError, RefusedError, SceneError, a bad thread count) → ``fail``."""
    try:
        yield
    except OptionError as err:
        fail(err.cli_message())
    except (RefusedError, SceneError) as err:
        fail(str(err))


def overrides_of(overrides: list[str] | None, precision: str | None) -> dict:
    """``--set KEY=VALUE`` flags and ``--precision`` as one dict of scene overrides (bad input → ``fail``)."""
    with one_line_errors():
        sets = parse_overrides(overrides)
    if precision is not None:
        sets["integrator.precision"] = precision
    return sets


def load_scene_or_fail(scene_path: Path | None, overrides: list[str] | None, precision: str | None):
    """The scene file (a path, or the name of a shipped example; default: the built-in example) with ``--set`` and
    ``--precision`` applied (bad input → ``fail``)."""
    sets = overrides_of(overrides, precision)
    with one_line_errors():
        return load_scene(shipped_file(scene_path) if scene_path else example_path(), sets)
