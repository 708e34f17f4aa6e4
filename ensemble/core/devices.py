"""Starting Warp quietly, and the default device.

On a machine without an NVIDIA driver, Warp's native initialisation prints "Warp CUDA warning:
Could not find or load the NVIDIA CUDA driver" to the process's stderr even when only the CPU is
wanted. :func:`init_warp` looks for the driver library first (as Warp does) and, when there is
none, starts Warp with stderr silenced for the moment of initialisation only.
"""

from __future__ import annotations

import contextlib
import ctypes
import hashlib
import os
import sys
import threading
import time
from pathlib import Path

import warp as wp
from hertzian.core import timeline


def cuda_driver_present() -> bool:
    """Whether the NVIDIA driver library can be loaded (libcuda.so / libcuda.so.1, nvcuda.dll)."""
    names = ("nvcuda.dll",) if sys.platform == "win32" else ("libcuda.so", "libcuda.so.1")
    for name in names:
        try:
            ctypes.CDLL(name)
            return True
        except OSError:
            continue
    return sys.platform == "darwin"  # no CUDA there; Warp prints nothing either


@contextlib.contextmanager
def _stderr_silenced():
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


_warp_started = False


def init_warp() -> None:
    """``wp.init()`` at warning log level, without the missing-driver warning on CPU-only machines (once a process;
    later calls return at once)."""
    global _warp_started
    wp.config.log_level = wp.LOG_WARNING
    if _warp_started:
        return
    if cuda_driver_present():
        wp.init()
    else:
        try:
            with _stderr_silenced():
                wp.init()
        except OSError:  # no file descriptor 2 to redirect (an embedded interpreter): start as usual
            wp.init()
    _warp_started = True
    share_precompiled_header()
    timeline.mark("warp_initialised")


PCH_FOLDER = "hertzian-pch"
"""Folder of Warp's kernel cache (``wp.config.kernel_cache_dir``) holding the shared CPU precompiled header."""


def share_precompiled_header() -> None:
    """Keep the precompiled header of Warp's CPU compiles in the kernel cache instead of a folder of the process.

    Warp's clang builds that header (Warp's native headers, 4.6 MB) on a process's first CPU compile and deletes it
    at exit: about 1 s of each compiling process on the 2-core machine, most of a small variant's compile. Shared,
    a later process compiling a new variant reuses it. The folder is keyed by the Warp headers it was built from;
    clang writes it to a temporary file and renames it, so processes compiling at once do not see a partial file.
    On a machine without CUDA whose cache has no header yet and with no prebuilt kernels
    (``hertzian.core.solvers.prebuilt``), the header is built at once in the background (:func:`prime_precompiled_header`). Does nothing where Warp has no CPU compiler or no such hook."""
    runtime = wp._src.context.runtime
    if runtime is None or getattr(runtime, "llvm", None) is None or not hasattr(runtime, "get_clang_pch_dir"):
        return
    native = Path(wp.__file__).parent / "native"
    headers = sorted((str(p.relative_to(native)), p.stat().st_size, p.stat().st_mtime_ns) for p in native.rglob("*.h"))
    key = hashlib.sha1(repr((wp.__version__, headers)).encode()).hexdigest()[:16]
    folder = Path(wp.config.kernel_cache_dir) / PCH_FOLDER / key
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:  # a read-only cache: each process builds its own, as Warp does
        return

    def header_folder() -> str:
        # Warp asks for the folder right before a CPU compile (its source already generated): a compile waits here
        # for a header being built, so that it compiles against that header instead of building one of its own
        primer = _header_primer
        if primer is not None and primer is not threading.current_thread():
            primer.join()
        return str(folder)

    runtime.get_clang_pch_dir = header_folder
    global _header_folder
    _header_folder = folder
    from hertzian.core.solvers.prebuilt import roots

    if not wp.is_cuda_available() and not roots():  # with a prebuilt family, a run usually compiles nothing
        prime_precompiled_header()


_header_folder: Path | None = None
"""The shared folder of the CPU precompiled header (``share_precompiled_header``), or None."""
_header_primer: threading.Thread | None = None
"""The thread building the CPU precompiled header (:func:`prime_precompiled_header`), or None."""


def prime_precompiled_header() -> None:
    """Build the CPU precompiled header in a background thread now, unless the kernel cache has it or a thread
    builds it already (Warp's clang runs outside the GIL).

    ``share_precompiled_header`` calls this when Warp starts on a machine without CUDA, whose first run compiles
    CPU kernels; ``hertzian.core.solvers.compile`` before it compiles CPU variants in several threads, each of
    which would otherwise build a header of its own. Meanwhile the process loads its scene and generates its
    kernels' source; their compiles wait for the header. A failure here is left to the compile that needs the
    header, which reports its own."""
    global _header_primer
    if _header_folder is None or _header_primer is not None or any(_header_folder.glob(f"*_bd{CPU_BLOCK}_*.pch")):
        return
    _remove_abandoned_headers(_header_folder)

    def build() -> None:
        from hertzian.kernels.primer import header_primer

        try:
            header_primer.module.load("cpu", block_dim=CPU_BLOCK)
        except Exception:  # noqa: BLE001 (the run's own compile reports it)
            return
        timeline.mark("precompiled_header_built")

    _header_primer = threading.Thread(target=build, name="hertzian-header-primer", daemon=True)
    _header_primer.start()


def _remove_abandoned_headers(folder: Path, age: float = 60.0) -> None:
    """Delete clang's temporary header files in ``folder`` older than ``age`` seconds: a process that ended while
    its header was being built (a header takes about a second) leaves its empty temporary file behind."""
    now = time.time()
    for tmp in folder.glob("*.pch.tmp"):
        with contextlib.suppress(OSError):  # another process removed or renamed it
            if now - tmp.stat().st_mtime > age:
                tmp.unlink()


CPU_BLOCK = 1
"""The block size of CPU launches (Warp's CPU default), which the header's file name carries (``_bd1_``)."""


def check_device(device: str | None) -> str:
    """``device`` ('cpu', 'cuda', 'cuda:N') if Warp has it here, else OptionError; None: :func:`default_device`.
    Also refuses a bad CPU thread count (an environment variable of the chain kernel) before anything runs."""
    import warp as wp
    from hertzian.core.errors import OptionError, RefusedError
    from hertzian.core.solvers.chain import cpu_threads

    init_warp()
    try:
        cpu_threads()
    except ValueError as err:
        raise RefusedError(str(err)) from None
    if device is None:
        return default_device()
    try:
        if str(device).startswith("cuda") and not wp.is_cuda_available():
            raise RuntimeError  # asking Warp for it would print CUDA driver errors
        wp.get_device(device)
    except Exception:
        available = ", ".join(str(d) for d in wp.get_devices())
        raise OptionError("device", device, f"not available here; available: {available}") from None
    return device


def default_device() -> str:
    """'cuda' when a CUDA device is present, else 'cpu'."""
    init_warp()
    return "cuda" if wp.is_cuda_available() else "cpu"


def open_device(device: str) -> None:
    """Start ``device`` now (CUDA: create its primary context), so that this cost shows apart from a model build's
    in a timeline (hertzian.core.timeline)."""
    init_warp()
    dev = wp.get_device(device)
    if dev.is_cuda:
        dev.context  # noqa: B018 (the property creates the context)
    timeline.mark("device_ready", device=str(dev))
