"""Which kernel steps an ensemble, and in what launch shape: a short measured calibration, cached.

Kernels (``--kernel``):

* ``step`` — one Gear/Verlet step per launch over (chain, grain) (``kernels/step.py``): every feature,
  memory-bound on GPUs (the whole state through device memory every step).
* ``tile`` — whole chains in one block, K steps per launch (``kernels/tile.py``), CUDA.
* ``window`` — long chains cut into blocks with ghost zones, K ≤ ghost steps per launch
  (``kernels/tile.py`` + ``kernels/ghost.py``), CUDA.
* ``sweep`` — one CPU thread per chain, many steps per launch (``kernels/cpu.py``).
* ``auto`` — per-step for features the fused kernels lack (drive, traces) and for runs too short to
  repay a compile; else ``sweep`` on a CPU, and on a GPU the fastest of a few ``tile``/``window``
  shapes, timed once per (device, features, grains, chains) and remembered in
  ``$HERTZIAN_CACHE`` (default ``~/.cache/hertzian/calibration.json``).

Every fused kernel reproduces the per-step kernel's arithmetic (tests/test_tile.py,
tests/test_cpu_kernel.py), so the choice changes speed, not results.
"""

from __future__ import annotations

import json
import math
import os
import statistics
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import warp as wp

from kernels.cpu import launch_sweep, sweep_kernel, sweepable
from kernels.tile import TilePlan, TileShape, fusable, launch_tile, plan_tile, tile_kernel

from .model import Model, State

KERNELS = ("auto", "step", "tile", "window", "sweep")

AUTO_MIN_GRAIN_STEPS_CPU = 2e8
"""Below this many grain-steps in a run, ``auto`` keeps the per-step kernel on a CPU (a compile costs seconds)."""
AUTO_MIN_GRAIN_STEPS_GPU = 5e9
"""Likewise on a GPU, where a calibration costs tens of seconds the first time."""
CALIBRATION_VERSION = 1


