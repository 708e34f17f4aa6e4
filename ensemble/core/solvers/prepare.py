"""Every kernel a job needs, named before its first launch and compiled at once.

A job is a list of :class:`Need` (one per launch group: features, chain length, chains, steps, kernel choice).
:func:`kernel_variants` names the Warp modules and block sizes those launches will load: the stepping kernel the
solver choice takes (``choose_config``: a shape ``hertzian tune`` chose, else the shipped rule's), the record
reductions of that chain length, ``track_extremes`` and, with traces but no snapshot fields, the traced-start
gather. :func:`prepare_kernels` compiles and loads them (``compile.load_variants``), so that the run itself compiles
nothing. Every entry point calls it: ``Runner`` (one run), ``warm_kernels`` (sweeps and the paper reproduction), the
detection library, and ``hertzian warmup``, which fills Warp's kernel cache ahead of time.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Iterable

import warp as wp
from hertzian.core.solvers.calibrate import choose_config
from hertzian.core.solvers.compile import load_variants, recorder_variants, solver_variants
from hertzian.core.solvers.config import SolverConfig
from hertzian.kernels.cpu import chain_kernel
from hertzian.kernels.features import Features, device_of


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
    fields: bool = False
    """The runs record snapshot fields (``record.fields``): no traced-start gather then (False: compile it)."""


def planned_config(need: Need, device) -> SolverConfig:
    """The SolverConfig a run of ``need`` on ``device`` takes (``choose_config``: on a GPU the tuned shape when
    ``hertzian tune`` chose one, else the shipped rule's)."""
    if isinstance(need.kernel, SolverConfig):
        return need.kernel
    model = SimpleNamespace(
        device=device_of(device), features=need.features, grain_count=need.grains, chain_count=need.chains
    )
    return choose_config(model, need.kernel, run_steps=need.steps)


def kernel_variants(needs: Iterable[Need | Features | wp.Kernel], device) -> list[tuple]:
    """The distinct (Warp module, block_dim) every launch of ``needs`` loads on ``device``, in first-need order;
    a Warp kernel stands for its own launches at Warp's default block size.
    A bare Features stands for runs of unknown size: its record kernels for short chains and, on a CPU, the chain
    kernel ``auto`` takes (on a GPU the stepping kernel's shape depends on the size)."""
    dev = device_of(device)
    out: dict[tuple, None] = {}
    for need in needs:
        if isinstance(need, wp.Kernel):  # a kernel launched as it is (detection library, response windows)
            out[(need.module, None)] = None
            continue
        if isinstance(need, Features):
            stepping = [(chain_kernel(need).module, None)] if dev.is_cpu else []
            for variant in stepping + recorder_variants(need, 1, dev):
                out[variant] = None
            continue
        config = planned_config(need, dev)
        for variant in solver_variants(config, need.features, need.grains, need.chains):
            out[variant] = None
        for variant in recorder_variants(need.features, need.grains, dev, fields=need.fields):
            out[variant] = None
    return list(out)


def prepare_kernels(needs: Iterable[Need | Features | wp.Kernel], device, max_workers: int | None = None) -> dict:
    """Compile (or read from Warp's kernel cache) and load every kernel variant ``needs`` will launch on
    ``device``, ``max_workers`` at a time (None: ``default_workers``). Returns {"variants": count,
    "seconds": wall time [s], "workers": threads used, "loads": per variant {"module", "block_dim", "cached",
    "seconds"}}."""
    start = time.perf_counter()
    variants = kernel_variants(needs, device)
    workers, loads = load_variants(variants, device, max_workers)
    return {"variants": len(variants), "seconds": time.perf_counter() - start, "workers": workers, "loads": loads}
