"""Every kernel a job needs, named before its first launch and compiled at once (concurrently where that pays).

A job is a list of :class:`Need` (one per launch group: features, chain length, chains, steps, kernel choice).
:func:`kernel_variants` names the Warp modules and block sizes those launches will load: the stepping kernel the
solver choice takes (``choose_config`` without a calibration: a shape the calibration cache holds, else the
default shape), the record reductions of that chain length, ``track_extremes`` and, with traces, the traced-start
gather. :func:`prepare_kernels` compiles and loads them, so that the run itself compiles nothing. Every entry point
calls it: ``Runner`` (one run), ``warm_kernels`` (sweeps and the paper reproduction), the detection library, and
``hertzian warmup``, which fills Warp's kernel cache ahead of time.

Concurrency: ``max_workers`` threads each call ``Module.load``; the CUDA compiler (NVRTC) runs outside the GIL, so
GPU variants compile side by side. On a CPU the in-process clang compiles of Warp serialise and threads made them
slower (docs/fixed-costs.md), so a CPU prepares serially unless told otherwise.
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Iterable

import warp as wp
from hertzian.core.solvers.config import SolverConfig
from hertzian.kernels.cpu import chain_kernel, chain_kernel_supports
from hertzian.kernels.features import Features
from hertzian.kernels.records import STAGED_GRAINS, record_kernels, record_modules, traced_start_kernel, track_extremes
from hertzian.kernels.step import step_kernel
from hertzian.kernels.tile import drive_table, tile_kernel

GPU_COMPILE_WORKERS = 8
"""Default threads compiling CUDA variants at once (capped by the host's cores)."""


@dataclass(frozen=True)
class Need:
    """One launch group of a job: what its solver and recorder will compile."""

    features: Features
    grains: int
    chains: int = 1
    steps: int | None = None
    """Steps of one run (None: long, as ``choose_config`` counts it)."""
    kernel: str | SolverConfig = "auto"
    """A ``--kernel`` choice (hertzian.core.solvers.calibrate.KERNELS) or the config itself."""


def planned_config(need: Need, device) -> SolverConfig:
    """The SolverConfig a run of ``need`` on ``device`` takes, without calibrating: a GPU's cached calibration when
    there is one (the run reads the same entry), else the choice ``choose_config`` makes with ``calibrate_now=False``."""
    from hertzian.core.solvers.calibrate import cached_config, choose_config  # calibrate imports this module

    if isinstance(need.kernel, SolverConfig):
        return need.kernel
    model = SimpleNamespace(
        device=wp.get_device(device), features=need.features, grain_count=need.grains, chain_count=need.chains
    )
    config = choose_config(model, need.kernel, run_steps=need.steps, calibrate_now=False)
    if config.kind in ("tile", "window") and need.kernel in ("auto", "fused"):
        return cached_config(model) or config
    return config


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


def recorder_variants(features: Features, grains: int, device) -> list[tuple]:
    """(Warp module, block_dim) of the record kernels a run of ``grains``-grain chains loads (Recorder.load)."""
    out = record_modules(record_kernels(features), long_chains=grains >= STAGED_GRAINS, device=device)
    out.append((track_extremes.module, None))
    if features.traces:
        out.append((traced_start_kernel(features.precision).module, None))
    return out


def kernel_variants(needs: Iterable[Need | Features | wp.Kernel], device) -> list[tuple]:
    """The distinct (Warp module, block_dim) every launch of ``needs`` loads on ``device``, in first-need order;
    a Warp kernel stands for its own launches at Warp's default block size.
    A bare Features stands for runs of unknown size: its record kernels for short chains and, on a CPU, the chain
    kernel ``auto`` takes (on a GPU the stepping kernel's shape depends on the size)."""
    dev = wp.get_device(device)
    out: dict[tuple, None] = {}
    for need in needs:
        if isinstance(need, wp.Kernel):  # a kernel launched as it is (detection library, response windows)
            out[(need.module, None)] = None
            continue
        if isinstance(need, Features):
            stepping = [(chain_kernel(need).module, None)] if dev.is_cpu and chain_kernel_supports(need) else []
            for variant in stepping + recorder_variants(need, 1, dev):
                out[variant] = None
            continue
        config = planned_config(need, dev)
        for variant in solver_variants(config, need.features, need.grains, need.chains):
            out[variant] = None
        for variant in recorder_variants(need.features, need.grains, dev):
            out[variant] = None
    return list(out)


def default_workers(device) -> int:
    """Compile threads: ``HERTZIAN_COMPILE_WORKERS`` if set, else 1 on a CPU (serial clang) and up to
    GPU_COMPILE_WORKERS on a GPU."""
    value = os.environ.get("HERTZIAN_COMPILE_WORKERS", "").strip()
    if value:
        if not value.isdigit() or int(value) < 1:
            raise ValueError(f"HERTZIAN_COMPILE_WORKERS = {value!r}: must be a whole number ≥ 1")
        return int(value)
    if wp.get_device(device).is_cpu:
        return 1
    return max(1, min(GPU_COMPILE_WORKERS, os.cpu_count() or 1))


def _load(device, module, block_dim) -> None:
    if device.is_cpu and (block_dim or 1) > 1:
        wp.config.enable_cpu_blocks = True  # Warp 1.19 runs CPU blocks as fibers only when asked (Solver.load)
    module.load(device, block_dim=block_dim if block_dim is not None else (1 if device.is_cpu else 256))


def prepare_kernels(needs: Iterable[Need | Features | wp.Kernel], device, max_workers: int | None = None) -> dict:
    """Compile (or read from Warp's kernel cache) and load every kernel variant ``needs`` will launch on
    ``device``, ``max_workers`` at a time (None: :func:`default_workers`). Returns {"variants": count,
    "seconds": wall time [s], "workers": threads used}."""
    start = time.perf_counter()
    dev = wp.get_device(device)
    variants = kernel_variants(needs, dev)
    workers = max(1, min(len(variants), max_workers or default_workers(dev)))
    if workers == 1:
        for module, block_dim in variants:
            _load(dev, module, block_dim)
    else:
        with ThreadPoolExecutor(max_workers=workers, thread_name_prefix="hertzian-compile") as pool:
            for future in [pool.submit(_load, dev, m, b) for m, b in variants]:
                future.result()
    return {"variants": len(variants), "seconds": time.perf_counter() - start, "workers": workers}
