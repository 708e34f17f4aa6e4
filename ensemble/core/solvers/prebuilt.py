"""Prebuilt kernels: Warp modules compiled ahead of time into a folder, loaded from there before anything compiles.

A prebuilt folder has the layout of Warp's kernel cache: one sub-folder per module variant (``wp_<name>_<hash>``,
the hash covering the kernel source, the module options and the block size) holding its metadata and binaries, and
an index (``family.json``) naming the Warp version they were built with. ``hertzian prebuild`` writes one
(``hertzian.core.solvers.compile.prebuild_variants``). A run looks in every folder of :func:`roots` for a variant
missing from Warp's kernel cache and loads the binary it finds there (:func:`load`: Warp's ``Module.load`` given that
binary, as ``wp.load_aot_module`` does), so nothing compiles. A folder with no binary for this device leaves the
variant to be compiled as before.

Which binary fits:
* CPU: the object file Warp itself would name (``<id>.cpu<target>.o``). With Warp's default ``-march=native`` the
  target hash covers the CPU's instruction-set extensions, so objects fit processors with the same extensions.
* CUDA: the cubin of the device's architecture, else PTX of the highest architecture not above it (the driver
  compiles PTX for newer GPUs at load time).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import warp as wp

PACKAGE_FOLDER = Path(__file__).resolve().parents[2] / "prebuilt-kernels"
"""The package's own prebuilt folder (``hertzian/prebuilt-kernels``): ``hertzian prebuild`` writes it by default, and
a wheel built after that ships it."""
COMPANION = "hertzian_kernels"
"""The companion data package ``hertzian prebuild --wheel`` writes: a prebuilt folder installed with pip."""
ENVIRONMENT = "HERTZIAN_PREBUILT"
"""Environment variable naming more prebuilt folders (``os.pathsep``-separated), searched first; ``off``: none."""


def roots() -> list[Path]:
    """Existing prebuilt folders, in the order they are searched: ``$HERTZIAN_PREBUILT``, the package's own, then the
    companion package's (none when ``$HERTZIAN_PREBUILT`` is ``off``)."""
    value = os.environ.get(ENVIRONMENT, "")
    if value.strip() == "off":
        return []
    named = [Path(p) for p in value.split(os.pathsep) if p.strip()]
    return [p for p in [*named, PACKAGE_FOLDER, _companion_folder()] if p is not None and _fits(p)]


INDEX = "family.json"
"""The index a prebuilt folder holds: the Warp version its binaries were built with, the device, architectures
and modules."""


def _fits(folder: Path) -> bool:
    """Whether ``folder`` is a prebuilt folder built with this Warp version (binaries of another Warp may not load)."""
    return bool(_index(folder))


def _companion_folder() -> Path | None:
    """The installed companion package's folder (not imported), or None."""
    from importlib.util import find_spec

    spec = find_spec(COMPANION)
    return (
        None if spec is None or not spec.submodule_search_locations else Path(list(spec.submodule_search_locations)[0])
    )


def variant_names(module, block: int) -> tuple[str, str]:
    """(folder name, metadata file name) of ``module`` at ``block`` threads: Warp's own names."""
    return module.get_module_identifier(block), module._get_meta_name(block)


def binary_names(module, device, block: int) -> list[tuple[str, int | None]]:
    """(file name, architecture) of the binaries of ``module`` at ``block`` that fit ``device``, best first."""
    if device.is_cpu:
        return [(module._get_compile_output_name(device, block_dim=block), None)]
    names = [
        (module._get_compile_output_name(None, output_arch=device.arch, use_ptx=False, block_dim=block), device.arch)
    ]
    for arch in range(device.arch, 49, -1):
        names.append((module._get_compile_output_name(None, output_arch=arch, use_ptx=True, block_dim=block), arch))
    return names


def find(module, device, block: int) -> tuple[Path, Path, int | None] | None:
    """(binary, metadata, architecture) of the first prebuilt binary of ``module`` at ``block`` that fits
    ``device``, or None."""
    folder, meta = variant_names(module, block)
    for root in roots():
        where = root / folder
        if not (where / meta).is_file():
            continue
        for name, arch in binary_names(module, device, block):
            if (where / name).is_file():
                return where / name, where / meta, arch
    return None


