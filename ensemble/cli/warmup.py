"""``hertzian warmup``: compile a job's kernels into Warp's kernel cache ahead of time (an image build, once per node)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Optional

import typer
from hertzian.cli.app import DeviceOption, KernelOption, app, fail, resolve_device


@app.command()
def warmup(
    path: Annotated[
        Optional[Path], typer.Argument(help="A sweep file (a [scene] table and [sweep] axes) or a scene TOML.")
    ] = None,
    paper: Annotated[bool, typer.Option("--paper", help="Every figure group of `hertzian reproduce`.")] = False,
    quick: Annotated[bool, typer.Option("--quick", help="With --paper: the groups of `reproduce --quick`.")] = False,
    detect: Annotated[
        Optional[Path], typer.Option("--detect", help="BASE scene of `hertzian detect --scene BASE`.")
    ] = None,
    device: DeviceOption = None,
    kernel: KernelOption = "auto",
    workers: Annotated[
        Optional[int],
        typer.Option("--workers", help="Compile threads (default: one per core on a CPU, up to 8 on a GPU)."),
    ] = None,
    any_length: Annotated[
        bool,
        typer.Option(
            "--any-length",
            help="Also every launch shape the job's feature sets take on this device at any chain length (2 to "
            "100000 grains) and chain count.",
        ),
    ] = False,
    dry_run: Annotated[bool, typer.Option("--dry-run", help="List the kernel variants; compile nothing.")] = False,
    list_family: Annotated[
        bool,
        typer.Option(
            "--list", help="Print the default family (what `hertzian prebuild` compiles) by feature set and shape."
        ),
    ] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the result as one JSON object.")] = False,
):
    """Compile and cache every kernel variant a job will launch, so its first run compiles nothing.

    Warp keeps compiled kernels in its kernel cache (``WARP_CACHE_PATH``, default ~/.cache/warp); a run on the
    same device, Warp version and hertzian source reads them from there. One of PATH, --paper or --detect.
    """
    from hertzian.core.scene import SceneError
    from hertzian.core.shipped import shipped_file
    from hertzian.core.solvers.calibrate import KERNELS
    from hertzian.core.solvers.prepare import kernel_variants, prepare_kernels

    if list_family:
        if path is not None or paper or detect is not None:
            fail(
                "warmup: --list = with PATH, --paper or --detect: --list prints the whole default family; give it alone"
            )
        _print_family(resolve_device(device), as_json)
        return
    if sum((path is not None, paper, detect is not None)) != 1:
        fail("warmup: PATH, --paper, --detect = none or several: give exactly one (or --list)")
    if kernel not in KERNELS:
        fail(f"--kernel = {kernel!r}: one of {', '.join(KERNELS)}")
    path, detect = (None if p is None else shipped_file(p) for p in (path, detect))
    if workers is not None and workers < 1:
        fail(f"--workers = {workers}: must be at least 1")
    dev = resolve_device(device)
    try:
        needs = _needs(path, paper, quick, detect, dev, kernel)
    except (SceneError, ValueError) as err:
        fail(str(err))
    if any_length:
        from hertzian.studies.warmup import with_any_length

        needs = with_any_length(needs, dev)
    if dry_run:
        variants = kernel_variants(needs, dev)
        names = [f"{module.name} (block {block or 'default'})" for module, block in variants]
        typer.echo(json.dumps({"variants": names}, indent=1) if as_json else "\n".join(names))
        return
    report = prepare_kernels(needs, dev, max_workers=workers)
    if as_json:
        typer.echo(json.dumps({"device": dev, **report}))
    else:
        compiled = sum(not load["cached"] for load in report["loads"])
        typer.echo(
            f"{report['variants']} kernel variants ready on {dev} in {report['seconds']:.2f} s ({compiled} compiled)"
        )


def _print_family(device: str, as_json: bool) -> None:
    """``--list``: every kernel variant of the default family on ``device``, with its feature set and shapes."""
    from hertzian.studies.warmup import family_needs, family_rows

    rows = family_rows(family_needs(device), device)
    if as_json:
        typer.echo(json.dumps({"device": device, "modules": rows}, indent=1))
        return
    for row in rows:
        block = row["block_dim"] or "default"
        shapes = ", ".join(row["shapes"]) or "any"
        typer.echo(f"{row['module']} (block {block}): {row['features'] or 'any features'}; grains x chains {shapes}")
    typer.echo(f"{len(rows)} kernel modules on {device}")


def _needs(path: Path | None, paper: bool, quick: bool, detect: Path | None, device: str, kernel: str) -> list:
    """The job's needs (hertzian.studies.warmup)."""
    from hertzian.core.scene import load_scene
    from hertzian.studies import warmup as needs

    if paper:
        return needs.paper_needs(device, quick=quick, kernel=None if kernel == "auto" else kernel)
    if detect is not None:
        return needs.detect_needs(load_scene(detect))
    return needs.file_needs(path, device, kernel)
