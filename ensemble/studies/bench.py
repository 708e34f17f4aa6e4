"""``hertzian bench``: the project's kernels and peer implementations, timed side by side in one process.

For each size (chains × grains) of the benchmark ensemble — the paper's horizontal chain
(Sen, Manciu & Wright 1998, §III B: l0 = 1e-4, walls at both ends), gear4, float64, dt = 1.25e-5,
impacts v_imp from 1e-2 to 2e-2 across the chains — every implementation

1. integrates ``check_steps`` steps from t = 0 and is compared with the per-step kernel
   (largest |difference| over the largest |value| of the state; a mismatch fails the bench);
2. is warmed up (compilation, graph capture, JIT excluded from the timing);
3. is timed over ``repeats`` runs of ``steps`` steps, synchronised at both ends; the median counts.

Rates: grain-steps per second (GS/s), steps per second, the ratio to the measured memory wall
(copy bandwidth over the 2·values·8 bytes a one-step-per-pass implementation must move per
grain-step: read the state, write the state) and the ratio to the best implementation of the size.
"""

from __future__ import annotations

import gc
import math
import os
import statistics
import time
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone

import numpy as np
import warp as wp
from hertzian.core.devices import init_warp
from hertzian.core.model import build_model
from hertzian.core.runner import Runner
from hertzian.core.scene import Scene, scene_from_dict
from hertzian.core.solvers import STEP, choose_config, make_solver
from hertzian.core.solvers.calibrate import (
    calibrate,
    default_config,
    kind_configs,
    states_equal,
    step_reason,
    whole_chain_configs,
)
from hertzian.studies.peers import JaxGear4, NumpyGear4, PeerProblem, jax_available, problem_from_model


def today() -> str:
    """The date of a measurement, UTC, ISO 8601 (YYYY-MM-DD), from the clock at the time it is taken."""
    return datetime.now(timezone.utc).date().isoformat()


KERNEL_CHOICES = ("all", "auto", "step", "tile", "window", "chain")
PROJECT_TOLERANCE = 1e-13
"""Largest relative state difference allowed between the project's kernels (same arithmetic)."""
PEER_TOLERANCE = 1e-10
"""Largest relative difference allowed for peers (their compilers may contract or reorder)."""
NUMPY_MAX_GRAINS = 1 << 18
"""The NumPy peer runs on at most this many chains × grains (the first chains of the ensemble)."""


LAWS = ("hertz", "fput")
"""Contact laws of the benchmark ensemble (``bench_scenes``)."""


def bench_scenes(chains: int, grains: int, law: str = "hertz") -> list[Scene]:
    """The benchmark ensemble: the paper's chain (l0 = 1e-4, walls), gear4 float64 dt 1.25e-5, v_imp 1e-2…2e-2; or
    (``law = "fput"``) a β-FPUT chain between walls (a = m = 1, α = 0, β = 1, dt = 0.05, the fastest mode's ω·dt
    ≈ 0.1), v_imp 0.5…1.

    Plain Gear steps (``integrator.events = "off"``): the peers implement those, and the bench measures them.
    """
    if law not in LAWS:
        raise ValueError(f"law = {law!r}: one of {', '.join(LAWS)}")
    chain, dt, impact, duration = {"grains": grains, "l0": 1e-4}, 1.25e-5, 1e-2, 1.0
    if law == "fput":
        chain = {"grains": grains, "potential": "fput", "a": 1.0, "alpha": 0.0, "beta": 1.0}
        dt, impact, duration = 0.05, 0.5, 20.0
    base = scene_from_dict(
        {
            "chain": chain,
            "excitation": {"impact": impact},
            "integrator": {"method": "gear4", "dt": dt, "duration": duration, "precision": "float64", "events": "off"},
            "record": {"fields": ["u", "v"]},
        }
    )
    return [base.with_overrides({"excitation.impact": impact * (1.0 + c / max(chains, 1))}) for c in range(chains)]


