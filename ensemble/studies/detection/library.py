"""The detection library: the candidates searched (depths × mass ratios), their surface echoes and Gram matrices
from one ensemble run, assembled on the host or on the device, and cached per BASE and sample times under
``$HERTZIAN_DETECT_CACHE`` (program units)."""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import tempfile
import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import warp as wp
from hertzian.core.devices import init_warp
from hertzian.core.model import build_model
from hertzian.core.runner import Runner
from hertzian.core.scene import Scene, SceneError
from hertzian.core.status import Status
from hertzian.kernels.library import library_kernels
from hertzian.studies.detection.forward import default_batch_size, front_times, prepare_candidates, run_candidates

LIBRARY_VERSION = 2
"""Bumped when the cached library's content or layout changes (2: a directory of ``.npy`` files holding the
echoes and their Gram matrices; version 1's ``.npz`` files are not read)."""
FIRST_ECHO_GRAINS = 10
"""The first-echo score of depth d uses the samples before the echo from depth d + this could start. The
library caches Gram matrices over these windows (``Library.first_echo_gram``): a cached library built with
another value is rebuilt."""


CACHED_ARRAYS = ("clean", "echoes", "ok", "fronts", "gram", "first_echo_ends", "first_echo_gram")
"""The library's arrays, each saved as ``<name>.npy`` in the library's cache directory."""
SAVE_THREADS = 8
"""Threads that copy a large array into its ``.npy`` file (a 1000-grain library's echoes are ≈ 1.2 GB, and a detection
returns once its library is saved: one thread's copy was a large part of a cached detection's time on a GPU host)."""
SAVE_PIECE_BYTES = 64 << 20


ASSEMBLE_ON_DEVICE: bool | None = None
"""Whether :func:`build_library` assembles the library on the device (:func:`_library_on_device`); None: on CUDA
devices (on a CPU the host path is as fast; tests set True to check the two paths agree)."""


@dataclass(frozen=True)
class Grid:
    """The candidates searched: depths × log mass ratios, for blocks of ``block`` grains."""

    depths: np.ndarray
    """Depths searched (first grain of the block), shape (D,), int."""
    log_mass_ratio: np.ndarray
    """x = ln μ of the library's candidates, shape (M,): the light ones (< 0) then the heavy ones (> 0)."""
    block: int = 1
    mass_ratio_range: tuple[float, float] = (0.25, 4.0)
    """Prior range of μ: light in [μ_min, 1), heavy in (1, μ_max]."""

    @property
    def light(self) -> np.ndarray:
        return np.flatnonzero(self.log_mass_ratio < 0)

    @property
    def heavy(self) -> np.ndarray:
        return np.flatnonzero(self.log_mass_ratio > 0)

    def to_dict(self) -> dict:
        return {
            "depths": [int(d) for d in self.depths],
            "log_mass_ratio": [float(x) for x in self.log_mass_ratio],
            "block": int(self.block),
            "mass_ratio_range": [float(m) for m in self.mass_ratio_range],
        }


def make_grid(depths, mass_ratio_range=(0.25, 4.0), mass_steps: int = 7, block: int = 1) -> Grid:
    """``mass_steps`` log-spaced ratios on each side of 1 (1 itself is the clean chain)."""
    low, high = mass_ratio_range
    if not (0 < low < 1 < high):
        raise SceneError("--mass-range", f"{low},{high}", "must be two numbers μ_min < 1 < μ_max, both > 0")
    if mass_steps < 1:
        raise SceneError("--mass-steps", mass_steps, "must be an integer ≥ 1")
    light = np.linspace(math.log(low), 0.0, mass_steps + 1)[:-1]
    heavy = np.linspace(0.0, math.log(high), mass_steps + 1)[1:]
    return Grid(
        depths=np.asarray(depths, dtype=int),
        log_mass_ratio=np.concatenate([light, heavy]),
        block=int(block),
        mass_ratio_range=(float(low), float(high)),
    )


