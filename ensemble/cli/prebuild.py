"""``hertzian prebuild``: compile the default kernel family ahead of time into a folder that runs load from."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Optional

import typer
from hertzian.cli.app import DeviceOption, app, fail, resolve_device


def _architectures(value: str | None, option: str) -> list[int]:
    """``--arch``/``--ptx`` as a list of CUDA architectures (e.g. "80,90"); one line and exit 2 on bad input."""
    if not value:
        return []
    parts = [p.strip() for p in value.split(",")]
    if not all(p.isdigit() and 50 <= int(p) <= 199 for p in parts):
        fail(f"{option} = {value!r}: comma-separated CUDA architectures, e.g. 80,90")
    return sorted({int(p) for p in parts})


@app.command()
def prebuild(
    path: Annotated[
        Optional[Path],
        typer.Argument(help="A scene or sweep file whose kernels to prebuild (default: the default family)."),
    ] = None,
    out: Annotated[
        Optional[Path],
        typer.Option(
            "--out", help="Folder to write (default: the package's own prebuilt folder, which a wheel ships)."
        ),
    ] = None,
    device: DeviceOption = None,
    arch: Annotated[
        Optional[str],
        typer.Option("--arch", help="With a CUDA device: cubins for these architectures too, e.g. 80,90."),
    ] = None,
    ptx: Annotated[
        Optional[str],
        typer.Option("--ptx", help="With a CUDA device: PTX for these architectures (newer GPUs), e.g. 90."),
    ] = None,
    wheel: Annotated[
        Optional[Path],
        typer.Option("--wheel", help="Also pack the folder as a wheel of the companion package into this folder."),
    ] = None,
    any_length: Annotated[
        bool,
        typer.Option(
            "--any-length",
            help="Also every launch shape the family's feature sets take on this device at any chain length (2 to "
            "100000 grains) and chain count.",
        ),
    ] = False,
    gpu_family: Annotated[
        Optional[int],
        typer.Option(
            "--gpu-family",
            help="Plan the family for a GPU of this CUDA compute capability (e.g. 90) on this machine, no GPU needed, "
            "at any chain length and count, and build its cubins (and --ptx) instead of this device's binaries.",
        ),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the result as one JSON object.")] = False,
):
    """Compile the default kernel family (every shipped example, every shipped sweep, `reproduce` and
    `reproduce --quick`), or the kernels of PATH, ahead of time into a folder.

    A run loads a kernel missing from Warp's kernel cache from `$HERTZIAN_PREBUILT` or the package's own prebuilt
    folder before it compiles anything. CPU objects fit processors with this one's instruction-set extensions;
    on a GPU, the launch shapes are planned for the GPU present. `hertzian warmup --list` prints the family.
    """
    from hertzian.core.scene import SceneError
    from hertzian.core.shipped import shipped_file
    from hertzian.core.solvers import prebuilt
    from hertzian.core.solvers.compile import prebuild_variants
    from hertzian.core.solvers.prepare import kernel_variants
    from hertzian.studies.warmup import family_needs, file_needs

    archs, ptx_archs = _architectures(arch, "--arch"), _architectures(ptx, "--ptx")
    dev = resolve_device(device)
    if gpu_family is not None and gpu_family not in range(50, 200):
        fail(f"--gpu-family = {gpu_family}: a CUDA compute capability, e.g. 80 or 90")
    if (archs or ptx_archs) and not dev.startswith("cuda") and gpu_family is None:
        fail(
            f"--device = {dev!r}: --arch and --ptx need a CUDA device (the GPU family's launch shapes are planned on it)"
        )
    target = out if out is not None else prebuilt.PACKAGE_FOLDER
    for option, folder in (("--out", target), ("--wheel", wheel)):
        if folder is not None and folder.exists() and not folder.is_dir():
            fail(f"{option} = {str(folder)!r}: a file; give a folder")
        if folder is not None and not folder.exists() and not folder.parent.is_dir():
            fail(f"{option} = {str(folder)!r}: parent directory does not exist")
    if out is not None and out.is_dir() and any(out.iterdir()) and not (out / "family.json").is_file():
        fail(f"--out = {str(out)!r}: a folder holding other files (no family.json); give a new or empty folder")
    planned = dev if gpu_family is None else "cpu"  # a planned GPU's feature sets are the same as on this machine
    try:
        needs = family_needs(planned) if path is None else file_needs(shipped_file(path), planned)
    except (SceneError, ValueError) as err:
        fail(str(err))
    if gpu_family is not None:
        from hertzian.core.solvers.shape_rule import PlannedGPU
        from hertzian.studies.warmup import gpu_family_variants

        gpu = PlannedGPU(gpu_family)
        report = prebuild_variants(gpu_family_variants(needs, gpu), gpu, target, archs=archs, ptx=ptx_archs)
        _report({"device": gpu.name, "out": str(target), "archs": archs, "ptx": ptx_archs, **report}, wheel, as_json)
        return
    if any_length:
        from hertzian.studies.warmup import with_any_length

        needs = with_any_length(needs, dev)
    variants = kernel_variants(needs, dev)
    report = prebuild_variants(variants, dev, target, archs=archs, ptx=ptx_archs)
    _report({"device": dev, "out": str(target), "archs": archs, "ptx": ptx_archs, **report}, wheel, as_json)


def _report(report: dict, wheel: Path | None, as_json: bool) -> None:
    """Pack the wheel (``--wheel``) and print what was built."""
    from hertzian.core.solvers import prebuilt

    target = report["out"]
    dev = report["device"]
    if wheel is not None:
        from hertzian import __version__

        report["wheel"] = str(prebuilt.write_wheel(Path(target), wheel, __version__))
    if as_json:
        typer.echo(json.dumps(report))
        return
    typer.echo(
        f"{report['modules']} kernel modules ({report['binaries']} binaries, {report['bytes'] / 1e6:.1f} MB) "
        f"prebuilt for {dev} in {target} ({report['seconds']:.1f} s)"
    )
    if wheel is not None:
        typer.echo(f"wrote {report['wheel']} (pip install it beside hertzian)")
