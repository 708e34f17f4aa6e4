"""ChainSolver: the chain-per-thread CPU chain kernel (kernels/cpu.py), every step of an advance in one launch.

A Warp CPU launch runs on one OS thread. The solver splits the chains into contiguous ranges, one per
CPU thread (``HERTZIAN_CPU_THREADS``, default: the cores this process may use), and launches them at
once from a small Python thread pool (Warp releases the GIL while a CPU kernel runs); every chain is
integrated by one thread with the same arithmetic, so the results do not depend on the split.

Fewer chains than threads: each chain is cut into overlapping windows, one launch per thread, all running at
once. A window sweeps its grains in an array of its own and, every ``WINDOW_STEPS`` steps, trades the grains next to
its cuts with its neighbours (kernels/cpu.py, a barrier in kernels/threads.py). It reaches ``WINDOW_STEPS`` ×
substeps grains past each cut, which no error from the cut can cross between two trades (a grain's step reads only
its neighbours). Every grain a window owns has the arithmetic of the whole-chain sweep, so the results do not
depend on the cut either.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import warp as wp
from hertzian.core.model import Model, State
from hertzian.core.solvers.base import Solver
from hertzian.core.solvers.config import CHAIN, SolverConfig
from hertzian.kernels.cpu import chain_kernel, launch_chain
from hertzian.kernels.threads import BARRIER_SPIN_LIMIT

MIN_GRAIN_STEPS_TO_SPLIT = 1 << 20
"""A launch of fewer grain-steps runs whole on the calling thread: handing ranges to the pool costs more
than such a launch's kernel time (~1e8 grain-steps/s per core: 1e6 grain-steps ≈ 10 ms)."""

WINDOW_STEPS = 16
"""Steps between two exchanges of the grains next to the cuts when chains are cut into windows. Each window sweeps
WINDOW_STEPS × substeps grains more at each cut; an exchange costs two barriers (~0.1 µs each) and the copies."""

MAX_BACKOFF = 4
"""After windows gave up, whole-chain launches before they are tried again (the wait doubles up to this)."""

MIN_WINDOW_GRAINS = 4
"""A window writes back at least this many times the grains it sweeps at one cut end: shorter chains stay whole."""


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
    return usable_cores()


def usable_cores() -> int:
    """The cores this process may use (its CPU affinity on Linux)."""
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


_POOLS: dict[int, ThreadPoolExecutor] = {}
"""The process's thread pools, by size (``_pool``)."""


def _pool(workers: int) -> ThreadPoolExecutor:
    """A process-wide pool of ``workers`` threads for the launches beyond the caller's own."""
    if workers not in _POOLS:
        _POOLS[workers] = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="hertzian-chain")
    return _POOLS[workers]


def close_pools() -> None:
    """Stop the pools' idle threads, for a process about to exit (a later launch starts a new pool)."""
    while _POOLS:
        _POOLS.popitem()[1].shutdown(wait=True)