class MultiStepper:
    """Advances a model's state many steps per launch, ping-ponging between two state buffers."""

    name = "fused"
    steps_per_launch = 1 << 30

    def __init__(self, model: Model):
        self.model = model
        self.graphs: dict[tuple[int, int], object] = {}

    def launch(self, state_in: State, state_out: State, status: wp.array, steps: int) -> None:
        raise NotImplementedError

    def launch_count(self, n_steps: int) -> int:
        return -(-n_steps // self.steps_per_launch)

    def _launches(self, buffers, parity: int, status, n_steps: int) -> int:
        while n_steps > 0:
            steps = min(n_steps, self.steps_per_launch)
            self.launch(buffers[parity], buffers[parity ^ 1], status, steps)
            parity ^= 1
            n_steps -= steps
        return parity

    def advance(self, buffers, parity: int, status: wp.array, n_steps: int, *, use_graph: bool = False) -> int:
        """Take ``n_steps`` steps from ``buffers[parity]``; returns the parity of the buffer now current."""
        if n_steps <= 0:
            return parity
        if not use_graph:
            return self._launches(buffers, parity, status, n_steps)
        key = (n_steps, parity)
        if key not in self.graphs:
            with wp.ScopedCapture(device=self.model.device) as capture:
                end = self._launches(buffers, parity, status, n_steps)
            self.graphs[key] = (capture.graph, end)
        graph, end = self.graphs[key]
        wp.capture_launch(graph)
        return end

    block_dim: int | None = None

    @property
    def module(self):
        return self.kernel.module

    def load(self) -> None:
        """Compile and load the kernel for its launch's block size (before any graph capture)."""
        if self.model.device.is_cpu and (self.block_dim or 1) > 1:
            wp.config.enable_cpu_blocks = True  # Warp 1.19 runs CPU blocks as fibers only when asked
        wp.load_module(self.kernel.module, device=self.model.device, block_dim=self.block_dim)

    def describe(self) -> str:
        return self.name


class TileStepper(MultiStepper):
    """The fused kernels of ``kernels/tile.py`` (whole chains or windows) in one launch plan."""

    def __init__(self, model: Model, plan: TilePlan):
        super().__init__(model)
        self.plan = plan
        self.kernel = tile_kernel(model.features, plan.shape)
        self.steps_per_launch = plan.steps_per_launch
        self.name = "window" if plan.shape.windowed else "tile"
        self.block_dim = plan.shape.block_dim

    def launch(self, state_in: State, state_out: State, status: wp.array, steps: int) -> None:
        m = self.model
        launch_tile(self.plan, self.kernel, x_in=state_in.x, clock_in=state_in.clock, inverse_mass=m.inverse_mass,
                    contact_constant=m.contact_constant, static_overlap=m.static_overlap, exponent=m.exponent,
                    status=status, dt=m.dt, steps=steps, x_out=state_out.x, clock_out=state_out.clock,
                    device=m.device)

    def describe(self) -> str:
        return f"{self.name} ({self.plan.describe()})"


class SweepStepper(MultiStepper):
    """The chain-per-thread CPU sweep of ``kernels/cpu.py``."""

    name = "sweep"

    def __init__(self, model: Model, steps_per_launch: int = 1 << 30):
        super().__init__(model)
        self.kernel = sweep_kernel(model.features)
        self.steps_per_launch = steps_per_launch

    def launch(self, state_in: State, state_out: State, status: wp.array, steps: int) -> None:
        m = self.model
        launch_sweep(self.kernel, x_in=state_in.x, clock_in=state_in.clock, inverse_mass=m.inverse_mass,
                     contact_constant=m.contact_constant, static_overlap=m.static_overlap, exponent=m.exponent,
                     status=status, dt=m.dt, steps=steps, x_out=state_out.x, clock_out=state_out.clock,
                     device=m.device)


# ---- candidate launch shapes ----------------------------------------------------------------------

REGISTERS = {4: 128, 8: 232, 16: 255}
"""Registers per thread of the gear4 float64 fused kernel for G grains per lane, padded/windowed variants
(ptxas for sm_90 reports 122, 216 and 255 for the plain variants; launches of 264 lanes at G = 8 and 528 at
G = 4 were refused on the H100, so windowed variants use a little more)."""


def _fits(lanes: int, G: int, registers: int = 65536) -> bool:
    """Whether a block of ``lanes`` threads at G grains per lane fits in ``registers`` (whole warps count)."""
    return -(-lanes // 32) * 32 * REGISTERS[G] <= registers


def _sm_count(model: Model) -> int:
    return (getattr(model.device, "sm_count", 0) or 1) if model.device.is_cuda else 1


def whole_chain_plans(model: Model) -> list[TilePlan]:
    """Whole-chain shapes worth timing for this model (block ≤ 1024 threads, registers permitting)."""
    f, n, c = model.features, model.grain_count, model.chain_count
    plans = []
    for G, regs in ((8, 0), (4, 0), (8, 168), (16, 0)):
        lanes = -(-n // G)
        if -(-lanes // 32) * 32 * (regs or REGISTERS[G]) > 65536:
            continue
        per_block = 1
        while per_block * 2 * lanes <= 128 and per_block * 2 <= c:
            per_block *= 2          # short chains: several per block, blocks of ≥ 64–128 threads
        for cpb in sorted({1, per_block}):
            try:
                plans.append(plan_tile(f, n, c, grains_per_lane=G, chains_per_block=cpb, steps_per_launch=64,
                                       max_registers=regs))
            except ValueError:
                pass
    return plans


def window_plans(model: Model) -> list[TilePlan]:
    """Windowed shapes worth timing: with many chains the fewest blocks per chain that fit an SM, or two per SM
    (G = 4 or 8, K = 32 or 64); with few chains, enough blocks to fill the GPU, or half as many (G = 4, K = 16
    or 32)."""
    f, n, c = model.features, model.grain_count, model.chain_count
    sms = _sm_count(model)
    plans = []
    many = c >= sms
    for G in ((8, 4) if many else (4,)):
        for K in ((32, 64) if many else (16, 32)):
            b_max = n // (2 * K)          # keep the interior at least twice the ghost zone
            b_min = 2
            while b_min <= b_max and not _fits(-(-(-(-n // b_min) + 2 * K) // G), G):
                b_min += 1
            if b_min > b_max:
                continue
            b_fill = min(b_max, max(b_min, -(-2 * sms // c)))
            b_mid = max(b_min, min(b_fill, round(math.sqrt(b_min * b_fill))))
            b_two = b_min                 # two blocks per SM: half an SM's registers per block
            while b_two < b_max and not _fits(-(-(-(-n // b_two) + 2 * K) // G), G, 32768):
                b_two += 1
            for b in sorted({b_min, b_two} if many else {b_mid, b_fill}):
                interior = -(-n // b)
                lanes = -(-(interior + 2 * K) // G)
                try:
                    plans.append(plan_tile(f, n, c, grains_per_lane=G, lanes_per_chain=lanes, steps_per_launch=K,
                                           windowed=True))
                except ValueError:
                    pass
    return plans


def default_plan(model: Model) -> TilePlan:
    """A shape chosen without timing: whole chains when they fill the GPU, else windows."""
    n, c = model.grain_count, model.chain_count
    sms = getattr(model.device, "sm_count", 132) or 132
    whole = [p for p in whole_chain_plans(model) if p.shape.max_registers == 0]
    if n <= 1024 and c >= 2 * sms and whole:
        return whole[0]
    windows = window_plans(model)
    if windows:
        return windows[0]
    return whole[0]


# ---- measuring --------------------------------------------------------------------------------------

def time_stepper(stepper: MultiStepper, *, steps: int, repeats: int = 3, use_graph: bool | None = None,
                 buffers: tuple[State, State] | None = None) -> float:
    """Median seconds per step of ``stepper`` (warm-up excluded), on ``buffers`` or scratch copies of the
    model's initial state (the content is overwritten)."""
    m = stepper.model
    graph = m.device.is_cuda if use_graph is None else use_graph
    buffers = buffers or (m.initial_state(), m.state())
    status = wp.zeros(m.chain_count, dtype=wp.int32, device=m.device)
    stepper.load()
    parity = stepper.advance(buffers, 0, status, steps, use_graph=graph)   # warm-up (and graph capture)
    wp.synchronize_device(m.device)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        parity = stepper.advance(buffers, parity, status, steps, use_graph=graph)
        wp.synchronize_device(m.device)
        times.append(time.perf_counter() - start)
    return statistics.median(times) / steps


def cache_path() -> Path:
    """Where calibrations are remembered (``$HERTZIAN_CACHE`` or ``~/.cache/hertzian/calibration.json``)."""
    return Path(os.environ.get("HERTZIAN_CACHE", Path.home() / ".cache" / "hertzian" / "calibration.json"))


def _cache_key(model: Model) -> str:
    c = model.chain_count
    bucket = 1 << max(0, math.ceil(math.log2(c)))       # chain counts within a factor 2 share a choice
    return json.dumps([CALIBRATION_VERSION, wp.__version__, model.device.name, asdict(model.features),
                       model.grain_count, bucket])


def _read_cache() -> dict:
    try:
        return json.loads(cache_path().read_text())
    except (OSError, ValueError):
        return {}


def _write_cache(entries: dict) -> None:
    path = cache_path()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp")
        tmp.write_text(json.dumps(entries, indent=1))
        tmp.replace(path)
    except OSError:
        pass  # a read-only home only costs a re-calibration


def calibrate(model: Model, *, plans: list[TilePlan] | None = None, steps: int | None = None,
              buffers: tuple[State, State] | None = None, log=None) -> tuple[TilePlan, list[tuple[TilePlan, float]]]:
    """Time candidate fused shapes on ``model`` and return (fastest plan, [(plan, seconds per step)]).

    ``buffers``: two state buffers to time on (overwritten); default: fresh copies of the initial state.
    """
    if plans is None:
        plans = whole_chain_plans(model)
        if not plans or model.chain_count < _sm_count(model) or model.grain_count > 1024:
            plans = plans + window_plans(model)
    buffers = buffers or (model.initial_state(), model.state())
    results, failures = [], []
    for plan in plans:
        k = plan.steps_per_launch
        n_steps = steps or k * max(2, -(-256 // k))
        try:
            seconds = time_stepper(TileStepper(model, plan), steps=n_steps, buffers=buffers)
        except Exception as err:  # a shape the device refuses (registers, shared memory) is skipped
            failures.append(f"{plan.describe()}: {type(err).__name__}: {err}")
            if log:
                log(f"  {failures[-1]}")
            continue
        results.append((plan, seconds))
        if log:
            log(f"  {plan.describe()}: {model.chain_count * model.grain_count / seconds:.3g} grain-steps/s")
    if not results:
        raise RuntimeError("no fused launch shape ran on this device: " + "; ".join(failures))
    best = min(results, key=lambda r: r[1])[0]
    return best, results


def calibrated_plan(model: Model, *, buffers: tuple[State, State] | None = None, log=None) -> TilePlan:
    """The cached calibration for this model's (device, features, grains, chain-count bucket); calibrate once."""
    entries = _read_cache()
    key = _cache_key(model)
    if key in entries:
        try:
            e = entries[key]
            return TilePlan(TileShape(**e["shape"]), e["steps_per_launch"], e["interior"], e["ghost"],
                            e["blocks_per_chain"], e["blocks_per_chain"] * model.chain_count
                            if e["shape"]["windowed"] else -(-model.chain_count // e["shape"]["chains_per_block"]))
        except (KeyError, TypeError):
            pass
    best, _ = calibrate(model, buffers=buffers, log=log)
    entries = _read_cache()
    entries[key] = {"shape": asdict(best.shape), "steps_per_launch": best.steps_per_launch,
                    "interior": best.interior, "ghost": best.ghost, "blocks_per_chain": best.blocks_per_chain}
    _write_cache(entries)
    return best


def make_stepper(model: Model, kernel: str = "auto", *, run_steps: int | None = None, calibrate_now: bool = True,
                 buffers: tuple[State, State] | None = None, log=None) -> MultiStepper | None:
    """The fused stepper to use for ``model``, or None for the per-step kernel.

    ``kernel`` is one of KERNELS; a forced kernel that cannot run these features raises ValueError.
    ``run_steps`` (steps of the run) lets ``auto`` keep short runs on the per-step kernel. ``buffers``: two
    state buffers a calibration may overwrite (default: fresh ones).
    """
    if kernel not in KERNELS:
        raise ValueError(f"kernel = {kernel!r}: one of {', '.join(KERNELS)}")
    f = model.features
    if kernel == "step":
        return None
    if kernel == "sweep":
        if not model.device.is_cpu:
            raise ValueError("kernel = 'sweep': a CPU kernel; use --device cpu")
        if not sweepable(f):
            raise ValueError(f"kernel = 'sweep': no drive and no traces (features {f})")
        return SweepStepper(model)
    if kernel in ("tile", "window"):
        if not fusable(f):
            raise ValueError(f"kernel = {kernel!r}: no drive and no traces (features {f})")
        plans = whole_chain_plans(model) if kernel == "tile" else window_plans(model)
        if not plans:
            raise ValueError(f"kernel = {kernel!r}: no launch shape fits {model.grain_count} grains")
        if model.device.is_cuda and calibrate_now and len(plans) > 1:
            return TileStepper(model, calibrate(model, plans=plans, buffers=buffers, log=log)[0])
        return TileStepper(model, plans[0])
    # auto
    if not fusable(f):
        return None
    work = model.chain_count * model.grain_count * (run_steps if run_steps is not None else math.inf)
    if model.device.is_cpu:
        return SweepStepper(model) if work >= AUTO_MIN_GRAIN_STEPS_CPU else None
    if work < AUTO_MIN_GRAIN_STEPS_GPU:
        return None
    plan = calibrated_plan(model, buffers=buffers, log=log) if calibrate_now else default_plan(model)
    return TileStepper(model, plan)


def states_equal(a: np.ndarray, b: np.ndarray) -> float:
    """Largest |a − b| relative to the largest |b| (0 when bitwise equal)."""
    scale = float(np.max(np.abs(b))) or 1.0
    return float(np.max(np.abs(a - b))) / scale
