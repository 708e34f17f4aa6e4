"""``hertzian tune``: time a job's fused launch shapes on this GPU and remember the fastest (hertzian.studies.tune)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Optional

import typer
from hertzian.cli.app import DeviceOption, app, fail, one_line_errors, resolve_device

TUNED_KERNELS = ("auto", "tile", "window")


@app.command()
def tune(
    path: Annotated[
        Optional[Path], typer.Argument(help="A sweep file (a [scene] table and [sweep] axes) or a scene TOML.")
    ] = None,
    paper: Annotated[bool, typer.Option("--paper", help="Every figure group of `hertzian reproduce`.")] = False,
    quick: Annotated[bool, typer.Option("--quick", help="With --paper: the groups of `reproduce --quick`.")] = False,
    device: DeviceOption = None,
    kernel: Annotated[
        str, typer.Option("--kernel", help="auto | tile | window: the shapes of the fused kernels, or of one kind.")
    ] = "auto",
    as_json: Annotated[bool, typer.Option("--json", help="Print the result as one JSON object.")] = False,
):
    """Time the fused kernels' launch shapes of a job on this GPU and remember the fastest for its runs.

    Runs never time anything: on a GPU each takes the shape tuned here for its model (``HERTZIAN_CACHE``, default
    ~/.cache/hertzian/calibration.json), else the shape of the rule shipped for the GPU's architecture. Each launch
    group is reported with its fastest shape and how much slower the rule's is. A CPU has nothing to tune. One of
    PATH or --paper.
    """
    from hertzian.core.shipped import shipped_file

    if (path is not None) == paper:
        fail("tune: PATH, --paper = none or both: give exactly one")
    if quick and not paper:
        fail("tune: --quick = without --paper: --quick picks the groups of `reproduce --quick`")
    if kernel not in TUNED_KERNELS:
        fail(f"--kernel = {kernel!r}: one of {', '.join(TUNED_KERNELS)} (the fused kernels' shapes)")
    if path is not None:
        path = shipped_file(path)
        if not path.is_file():
            fail(f"path = {str(path)!r}: no such file (a scene or sweep TOML, or a shipped name)")
    dev = resolve_device(device)
    import warp as wp

    if wp.get_device(dev).is_cpu:
        message = "a CPU has no launch shapes to tune: its chain kernel takes each chain whole (nothing written)"
        typer.echo(json.dumps({"device": dev, "groups": [], "note": message}) if as_json else f"{dev}: {message}")
        return
    rows = _tune_rows(path, paper, quick, dev, kernel, None if as_json else typer.echo)
    if as_json:
        typer.echo(json.dumps({"device": dev, "groups": rows}, indent=1))
    else:
        typer.echo(f"{len(rows)} launch groups tuned on {dev}")


def _tune_rows(path: Path | None, paper: bool, quick: bool, device: str, kernel: str, echo) -> list[dict]:
    """Tune every launch group of the job; ``echo`` (None: quiet) prints each row as it is done."""
    from hertzian.studies.tune import describe_row, paper_models, scene_or_sweep_models, tune_model

    rows = []
    with one_line_errors():
        models = paper_models(device, quick=quick) if paper else scene_or_sweep_models(path, device)
        for model in models:
            try:
                rows.append(tune_model(model, kernel))
            except ValueError as err:  # a forced kind that cannot run this group
                fail(str(err))
            if echo:
                echo(describe_row(rows[-1]))
    return rows
