"""The typer ``app`` every command registers on, and what commands share: options, ``fail``, devices.

Bad input prints one line ``error: KEY = VALUE: what is allowed`` to stderr and exits with
code 2, writing nothing. This module imports no command module.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Annotated, Optional

import typer
from hertzian.core.scene import SceneError, load_scene, parse_overrides

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    help="Simulate many Hertzian granular chains at once (Warp kernels on GPU or CPU).",
)

EXIT_BAD_INPUT = 2

DeviceOption = Annotated[
    Optional[str], typer.Option("--device", help="cpu | cuda | cuda:N (default: cuda if present, else cpu).")
]
SetOption = Annotated[
    Optional[list[str]], typer.Option("--set", help="Override a scene key, e.g. --set chain.l0=1e-4 (repeatable).")
]
SceneArgument = Annotated[Optional[Path], typer.Argument(help="Scene TOML (SPEC §8). Default: the built-in example.")]
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
        help="auto | fused | step | tile | window | sweep: which "
        "solver steps the chains (ensemble/core/solvers; fused = auto, short runs "
        "included); results are the same.",
    ),
]


def fail(message: str) -> None:
    """One clear line on stderr, exit code 2."""
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(EXIT_BAD_INPUT)


def example_path(name: str = "impact") -> Path:
    """A built-in example scene shipped with the package."""
    return Path(str(resources.files("hertzian.examples") / f"{name}.toml"))


def resolve_device(device: str | None) -> str:
    import warp as wp
    from hertzian.core.devices import init_warp
    from hertzian.core.solvers.chain import cpu_threads

    init_warp()
    try:
        cpu_threads()  # the CPU chain kernel's thread count (an environment variable): refused before anything runs
    except ValueError as err:
        fail(str(err))
    if device is None:
        return "cuda" if wp.is_cuda_available() else "cpu"
    try:
        wp.get_device(device)
    except Exception:
        available = ", ".join(str(d) for d in wp.get_devices())
        fail(f"--device = {device!r}: not available here; available: {available}")
    return device


def load_scene_or_fail(scene_path: Path | None, overrides: list[str] | None, precision: str | None):
    try:
        sets = parse_overrides(overrides)
        if precision is not None:
            sets["integrator.precision"] = precision
        return load_scene(scene_path or example_path(), sets)
    except SceneError as err:
        fail(str(err))
