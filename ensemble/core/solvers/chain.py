"""ChainSolver: the chain-per-thread CPU chain kernel (kernels/cpu.py), every step of an advance in one launch.

A Warp CPU launch runs on one OS thread. The solver splits the chains into contiguous ranges, one per
CPU thread (``HERTZIAN_CPU_THREADS``, default: the cores this process may use), and launches them at
once from a small Python thread pool (Warp releases the GIL while a CPU kernel runs); every chain is
integrated by one thread with the same arithmetic, so the results do not depend on the split.
"""

from __future__ import annotations

import functools
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import warp as wp
from hertzian.core.model import Model, State
from hertzian.core.solvers.base import Solver
from hertzian.core.solvers.config import CHAIN, SolverConfig
from hertzian.kernels.cpu import chain_kernel, launch_chain

MIN_GRAIN_STEPS_TO_SPLIT = 1 << 20
"""A launch of fewer grain-steps runs whole on the calling thread: handing ranges to the pool costs more
than such a launch's kernel time (~1e8 grain-steps/s per core: 1e6 grain-steps ≈ 10 ms)."""


def cpu_threads() -> int:
    """Threads for the CPU chain kernel: ``HERTZIAN_CPU_THREADS`` if set (≥ 1), else the cores this process may use."""
    value = os.environ.get("HERTZIAN_CPU_THREADS", "").strip()
    if value:
        try:
            count = int(value)
        except ValueError:
            count = 0
        if count < 1:
            raise ValueError(f"HERTZIAN_CPU_THREADS = {value!r}: must be a whole number ≥ 1")
        return count
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def chain_ranges(chain_count: int, threads: int) -> list[tuple[int, int]]:
    """``threads`` contiguous (first, end) ranges covering the chains, sizes differing by at most one."""
    parts = max(1, min(threads, chain_count))
    base, extra = divmod(chain_count, parts)
    ranges, first = [], 0
    for k in range(parts):
        end = first + base + (1 if k < extra else 0)
        ranges.append((first, end))
        first = end
    return ranges


@functools.cache
def _pool(workers: int) -> ThreadPoolExecutor:
    """A process-wide pool of ``workers`` threads for the launches beyond the caller's own."""
    return ThreadPoolExecutor(max_workers=workers, thread_name_prefix="hertzian-chain")


class ChainSolver(Solver):
    """One kernel thread per chain, the chains split over the CPU's cores; trace samples are written inside
    the launch (an advance is one launch per range of chains)."""

    kind = "chain"

    def __init__(self, model: Model, config: SolverConfig = CHAIN, *, threads: int | None = None):
        super().__init__(model, config)
        self.kernel = chain_kernel(self.kernel_features)
        traced = model.scenes[0].record.traces if model.features.traces else []
        self.traced_grain = wp.array(np.asarray(traced, dtype=np.int32), dtype=wp.int32, device=model.device)
        self.trace_stride = model.scenes[0].trace_stride if model.features.traces else 1
        self.ranges = chain_ranges(model.chain_count, threads or cpu_threads())
        """The chain ranges launched at once (one per thread)."""
        self.pool = _pool(len(self.ranges) - 1) if len(self.ranges) > 1 else None

    def launch(self, state_in: State, state_out: State, steps: int) -> None:
        m = self.model

        def run(chains: tuple[int, int]) -> None:
            launch_chain(
                self.kernel,
                x_in=state_in.x,
                clock_in=state_in.clock,
                inverse_mass=m.inverse_mass,
                contact_constant=m.contact_constant,
                static_overlap=m.static_overlap,
                exponent=m.exponent,
                status=state_in.status,
                dt=m.dt,
                steps=steps,
                x_out=state_out.x,
                clock_out=state_out.clock,
                device=m.device,
                drive=m.drive,
                work_in=state_in.work,
                power_in=state_in.power,
                work_out=state_out.work,
                power_out=state_out.power,
                damping=m.damping,
                dissipated=state_in.dissipated,
                traced_grain=self.traced_grain,
                trace_stride=self.trace_stride,
                trace_x=state_in.traces,
                chains=chains,
            )

        if self.pool is None or m.chain_count * m.grain_count * steps < MIN_GRAIN_STEPS_TO_SPLIT:
            run((0, m.chain_count))
            return
        others = [self.pool.submit(run, chains) for chains in self.ranges[1:]]
        run(self.ranges[0])  # this thread takes the first range
        for future in others:
            future.result()