@dataclass
class Library:
    """Surface traces of every candidate chain as echoes (trace − clean chain), their signal-independent Gram
    matrices, and what the clean chain tells about the host."""

    key: str
    grid: Grid
    forward: Scene
    """The forward scene (BASE tracing grain 0 at the signal's times)."""
    clean: np.ndarray
    """Clean chain's surface velocity [length/time], shape (S,)."""
    echoes: np.ndarray
    """Candidates' surface velocity minus the clean chain's [length/time], shape (D, M, S) (depths × log mass
    ratios × samples). A candidate that did not run OK counts as velocity 0 (echo −clean); the interpolation
    never puts weight on it."""
    ok: np.ndarray
    """Whether each candidate ran without a status flag, shape (D, M), bool."""
    fronts: np.ndarray
    """Pulse front arrival at each grain of the clean chain [time], shape (N,)."""
    gram: np.ndarray
    """Per depth, the echoes' inner products over all samples, echoes[k] · echoes[k]ᵀ [(length/time)²], shape
    (D, M, M)."""
    first_echo_ends: np.ndarray
    """Per depth, how many samples its first-echo window holds (those with t < 2 t_front(d + FIRST_ECHO_GRAINS)),
    shape (D,), int."""
    first_echo_gram: np.ndarray
    """As ``gram``, over each depth's first-echo window, shape (D, M, M)."""
    build_seconds: float
    """Wall seconds it took to simulate (0 when it came from the cache)."""
    from_cache: bool = False
    saving: object = None
    """The cache's save still running in a thread (a Future; ``build_library(..., save_in_background=True)``),
    else None: call ``finish_saving()`` before another process may read the cache."""

    def finish_saving(self) -> None:
        """Wait for a save started in the background (re-raising its error)."""
        if self.saving is not None:
            saving, self.saving = self.saving, None
            saving.result()


def cache_dir() -> Path:
    """Where libraries are cached: ``$HERTZIAN_DETECT_CACHE`` or ``~/.cache/hertzian/detect``."""
    return Path(os.environ.get("HERTZIAN_DETECT_CACHE", Path.home() / ".cache" / "hertzian" / "detect"))