class ChainSolver(Solver):
    """One kernel thread per chain, the chains split over the CPU's cores; trace samples are written inside
    the launch (an advance is one launch per range of chains)."""

    kind = "chain"

    def __init__(
        self,
        model: Model,
        config: SolverConfig = CHAIN,
        *,
        threads: int | None = None,
        window_steps: int | None = None,
    ):
        super().__init__(model, config)
        self.kernel = chain_kernel(self.kernel_features)
        traced = model.scenes[0].record.traces if model.features.traces else []
        self.traced_grain = wp.array(np.asarray(traced, dtype=np.int32), dtype=wp.int32, device=model.device)
        self.trace_stride = model.scenes[0].trace_stride if model.features.traces else 1
        threads = threads or cpu_threads()
        window_steps = window_steps or WINDOW_STEPS
        self.ranges = chain_ranges(model.chain_count, threads)
        """The chain ranges launched at once (one per thread)."""
        self._set_up_windows(threads, window_steps)
        parallel = max(len(self.ranges), len(self.windows))
        self.pool = _pool(parallel - 1) if parallel > 1 else None

    def _set_up_windows(self, threads: int, window_steps: int) -> None:
        """The windows of each chain, their arrays and their barrier (none when the chains fill the threads)."""
        model = self.model
        ring = model.features.surface == "periodic"  # a ring's closing contact joins its two ends: whole chains
        parts = min(threads, usable_cores()) if 2 * model.chain_count <= threads and not ring else 1
        self.windows = chain_windows(model.grain_count, parts, window_steps * self.kernel_features.substeps)
        """(lo, hi, own_lo, own_hi) of each window of a chain cut over the threads, or [] (whole chains): when the
        chains would leave half the threads idle. A thread sweeps one window of every chain; the windows wait for
        each other, so there are never more than cores."""
        self.exchange_every = window_steps * self.kernel_features.substeps
        """Passes (sweeps of a window) between two exchanges of the grains next to the cuts."""
        shape = (self.kernel_features.values, model.chain_count, model.grain_count)
        self.window_x = [wp.zeros(shape, dtype=model.real, device=model.device) for _ in self.windows]
        """Each window's own sweep array."""
        self.barrier_state = wp.zeros(3, dtype=wp.uint32, device=model.device)
        """The windows' barrier: arrivals, generation, abort flag (kernels/threads.py)."""
        self.patience = BARRIER_SPIN_LIMIT
        """Spins a window waits at a barrier before the windows give up (kernels/threads.py)."""
        self._skip_windows, self._backoff = 0, 1
        """Launches to run as whole chains before windows are tried again, and the next such wait."""
        damped = model.features.damping != "none"
        self._dissipated_before = wp.zeros(
            (model.chain_count, model.grain_count) if damped and self.windows else (0, 0),
            dtype=wp.float64,
            device=model.device,
        )
        """A launch's dissipated energy before it, to restore when its windows give up."""

    def _launch(self, state_in: State, state_out: State, steps: int, chains: tuple[int, int], window: int | None):
        m = self.model
        windowed = window is not None
        launch_chain(
            self.kernel,
            x_in=state_in.x,
            clock_in=state_in.clock,
            inverse_mass=m.inverse_mass,
            contact_constant=m.contact_constant,
            static_overlap=m.static_overlap,
            law_parameters=m.law_parameters,
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
            window=self.windows[window] if windowed else None,
            x_window=self.window_x[window] if windowed else None,
            exchange_every=self.exchange_every,
            barrier_state=self.barrier_state,
            parties=len(self.windows),
            patience=self.patience,
        )

    def launch(self, state_in: State, state_out: State, steps: int) -> None:
        m = self.model

        def run(chains: tuple[int, int], window: int | None = None) -> None:
            self._launch(state_in, state_out, steps, chains, window)

        if self.windows and m.grain_count * steps >= MIN_GRAIN_STEPS_TO_SPLIT:
            if self._skip_windows > 0:
                self._skip_windows -= 1
            elif self._windowed(state_in, steps, run):
                self._backoff = 1
                return
            else:  # other work holds a core: whole chains for a while, then windows again (twice as long a while)
                self._skip_windows, self._backoff = self._backoff, min(2 * self._backoff, MAX_BACKOFF)
        if self.pool is None or m.chain_count * m.grain_count * steps < MIN_GRAIN_STEPS_TO_SPLIT:
            run((0, m.chain_count))
            return
        others = [self.pool.submit(run, chains) for chains in self.ranges[1:]]
        run(self.ranges[0])  # this thread takes the first range
        for future in others:
            future.result()

    def _windowed(self, state_in: State, steps: int, run) -> bool:
        """One launch per window, all at once; False (nothing of it kept: the launch is then run as whole chains from
        the same state) when a window waited too long at a barrier: its partner was not running."""
        m = self.model
        damped = state_in.dissipated.shape[0] > 0
        if damped:
            wp.copy(self._dissipated_before, state_in.dissipated)  # updated in place by the windows
        every = (0, m.chain_count)
        others = [self.pool.submit(run, every, w) for w in range(1, len(self.windows))]
        run(every, 0)
        for future in others:
            future.result()
        if not self.barrier_state.numpy()[2]:
            return True
        if damped:
            wp.copy(state_in.dissipated, self._dissipated_before)
        self.barrier_state.zero_()
        return False


def chain_windows(grains: int, parts: int, reach: int) -> list[tuple[int, int, int, int]]:
    """``parts`` windows (lo, hi, own_lo, own_hi) cutting a chain of ``grains``: the owned ranges tile the chain
    evenly and each window reaches ``reach`` grains past its owned range on each side that has a neighbour. []
    when ``parts`` < 2 or an owned range would be shorter than MIN_WINDOW_GRAINS × ``reach``."""
    if parts < 2 or grains < parts * MIN_WINDOW_GRAINS * reach:
        return []
    windows = []
    for first, end in chain_ranges(grains, parts):
        windows.append((max(0, first - reach), min(grains, end + reach), first, end))
    return windows