def copy_bandwidth(device) -> float:
    """Measured copy bandwidth of ``device`` [bytes/s], bytes read plus bytes written (median of repeats)."""
    device = wp.get_device(device)
    if device.is_cuda:
        n = 1 << 27  # 1 GiB of float64
        src = wp.empty(n, dtype=wp.float64, device=device)
        src.fill_(1.0)
        dst = wp.empty_like(src)
        wp.copy(dst, src)
        times = []
        for _ in range(10):
            with wp.ScopedTimer("copy", synchronize=True, print=False) as timer:
                wp.copy(dst, src)
            times.append(timer.elapsed / 1e3)
        del src, dst
        return 2 * n * 8 / statistics.median(times)
    n = 1 << 24  # 128 MiB
    src = np.ones(n)
    dst = np.empty_like(src)
    np.copyto(dst, src)
    times = []
    for _ in range(5):
        start = time.perf_counter()
        np.copyto(dst, src)
        times.append(time.perf_counter() - start)
    return 2 * n * 8 / statistics.median(times)


@dataclass
class Implementation:
    """One thing to time: advance(n) from its current state, state() as (values, chains, grains)."""

    name: str
    kernel: str
    chains: int
    advance: object
    state: object
    chunk: int = 1
    """Step counts are multiples of this (graph length, steps per launch)."""
    synchronize: object = None
    tolerance: float = PROJECT_TOLERANCE
    cpu: bool = False


def _warp_impl(name: str, runner: Runner) -> Implementation:
    dev = runner.model.device
    solver = runner.solver
    kernel = solver.describe()
    if solver.kind == "step":
        chunk = solver.config.graph_steps if solver.use_graph else 1
    else:
        chunk = solver.steps_per_launch if solver.steps_per_launch < (1 << 20) else 1
        if dev.is_cuda:
            chunk = math.lcm(chunk, 512)
    return Implementation(
        name=name,
        kernel=kernel,
        chains=runner.model.chain_count,
        advance=runner.advance,
        state=lambda: runner.current.x.numpy(),
        chunk=chunk,
        synchronize=lambda: wp.synchronize_device(dev),
        cpu=dev.is_cpu,
    )


def _time(
    impl: Implementation, steps: int | None, repeats: int, min_seconds: float, max_steps: int
) -> tuple[int, float]:
    """(steps per run, median seconds per run) after a warm-up at the timed step count."""
    sync = impl.synchronize or (lambda: None)

    def run(n):
        sync()
        start = time.perf_counter()
        impl.advance(n)
        sync()
        return time.perf_counter() - start

    if steps is None:
        n = impl.chunk
        run(n)
        elapsed = run(n)
        while elapsed < min_seconds and n < max_steps:
            grow = min(max(2.0, 1.2 * min_seconds / max(elapsed, 1e-9)), 1000.0)
            n = min(max_steps, impl.chunk * max(1, math.ceil(n * grow / impl.chunk)))
            elapsed = run(n)
    else:
        n = impl.chunk * max(1, math.ceil(steps / impl.chunk))
        run(n)
    run(n)  # both ping-pong parities warmed (graphs are captured per parity)
    times = [run(n) for _ in range(repeats)]
    return n, statistics.median(times)