def load(module, device, block: int) -> bool:
    """Load ``module`` at ``block`` threads on ``device`` from a prebuilt folder; False when none holds a binary
    that fits (the caller then compiles as usual)."""
    found = find(module, device, block)
    if found is None:
        return False
    binary, meta, arch = found
    module.load(device, block_dim=block, binary_path=binary, output_arch=arch, meta_path=meta)
    return True


def targets(device, archs: list[int], ptx: list[int]) -> list[tuple]:
    """(device or None, architecture, PTX?) of every binary a prebuilt variant gets: ``device``'s own (a CPU object,
    or a cubin of its GPU), a cubin for each of ``archs`` and PTX for each of ``ptx``."""
    own = (device, None, None) if device.is_cpu else (None, device.arch, False)
    return [own] + [(None, a, False) for a in archs if (None, a, False) != own] + [(None, a, True) for a in ptx]


def compile_into(out: Path, module, block: int, target: tuple) -> None:
    """Compile one binary of ``module`` at ``block`` threads into ``out`` (nothing when it is there already)."""
    device, arch, use_ptx = target
    folder, _ = variant_names(module, block)
    options = module.resolved_options[block]  # filled by get_module_identifier
    name = module._get_compile_output_name(device, output_arch=arch, use_ptx=use_ptx, block_dim=block)
    if not (out / folder / name).is_file():
        module._compile(device, out / folder, name, arch, use_ptx=use_ptx, options=options)


def write_index(out: Path, device, archs: list[int], ptx: list[int], folders: set[str]) -> None:
    """Add what a build wrote into ``out`` (module ``folders`` for ``device``, ``archs``, ``ptx``) to its index."""
    index = _index(out)
    for key, values in (("devices", [str(device)]), ("archs", archs), ("ptx", ptx)):
        index[key] = sorted(set(index.get(key, [])) | set(values))
    index["modules"] = sorted(set(index.get("modules", [])) | folders)
    index["warp"] = wp.config.version
    (out / INDEX).write_text(json.dumps(index, indent=1) + "\n")


def _index(folder: Path) -> dict:
    """The index of a prebuilt ``folder`` built with this Warp version (empty when there is none)."""
    try:
        index = json.loads((folder / INDEX).read_text())
    except (OSError, ValueError):
        return {}
    return index if isinstance(index, dict) and index.get("warp") == wp.config.version else {}


def write_wheel(folder: Path, dist: Path, version: str) -> Path:
    """Pack the prebuilt ``folder`` as the companion package's wheel in ``dist`` (``pip install`` it beside
    hertzian); returns its path. Tagged for this platform: its CPU objects fit no other."""
    import base64
    import hashlib
    import sysconfig
    import zipfile

    tag = "py3-none-" + sysconfig.get_platform().replace("-", "_").replace(".", "_")
    info = f"{COMPANION}-{version}.dist-info"
    files = {
        f"{COMPANION}/__init__.py": b'"""Kernels of hertzian compiled ahead of time (hertzian prebuild --wheel)."""\n'
    }
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        files[f"{COMPANION}/{path.relative_to(folder).as_posix()}"] = path.read_bytes()
    files[f"{info}/METADATA"] = f"Metadata-Version: 2.1\nName: {COMPANION}\nVersion: {version}\n".encode()
    files[f"{info}/WHEEL"] = f"Wheel-Version: 1.0\nGenerator: hertzian\nRoot-Is-Purelib: false\nTag: {tag}\n".encode()
    record = []
    for name, data in files.items():
        digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
        record.append(f"{name},sha256={digest},{len(data)}")
    files[f"{info}/RECORD"] = ("\n".join([*record, f"{info}/RECORD,,"]) + "\n").encode()
    dist.mkdir(parents=True, exist_ok=True)
    wheel = dist / f"{COMPANION}-{version}-{tag}.whl"
    with zipfile.ZipFile(wheel, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, data in files.items():
            archive.writestr(name, data)
    return wheel