def library_key(forward: Scene, grid: Grid) -> str:
    """Hash of the forward scene (BASE + signal times) and the grid."""
    text = json.dumps({"version": LIBRARY_VERSION, "scene": forward.to_dict(), "grid": grid.to_dict()}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def default_depths(
    fronts: np.ndarray, duration: float, grain_count: int, block: int, depth_range: tuple[int, int] | None = None
) -> np.ndarray:
    """Depths searched: from max(1, ⌈N/20⌉) (or the given start) to the deepest whose echo can start in the record."""
    last_fit = grain_count - block
    if depth_range is not None:
        first, last = depth_range
        if not (1 <= first <= last <= last_fit):
            raise SceneError("--depths", f"{first}:{last}", f"must satisfy 1 ≤ first ≤ last ≤ {last_fit} (N − block)")
    else:
        first, last = max(1, math.ceil(grain_count / 20)), last_fit
    reachable = np.flatnonzero(2 * fronts[: last_fit + 1] < duration)
    deepest = int(reachable[-1]) if reachable.size else 0
    if deepest < first:
        raise SceneError(
            "SIGNAL duration",
            f"{duration:g}",
            f"is shorter than one echo: the echo from depth {first} cannot start before t = {2 * fronts[first]:.4g}",
        )
    return np.arange(first, min(last, deepest) + 1)


def first_echo_ends(t: np.ndarray, fronts: np.ndarray, depths: np.ndarray) -> np.ndarray:
    """Per depth d, how many samples of times ``t`` precede 2 t_front(d + FIRST_ECHO_GRAINS) (the return of
    the echo from FIRST_ECHO_GRAINS below d), shape (D,), int."""
    deeper = np.minimum(np.asarray(depths, dtype=int) + FIRST_ECHO_GRAINS, fronts.size - 1)
    return np.searchsorted(t, 2 * fronts[deeper]).astype(np.int64)


def assemble_library(
    key: str,
    grid: Grid,
    forward: Scene,
    clean: np.ndarray,
    traces: np.ndarray,
    ok: np.ndarray,
    fronts: np.ndarray,
    *,
    in_place: bool = False,
) -> Library:
    """A library from the clean chain's surface trace (S,), the candidates' (D, M, S) and whether each ran OK
    (D, M): the echoes (a candidate that did not run OK as velocity 0) and their Gram matrices over all samples
    and over each depth's first-echo window (samples at the forward scene's trace times). ``in_place``: the
    echoes overwrite ``traces`` (float64; a library's traces are ≈ 1 GB at 1000 grains) instead of a copy."""
    clean = np.array(clean, dtype=np.float64)  # a copy: ``traces`` may be a view of the same run's array
    ok = np.asarray(ok, dtype=bool)
    fronts = np.asarray(fronts, dtype=np.float64)
    echoes = np.asarray(traces, dtype=np.float64) if in_place else np.array(traces, dtype=np.float64)
    echoes[~ok] = 0.0
    echoes -= clean
    gram = np.matmul(echoes, echoes.transpose(0, 2, 1))
    t = np.arange(clean.size) * forward.record.trace_every
    ends = first_echo_ends(t, fronts, grid.depths)
    first_echo_gram = np.empty_like(gram)
    for k, end in enumerate(ends):
        head = echoes[k, :, :end]
        first_echo_gram[k] = head @ head.T
    return Library(
        key=key,
        grid=grid,
        forward=forward,
        clean=clean,
        echoes=echoes,
        ok=ok,
        fronts=fronts,
        gram=gram,
        first_echo_ends=ends,
        first_echo_gram=first_echo_gram,
        build_seconds=0.0,
    )


def _save_array(path: Path, array: np.ndarray) -> None:
    """``np.save(path, array)``; an array over SAVE_PIECE_BYTES is copied into the file's memory map by up to
    SAVE_THREADS threads, a share of its rows each (numpy releases the GIL while it copies). Same file."""
    if array.nbytes <= SAVE_PIECE_BYTES or array.ndim == 0 or not array.flags.c_contiguous:
        np.save(path, array)
        return

    target = np.lib.format.open_memmap(path, mode="w+", dtype=array.dtype, shape=array.shape)
    rows = array.reshape(array.shape[0], -1)
    flat = target.reshape(array.shape[0], -1)
    pieces = max(1, min(SAVE_THREADS, array.nbytes // SAVE_PIECE_BYTES, array.shape[0]))
    edges = np.linspace(0, array.shape[0], pieces + 1).astype(int)

    def copy(a: int, b: int) -> None:
        flat[a:b] = rows[a:b]

    with ThreadPoolExecutor(max_workers=pieces) as pool:
        for future in [pool.submit(copy, a, b) for a, b in zip(edges[:-1], edges[1:])]:
            future.result()
    flat = target = None  # unmapped: the file holds the data (written back by the kernel, no fsync)


def save_library(path: Path, library: Library) -> None:
    """Write the library's arrays into the new directory ``path``: into a fresh temporary directory beside it,
    renamed to ``path`` once complete, so that ``path`` never holds part of a library. If another process has
    saved the same library there meanwhile, its copy is kept."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f"{path.name}.tmp-", dir=path.parent))
    try:
        for name in CACHED_ARRAYS:
            _save_array(tmp / f"{name}.npy", np.asarray(getattr(library, name)))
        os.rename(tmp, path)
    except OSError:
        if not path.is_dir():
            raise
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def load_library(path: Path, key: str, grid: Grid, forward: Scene) -> Library | None:
    """The library saved in the directory ``path``, its arrays memory-mapped read-only (nothing is read until
    used). None, with a warning, when a file is missing or unreadable, or shapes, types or first-echo windows
    do not match the grid and forward scene."""
    try:
        arrays = {name: np.load(path / f"{name}.npy", mmap_mode="r") for name in CACHED_ARRAYS}
    except (OSError, ValueError) as err:
        problem = f"{err.__class__.__name__}: {err}"
    else:
        depths, masses, samples = len(grid.depths), len(grid.log_mass_ratio), forward.trace_sample_count
        expected = {
            "clean": ((samples,), np.float64),
            "echoes": ((depths, masses, samples), np.float64),
            "ok": ((depths, masses), np.bool_),
            "fronts": ((forward.chain.grains,), np.float64),
            "gram": ((depths, masses, masses), np.float64),
            "first_echo_ends": ((depths,), np.int64),
            "first_echo_gram": ((depths, masses, masses), np.float64),
        }
        wrong = [
            f"{name} {arrays[name].shape} {arrays[name].dtype}"
            for name, (shape, dtype) in expected.items()
            if arrays[name].shape != shape or arrays[name].dtype != dtype
        ]
        if wrong:
            problem = "unexpected shape or type: " + ", ".join(wrong)
        else:
            t = np.arange(samples) * forward.record.trace_every
            if np.array_equal(arrays["first_echo_ends"], first_echo_ends(t, np.asarray(arrays["fronts"]), grid.depths)):
                return Library(
                    key=key,
                    grid=grid,
                    forward=forward,
                    build_seconds=0.0,
                    from_cache=True,
                    **{name: np.asarray(array) for name, array in arrays.items()},
                )
            problem = "its first-echo windows differ from FIRST_ECHO_GRAINS's"
    warnings.warn(f"detection library cache {path} is not usable ({problem}); rebuilding it", stacklevel=3)
    return None


def _library_on_device(
    key: str,
    grid: Grid,
    forward: Scene,
    fronts: np.ndarray,
    candidates: list[tuple],
    device: str,
    batch_size: int | None,
) -> Library | None:
    """The library simulated as one ensemble whose traces stay on the device, where its echoes and Gram matrices are
    assembled (kernels/library.py: the same echoes, bit for bit, as :func:`assemble_library` from host traces; Gram
    matrices equal to rounding); only the echoes (into page-locked memory allocated while the run executes) and the
    small arrays come back. None where that path does not apply (more candidates than one batch, candidates that
    cannot be stacked, more than one record interval): the caller takes the host path."""

    init_warp()
    if len(candidates) > (batch_size or default_batch_size(device)) or forward.record_count != 2:
        return None
    prepared, order = prepare_candidates(forward, candidates, grid.block)
    if prepared is None:
        return None
    model = build_model(prepared.chains, device, prepared=prepared)
    depths, ratios, samples = len(grid.depths), len(grid.log_mass_ratio), forward.trace_sample_count
    host = {}

    def allocate() -> None:  # while the run executes: page-locked allocation is slow, so it overlaps the run
        pinned = model.device.is_cuda
        host["echoes"] = wp.empty((depths * ratios, samples), dtype=wp.float64, device="cpu", pinned=pinned)

    runner = Runner(model, kernel="fused", trace_values=("v",), traces_on_device=True, on_queued=allocate)
    result = runner.run()
    ok = np.empty(len(candidates), dtype=bool)
    ok[order] = result.status == Status.OK
    library_echoes, library_grams = library_kernels(model.features.precision)
    dev = model.device
    clean = wp.empty(samples, dtype=wp.float64, device=dev)
    echoes = wp.empty((depths * ratios, samples), dtype=wp.float64, device=dev)
    wp.launch(
        library_echoes,
        dim=(len(candidates), samples),
        inputs=[
            runner.current.traces,
            runner.recorder.traced_start,
            wp.array(np.asarray(order, dtype=np.int32), dtype=wp.int32, device=dev),
            int(np.flatnonzero(np.asarray(order) == 0)[0]),
            wp.array(ok.astype(np.int32), dtype=wp.int32, device=dev),
            model.trace_capacity,
            runner.recorder.real_np(model.dt),
        ],
        outputs=[clean, echoes],
        device=dev,
    )
    t = np.arange(samples) * forward.record.trace_every
    ends = first_echo_ends(t, fronts, grid.depths)
    gram = wp.empty((depths, ratios, ratios), dtype=wp.float64, device=dev)
    first_echo_gram = wp.empty_like(gram)
    wp.launch(
        library_grams,
        dim=gram.shape,
        inputs=[echoes.reshape((depths, ratios, samples)), wp.array(ends.astype(np.int32), dtype=wp.int32, device=dev)],
        outputs=[gram, first_echo_gram],
        device=dev,
    )
    wp.copy(host["echoes"], echoes)
    return Library(
        key=key,
        grid=grid,
        forward=forward,
        clean=clean.numpy(),
        echoes=host["echoes"].numpy().reshape(depths, ratios, samples),
        ok=ok[1:].reshape(depths, ratios),
        fronts=np.asarray(fronts, dtype=np.float64),
        gram=gram.numpy(),
        first_echo_ends=ends,
        first_echo_gram=first_echo_gram.numpy(),
        build_seconds=0.0,
    )


def build_library(
    forward: Scene,
    grid: Grid,
    device: str,
    *,
    fronts: np.ndarray | None = None,
    use_cache: bool = True,
    batch_size: int | None = None,
    save_in_background: bool = False,
) -> Library:
    """The library for a forward scene and grid, from the cache when it is there (else simulated and saved).

    The cache is the directory ``<cache_dir>/<key>/`` of one ``.npy`` file per array (:func:`save_library`),
    memory-mapped on load (:func:`load_library`); one that cannot be used is removed and rebuilt, with a warning.
    """
    key = library_key(forward, grid)
    path = cache_dir() / key
    if use_cache and path.is_dir():
        library = load_library(path, key, grid, forward)
        if library is not None:
            return library
        shutil.rmtree(path, ignore_errors=True)
    start = time.perf_counter()
    if fronts is None:
        fronts = front_times(forward, device)
    candidates = [(-1, 1.0)] + [(int(d), math.exp(x)) for d in grid.depths for x in grid.log_mass_ratio]

    on_device = wp.get_device(device).is_cuda if ASSEMBLE_ON_DEVICE is None else ASSEMBLE_ON_DEVICE
    library = _library_on_device(key, grid, forward, fronts, candidates, device, batch_size) if on_device else None
    if library is None:
        traces, ok = run_candidates(forward, candidates, grid.block, device, batch_size=batch_size)
        shape = (len(grid.depths), len(grid.log_mass_ratio))
        library = assemble_library(
            key,
            grid,
            forward,
            traces[0],
            traces[1:].reshape(shape + (-1,)),
            ok[1:].reshape(shape),
            fronts,
            in_place=True,
        )
    library.build_seconds = time.perf_counter() - start
    if use_cache:
        if save_in_background:
            # the caller scores and refines meanwhile (``detect`` waits for it before it returns)

            pool = ThreadPoolExecutor(max_workers=1)
            library.saving = pool.submit(save_library, path, library)
            pool.shutdown(wait=False)
        else:
            save_library(path, library)
    return library


def cached_fronts(forward: Scene, device: str, use_cache: bool) -> np.ndarray:
    key = hashlib.sha256(
        json.dumps({"version": LIBRARY_VERSION, "scene": forward.to_dict()}, sort_keys=True).encode()
    ).hexdigest()[:24]
    path = cache_dir() / f"fronts-{key}.npy"
    if use_cache and path.is_file():
        return np.load(path)
    fronts = front_times(forward, device)
    if use_cache:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp.npy")
        np.save(tmp, fronts)
        tmp.replace(path)
    return fronts