def run_bench(
    device: str,
    sizes: list[tuple[int, int]],
    *,
    kernel: str = "all",
    steps: int | None = None,
    repeats: int = 5,
    check_steps: int = 64,
    peers: bool = True,
    min_seconds: float | None = None,
    log=None,
    law: str = "hertz",
) -> list[dict]:
    """Bench every implementation at every (chains, grains) on the ensemble of ``law`` (:func:`bench_scenes`);
    returns one record (dict) per implementation and size."""
    if kernel not in KERNEL_CHOICES:
        raise ValueError(f"kernel = {kernel!r}: one of {', '.join(KERNEL_CHOICES)}")
    init_warp()
    dev = wp.get_device(device)
    log = log or (lambda message: None)
    bandwidth = copy_bandwidth(dev)
    host_bandwidth = copy_bandwidth("cpu") if dev.is_cuda else bandwidth
    min_seconds = min_seconds if min_seconds is not None else (0.3 if dev.is_cuda else 0.5)
    log(f"{dev.name}: copy bandwidth {bandwidth / 1e9:.0f} GB/s (read + write)")
    records = []
    for chains, grains in sizes:
        scenes = bench_scenes(chains, grains, law)
        model = build_model(scenes, dev)
        size = _SizeBench(
            dev=dev,
            grains=grains,
            bytes_per_grain_step=2 * model.features.values * 8,
            check_steps=check_steps,
            steps=steps,
            repeats=repeats,
            min_seconds=min_seconds,
            log=log,
        )
        wall = bandwidth / size.bytes_per_grain_step
        host_wall = host_bandwidth / size.bytes_per_grain_step
        log(
            f"{chains} chains x {grains} grains: memory wall {wall:.3g} grain-steps/s "
            f"({size.bytes_per_grain_step} B/grain-step)"
        )
        initial = _bench_kernels(size, model, chains, kernel, wall)
        gc.collect()
        if peers:
            _bench_peers(size, model, chains, initial, wall, host_wall)
            gc.collect()
        best = max(r["grain_steps_per_second"] for r in size.records)
        for r in size.records:
            r["ratio_to_best"] = r["grain_steps_per_second"] / best
            r["law"] = law
        records.extend(size.records)
        model = size = initial = None
        gc.collect()
    return records


@dataclass
class _SizeBench:
    """What the implementations benched at one (chains, grains) share: the reference state, the timing settings and
    the records so far."""

    dev: object
    grains: int
    bytes_per_grain_step: int
    check_steps: int
    steps: int | None
    repeats: int
    min_seconds: float
    log: object
    max_steps: int = 1 << 24
    reference: np.ndarray | None = None
    """Positions after check_steps steps of the per-step kernel, shape (grains, chains)."""
    records: list = field(default_factory=list)

    def bench(self, impl: Implementation, on_wall: float, real_chains: int) -> None:
        """Check ``impl``'s state after check_steps steps against the reference, time it, and keep its record."""
        diff = states_equal(impl.state(), self.reference[:, :real_chains])
        if not diff <= impl.tolerance:
            raise RuntimeError(
                f"{impl.name} ({impl.kernel}) differs from the per-step kernel by {diff:.3g} "
                f"(relative) after {self.check_steps} steps at {real_chains}x{self.grains}"
            )
        n, seconds = _time(impl, self.steps, self.repeats, self.min_seconds, self.max_steps)
        gs = real_chains * self.grains * n / seconds
        self.records.append(
            {
                "implementation": impl.name,
                "kernel": impl.kernel,
                "device": "cpu" if impl.cpu else str(self.dev),
                "device_name": "CPU" if impl.cpu else self.dev.name,
                "chains": real_chains,
                "grains": self.grains,
                "steps": n,
                "repeats": self.repeats,
                "seconds": seconds,
                "grain_steps_per_second": gs,
                "steps_per_second": n / seconds,
                "bytes_per_grain_step": self.bytes_per_grain_step,
                "memory_wall_grain_steps_per_second": on_wall,
                "ratio_to_memory_wall": gs / on_wall,
                "max_relative_difference": diff,
                "date": today(),
            }
        )
        self.log(
            f"  {impl.name:12s} {impl.kernel:44s} {gs:10.3g} GS/s {n / seconds:10.3g} steps/s "
            f"x{gs / on_wall:5.2f} wall  diff {diff:.1e}"
        )


def bench_kernel_names(kernel: str, is_cuda: bool) -> list[str]:
    """The project kernels ``hertzian bench --kernel KERNEL`` times: ``all`` is step, tile, window and, on a GPU,
    ``rule`` (the shape a run takes untuned, the shipped rule's: its ratio to the best is the rule's cost)."""
    if kernel == "all":
        return ["step", "tile", "window", "rule"] if is_cuda else ["step", "chain"]
    return [kernel]


def bench_config(model, name: str, states, log):
    """The config bench measures for kernel ``name``: ``choose_config``'s, except that a forced tile or window kernel
    on a GPU is timed in each of its candidate shapes and measured in the fastest, and ``rule`` is the shipped rule's
    shape (calibrate.default_config), whatever ``hertzian tune`` chose."""
    if name == "rule":
        return STEP if step_reason(model) else default_config(model)
    if name in ("tile", "window") and model.device.is_cuda:
        configs = kind_configs(model, name)
        return configs[0] if len(configs) == 1 else calibrate(model, configs=configs, states=states, log=log)[0]
    return choose_config(model, name, run_steps=None)


