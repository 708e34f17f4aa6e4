"""Loading kernel variants: the Warp modules a solver or a recorder launches, compiled at once (concurrently where
that pays). ``hertzian.core.solvers.prepare`` names every variant a job needs and calls :func:`load_variants`.

The job-level view:

A job is a list of :class:`Need` (one per launch group: features, chain length, chains, steps, kernel choice).
:func:`kernel_variants` names the Warp modules and block sizes those launches will load: the stepping kernel the
solver choice takes (``choose_config``: the shape ``hertzian tune`` chose, else the shipped rule's), the record
reductions of that chain length, ``track_extremes`` and, with traces but no snapshot fields, the traced-start
gather. :func:`prepare_kernels` compiles and loads them, so that the run itself compiles nothing. Every entry point
calls it: ``Runner`` (one run), ``warm_kernels`` (sweeps and the paper reproduction), the detection library, and
``hertzian warmup``, which fills Warp's kernel cache ahead of time.

Concurrency: ``max_workers`` threads each call ``Module.load``; the compilers (NVRTC, Warp's in-process clang) run
outside the GIL, so variants compile side by side. On a CPU every compile waits for one precompiled header of Warp's
headers, built once in the kernel cache (``hertzian.core.devices.prime_precompiled_header``); threads compiling
before it existed each built their own and were slower than one (docs/fixed-costs.md).
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import warp as wp
from hertzian.core.devices import prime_precompiled_header
from hertzian.core.solvers import prebuilt
from hertzian.core.solvers.config import SolverConfig
from hertzian.kernels.cpu import chain_kernel
from hertzian.kernels.features import Features, device_of
from hertzian.kernels.records import STAGED_GRAINS, record_kernels, record_modules, traced_start_kernel, track_extremes
from hertzian.kernels.step import step_kernel
from hertzian.kernels.tile import drive_table, tile_kernel

GPU_COMPILE_WORKERS = 8
"""Default threads compiling CUDA variants at once (capped by the host's cores)."""


def solver_variants(config: SolverConfig, features: Features, grains: int, chains: int) -> list[tuple]:
    """(Warp module, block_dim) of the stepping kernel (and a driven tile's phase table) a solver of ``config``
    loads; block_dim None: Warp's launch default, as the launch uses it."""
    from hertzian.core.solvers.tile import solver_plan  # tile imports base, which imports nothing of this module

    if config.kind == "step":
        return [(step_kernel(features).module, None)]
    if config.kind == "chain":
        return [(chain_kernel(features).module, None)]
    shape = solver_plan(config, features, grains, chains).shape
    out = [(tile_kernel(features, shape).module, shape.block_dim)]
    if features.surface == "driven":
        out.append((drive_table.module, None))
    return out


def recorder_variants(features: Features, grains: int, device, *, fields: bool = False) -> list[tuple]:
    """(Warp module, block_dim) of the record kernels a run of ``grains``-grain chains loads (Recorder.load);
    ``fields``: the run records snapshot fields, whose record 0 holds the traced grains' start (no gather)."""
    out = record_modules(record_kernels(features), long_chains=grains >= STAGED_GRAINS, device=device)
    out.append((track_extremes.module, None))
    if features.traces and not fields:
        out.append((traced_start_kernel(features.precision).module, None))
    return out


def default_workers(device) -> int:
    """Compile threads: ``HERTZIAN_COMPILE_WORKERS`` if set, else one per core on a CPU and up to
    GPU_COMPILE_WORKERS on a GPU."""
    value = os.environ.get("HERTZIAN_COMPILE_WORKERS", "").strip()
    if value:
        if not value.isdigit() or int(value) < 1:
            raise ValueError(f"HERTZIAN_COMPILE_WORKERS = {value!r}: must be a whole number ≥ 1")
        return int(value)
    cores = os.cpu_count() or 1
    if device_of(device).is_cpu:
        return cores
    return max(1, min(GPU_COMPILE_WORKERS, cores))


def block_of(device, block_dim: int | None) -> int:
    """The block size a launch at ``block_dim`` loads (None: Warp's default, 1 on a CPU)."""
    return block_dim if block_dim is not None else (1 if device.is_cpu else 256)


def in_cache(module, device, block_dim: int | None = None) -> bool:
    """Whether Warp's ``module`` at ``block_dim`` is loaded on ``device``, compiled in Warp's kernel cache
    (``wp.config.kernel_cache_dir``) or prebuilt (``hertzian.core.solvers.prebuilt``), so that loading it compiles
    nothing."""
    dev = wp.get_device(device)
    block = block_of(dev, block_dim)
    return (
        (dev.context, block) in module.execs
        or in_warp_cache(module, dev, block)
        or prebuilt.find(module, dev, block) is not None
    )


def in_warp_cache(module, device, block: int) -> bool:
    """Whether Warp's kernel cache holds ``module``'s binary at ``block`` threads for ``device``."""
    name = module.get_module_identifier(block)
    return (
        Path(wp.config.kernel_cache_dir) / name / module._get_compile_output_name(device, block_dim=block)
    ).is_file()


def _load(device, module, block_dim) -> dict:
    """Load one variant: from Warp's kernel cache, else from a prebuilt folder, else compiled.
    Returns {"module", "block_dim", "cached" (nothing compiled), "prebuilt" (read from a prebuilt folder),
    "seconds"}."""
    start = time.perf_counter()
    block = block_of(device, block_dim)
    if device.is_cpu and block > 1:
        wp.config.enable_cpu_blocks = True  # Warp 1.19 runs CPU blocks as fibers only when asked (Solver.load)
    loaded = (device.context, block) in module.execs or in_warp_cache(module, device, block)
    from_prebuilt = not loaded and prebuilt.load(module, device, block)
    cached = loaded or from_prebuilt
    if not from_prebuilt:
        module.load(device, block_dim=block)
    seconds = time.perf_counter() - start
    return {
        "module": module.name,
        "block_dim": block_dim,
        "cached": cached,
        "prebuilt": from_prebuilt,
        "seconds": seconds,
    }


def load_variants(variants: list[tuple], device, max_workers: int | None = None) -> tuple[int, list[dict]]:
    """Compile (or read from Warp's kernel cache) and load each (Warp module, block_dim) on ``device``,
    ``max_workers`` at a time (None: :func:`default_workers`). Returns the threads used and, per variant,
    {"module", "block_dim", "cached", "seconds"}."""
    dev = wp.get_device(device)
    workers = max(1, min(len(variants), max_workers or default_workers(dev)))
    if dev.is_cpu and workers > 1 and not all(in_cache(m, dev, b) for m, b in variants):
        prime_precompiled_header()  # one header, built once, instead of one per compiling thread
    if workers == 1:
        return workers, [_load(dev, module, block_dim) for module, block_dim in variants]
    with ThreadPoolExecutor(max_workers=workers, thread_name_prefix="hertzian-compile") as pool:
        return workers, [future.result() for future in [pool.submit(_load, dev, m, b) for m, b in variants]]


def prebuild_variants(
    variants: list[tuple], device, out: Path, *, archs: list[int] = (), ptx: list[int] = (), max_workers=None
) -> dict:
    """Compile each (Warp module, block_dim) of ``variants`` into the prebuilt folder ``out``
    (``hertzian.core.solvers.prebuilt``): for ``device`` itself (its CPU object, or its GPU's cubin), plus a cubin
    for each CUDA architecture of ``archs`` and PTX for each of ``ptx`` (neither needs a GPU), ``max_workers`` at a
    time. Returns {"modules", "binaries", "bytes", "seconds"}."""
    start = time.perf_counter()
    dev = device_of(device)
    archs, ptx = list(archs), list(ptx)
    out.mkdir(parents=True, exist_ok=True)
    jobs = [(m, block_of(dev, b), target) for m, b in variants for target in prebuilt.targets(dev, archs, ptx)]
    if dev.is_cpu:
        prime_precompiled_header()  # every CPU compile waits for one shared header
    workers = max(1, min(len(jobs), max_workers or default_workers(dev)))
    with ThreadPoolExecutor(max_workers=workers, thread_name_prefix="hertzian-prebuild") as pool:
        list(pool.map(lambda job: prebuilt.compile_into(out, *job), jobs))
    prebuilt.write_index(out, dev, archs, ptx, {prebuilt.variant_names(m, block)[0] for m, block, _ in jobs})
    size = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    return {"modules": len(variants), "binaries": len(jobs), "bytes": size, "seconds": time.perf_counter() - start}
