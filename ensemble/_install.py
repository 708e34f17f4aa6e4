"""Install time: the default kernel family compiled for this machine's CPU (and GPU) goes into the built package.

``pip install .`` builds a wheel; setuptools' ``build_py`` copies the package into it, and :class:`BuildWithKernels`
then compiles the default family (what ``hertzian prebuild --device cpu`` compiles: every shipped example, every
shipped sweep, ``reproduce`` and ``reproduce --quick``) into the wheel's ``hertzian/prebuilt-kernels``, and on a
machine with a CUDA GPU the same family planned for that GPU (``--device cuda``). A first run then loads its kernels
from there and compiles nothing (``hertzian.core.solvers.prebuilt``).

* Skipped for editable installs, when the source package holds a prebuilt folder (``hertzian prebuild`` was run
  before the build: that one is kept), and when ``HERTZIAN_PREBUILD=off``. A folder left in the build directory by
  an earlier build is removed first: it was compiled from the sources as they were then.
* The compile runs in a child process against the copied package, with a kernel cache of its own (nothing is
  written outside the build). If it cannot run (no Warp CPU compiler, say), the package is built without prebuilt
  kernels, runs compile what they need as before, and the build log says why in one line.

This module is read by setuptools before the package's dependencies exist: it imports setuptools only (when it is
there: Python 3.12 environments may lack it at run time), and the package only inside the child process.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

try:
    from setuptools.command.build_py import build_py
except ImportError:  # a run-time import (tests, the child process) where setuptools is not installed
    build_py = object

SWITCH = "HERTZIAN_PREBUILD"
"""Environment variable: ``off`` builds the package without prebuilt kernels."""
FOLDER = Path("hertzian") / "prebuilt-kernels"
TIMEOUT_S = 900


class BuildWithKernels(build_py):
    """``build_py``, then the default family compiled into the built package (see the module's text)."""

    def run(self) -> None:
        super().run()
        if getattr(self, "editable_mode", False):
            return
        build_lib = Path(self.build_lib)
        if not family_to_compile(Path(self.get_package_dir("hertzian")), build_lib):
            return
        if os.environ.get(SWITCH, "").strip().lower() == "off":
            return
        note = compile_family(build_lib)
        if note:
            print(f"hertzian: {note}", file=sys.stderr)


def family_to_compile(source_package: Path, build_lib: Path) -> bool:
    """Whether the build compiles the family into ``build_lib``: not when the source package holds one (``hertzian
    prebuild`` wrote it there, and ``build_py`` copied it). Otherwise a folder in ``build_lib`` is a previous build's,
    compiled from the sources as they were then: it is removed, so the package never ships stale kernels."""
    if (source_package / FOLDER.name / "family.json").exists():
        return False
    shutil.rmtree(build_lib / FOLDER, ignore_errors=True)
    return True


def compile_family(build_lib: Path) -> str:
    """Compile the default family into ``build_lib``'s package (:func:`main`); returns '' or why it was not built."""
    out = build_lib / FOLDER
    ours = not out.exists()
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(build_lib), os.environ.get("PYTHONPATH")]))}
    with tempfile.TemporaryDirectory(prefix="hertzian-build-") as cache:
        env["WARP_CACHE_PATH"] = cache
        command = [sys.executable, "-m", "hertzian._install", str(out)]
        try:
            done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=TIMEOUT_S)
            why = "" if done.returncode == 0 else ((done.stderr or done.stdout).strip().splitlines() or ["?"])[-1]
        except (OSError, subprocess.TimeoutExpired) as err:
            why = type(err).__name__
    if not why:
        return ""
    if ours:
        shutil.rmtree(out, ignore_errors=True)  # a partial folder this build wrote
    return f"built without prebuilt kernels ({why}); runs compile what they need"


def main(out: str) -> None:
    """Child process: compile the default family into ``out`` for the CPU and, when this machine has one, for its
    CUDA GPU (``hertzian prebuild --device cpu``, ``--device cuda``). A device whose compile fails is left out and
    named on stderr; the process fails only when nothing was built."""
    import warp as wp

    wp.config.quiet = True
    from hertzian.core.solvers.compile import prebuild_variants
    from hertzian.core.solvers.prepare import kernel_variants
    from hertzian.studies.warmup import family_needs

    built = 0
    for device in ["cpu", *(["cuda"] if wp.is_cuda_available() else [])]:
        try:
            report = prebuild_variants(kernel_variants(family_needs(device), device), device, Path(out))
        except Exception as err:  # a device that cannot compile is left out, not the package
            print(f"hertzian: no prebuilt {device} kernels ({type(err).__name__}: {err})", file=sys.stderr)
            continue
        built += 1
        print(f"hertzian: {report['modules']} {device} kernel modules prebuilt in {report['seconds']:.1f} s")
    if not built:
        raise SystemExit("no device could compile the family")


if __name__ == "__main__":
    main(sys.argv[1])