def _bench_kernels(size: _SizeBench, model, chains: int, kernel: str, wall: float) -> np.ndarray:
    """Bench the project's kernels (``kernel``: one, or all of the device's) on ``model``, one runner (one pair of
    state buffers) reset to t = 0 in between; sets ``size.reference`` from the per-step kernel first. Returns the
    initial positions, shape (grains, chains)."""
    dev = size.dev
    runner = Runner(model, kernel="step")
    initial = runner.buffers[0].x.numpy().copy()

    def reset(solver) -> None:
        runner.buffers[0].x.assign(initial)
        runner.buffers[0].clock.zero_()
        runner.buffers[0].status.zero_()
        runner.current = runner.buffers[0]
        runner.solver = solver

    # reference: the per-step kernel after check_steps steps
    runner.advance(size.check_steps)
    size.reference = runner.current.x.numpy().copy()
    names = bench_kernel_names(kernel, dev.is_cuda)
    step_solver = runner.solver
    for name in names:
        if (
            kernel == "all"
            and name == "window"
            and chains >= (dev.sm_count or 1)
            and size.grains <= 1024
            and whole_chain_configs(model)
        ):
            size.log("  window: skipped (whole chains fit a block and fill the GPU)")
            continue
        solver = step_solver
        if name != "step":
            try:
                # a bench run is long by design: auto decides as for a long run; a forced tile or window kernel is
                # measured in its fastest shape on a GPU (timed here, as `hertzian tune` does, without the cache)
                config = bench_config(model, name, runner.buffers, size.log)
            except ValueError as err:
                size.log(f"  {name}: skipped ({err})")
                continue
            solver = step_solver if config.kind == "step" else make_solver(model, config)
            solver.load()
        reset(solver)
        runner.advance(size.check_steps)
        label = {"auto": solver.kind, "rule": f"rule-{solver.kind}"}.get(name, name)
        size.bench(_warp_impl(f"warp-{label}", runner), wall, chains)
        del solver
    return initial


def _bench_peers(size: _SizeBench, model, chains: int, initial: np.ndarray, wall: float, host_wall: float) -> None:
    """Bench the peers from the same initial state: NumPy (one core, at most NUMPY_MAX_GRAINS grains in all) and,
    where it is installed, JAX."""
    grains, check_steps = size.grains, size.check_steps
    problem = problem_from_model(model, initial)
    numpy_chains = max(1, min(chains, NUMPY_MAX_GRAINS // grains))
    peer = NumpyGear4(_first_chains(problem, numpy_chains))
    peer.run(check_steps)
    impl = Implementation(
        name="numpy",
        kernel="numpy, 1 core",
        chains=numpy_chains,
        advance=peer.run,
        state=peer.state,
        tolerance=PEER_TOLERANCE,
        cpu=True,
    )
    size.bench(impl, host_wall, numpy_chains)
    del peer, impl
    if jax_available():
        os.environ.setdefault("XLA_PYTHON_CLIENT_PREALLOCATE", "false")
        peer = JaxGear4(problem, str(size.dev))
        peer.run(check_steps)
        platform = peer.device.platform
        impl = Implementation(
            name="jax",
            kernel=f"lax.scan unroll={peer.unroll} ({platform})",
            chains=chains,
            advance=peer.run,
            state=peer.state,
            tolerance=PEER_TOLERANCE,
            chunk=512 if platform == "gpu" else 1,
            cpu=platform == "cpu",
        )
        size.bench(impl, host_wall if platform == "cpu" else wall, chains)


def _first_chains(problem: PeerProblem, chains: int) -> PeerProblem:
    return replace(
        problem,
        x=problem.x[:, :chains].copy(),
        contact_constant=problem.contact_constant[:chains],
        static_overlap=problem.static_overlap[:chains],
        inverse_mass=problem.inverse_mass[:chains],
    )
