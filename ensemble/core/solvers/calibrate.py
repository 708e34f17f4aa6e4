"""Which solver steps an ensemble, and in what launch shape: a short measured calibration, cached.

This module only *chooses* a :class:`SolverConfig` (and remembers the choice); the solvers
themselves are in this package's ``step``, ``tile`` and ``chain`` modules. Kinds (``--kernel``):

* ``step`` — one Gear/Verlet step per launch over (chain, grain) (``kernels/step.py``): every feature,
  memory-bound on GPUs (the whole state through device memory every step).
* ``tile`` — whole chains in one block, K steps per launch (``kernels/tile.py``), CUDA.
* ``window`` — long chains cut into blocks with ghost zones, K ≤ ghost steps per launch
  (``kernels/tile.py`` + ``kernels/ghost.py``), CUDA.
* ``chain`` — one CPU thread per chain, many steps per launch (``kernels/cpu.py``).
* ``auto`` — per-step for features the fused kernels lack (see :func:`step_reason`); on a CPU the cheaper of
  ``chain`` and ``step`` counting the compile of a kernel not in Warp's kernel cache (:func:`cpu_auto_config`),
  and on a GPU the fastest of a few ``tile``/``window`` shapes, timed once per (device, features, grains,
  chains) and remembered in ``$HERTZIAN_CACHE`` (default ``~/.cache/hertzian/calibration.json``). A GPU run
  shorter than AUTO_MIN_GRAIN_STEPS_GPU is not timed: it takes the cached shape, else :func:`default_config`.
* ``fused`` — ``auto`` that calibrates short runs too (the first run of a shape on a GPU times its candidates,
  later ones read the cache).

Every fused kernel reproduces the per-step kernel's arithmetic (tests/kernels/test_tile.py,
tests/kernels/test_chain_kernel.py), so the choice changes speed, not results.
"""

from __future__ import annotations

import json
import math
import os
import statistics
import time
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
import warp as wp
from hertzian.core.model import Model, State
from hertzian.core.solvers.compile import in_cache, load_variants, solver_variants
from hertzian.core.solvers.config import CHAIN, STEP, SolverConfig
from hertzian.core.solvers.tile import TileSolver, config_of
from hertzian.kernels.cpu import chain_kernel, chain_kernel_supports
from hertzian.kernels.features import SUBSTEP_WEIGHTS
from hertzian.kernels.step import step_kernel
from hertzian.kernels.tile import fusable, plan_tile

KERNELS = ("auto", "fused", "step", "tile", "window", "chain")

AUTO_MIN_GRAIN_STEPS_GPU = 5e9
"""Below this many grain-steps in a run, ``auto`` on a GPU does not calibrate (tens of seconds the first time): it
takes the shape the calibration cache holds for the model, else :func:`default_config`."""
CALIBRATION_VERSION = 4
"""Bumped when the cached fields change (2: a SolverConfig; 3: the event step out of line by default; 4: one-warp
windows among the candidates)."""


CPU_COSTS = {"step": (4.40, 8.33e6), "chain": (4.97, 1.29e8)}
"""(compile seconds on a cold Warp cache, warm rate [grain-steps/s]) of the CPU stepping kernels: the example
scene at 200 grains on the 2-core machine (docs/records/bench/cpu_auto_rule.json, ``kernel_costs``; regenerated
by ``python -m hertzian.studies.fixed_costs``). The CPU ``auto`` rule (:func:`cpu_auto_config`) reads them: the
chain kernel is the cheaper from 5.2e6 grain-steps on a cold cache and from 4.4e7 where only the per-step kernel
is cached (:func:`cpu_crossovers`)."""


def stepping_features(features):
    """The features that decide whether a fused kernel can run a model: traces never do (every kernel writes
    its trace samples inside its launch)."""
    return replace(features, traces=False)


def fused_lacks(features, is_cpu: bool) -> str | None:
    """The feature the device's fused kernel (CPU chain kernel, CUDA tile/window) lacks, or None."""
    f = stepping_features(features)
    if f.damping == "contact" and f.compensation and not is_cpu:
        return "damping (damping.model = 'contact' in compensated float32; only the per-step kernel carries it on CUDA)"
    if f.method in SUBSTEP_WEIGHTS and not is_cpu:
        return f"method {f.method} (its substeps are in the per-step and CPU chain kernels only)"
    if is_cpu:
        return None if chain_kernel_supports(f) else f"features {f}"
    return None if fusable(f) else f"features {f}"


def step_reason_of(features, is_cpu: bool, grain_steps: float) -> str | None:
    """Why ``auto`` picks the per-step kernel for a run of ``grain_steps`` (one line), or None. Only a feature
    the fused kernel lacks does: on a CPU the chain kernel is faster than the per-step kernel, its compile
    included, from the shortest runs up (docs/fixed-costs.md, docs/records/bench/cpu_auto_rule.json); on a GPU a
    short run takes a fused kernel of a cached or default shape (:func:`choose_config`)."""
    lacks = fused_lacks(features, is_cpu)
    if lacks:
        return f"the {'chain' if is_cpu else 'tile/window'} kernel lacks {lacks}"
    return None


def event_cost_note(features, is_cpu: bool) -> str | None:
    """One line when a CUDA run carries event-aware steps (a contact can open, ``integrator.events = "auto"``),
    which cost the fused kernels several times the time of plain steps, the more contacts open (docs/stability.md
    §6c and §7c, record docs/records/bench/h100_events.json); None otherwise."""
    if is_cpu or features.event_window <= 0:
        return None
    return (
        'event-aware steps are compiled in (a contact can open; integrator.events = "auto"): on CUDA they '
        "cost the fused kernel 1.7-11x the time of plain steps, the more contacts open (docs/benchmarks.md, "
        'docs/stability.md 6c, 7c); integrator.events = "off" takes plain Gear steps'
    )


def cpu_kernel_config(kind: str) -> SolverConfig:
    """The SolverConfig of a CPU stepping kernel kind (``step`` or ``chain``)."""
    return CHAIN if kind == "chain" else STEP


def in_kernel_cache(module, device) -> bool:
    """Whether the Warp ``module`` is loaded on the CPU ``device`` or compiled in Warp's kernel cache (its object
    file for CPU launches, block 1), so that loading it compiles nothing."""
    return in_cache(module, device, 1)


def cpu_seconds(kind: str, grain_steps: float, cached: bool, costs: dict = CPU_COSTS) -> float:
    """Estimated seconds [s] of a CPU run of ``grain_steps`` on kernel ``kind``: its compile unless ``cached``,
    plus the work at its warm rate (``costs``: kind → (compile seconds, grain-steps/s))."""
    compile_s, rate = costs[kind]
    return (0.0 if cached else compile_s) + grain_steps / rate


def cpu_crossovers(costs: dict = CPU_COSTS) -> dict[str, float]:
    """Grain-steps above which the chain kernel is cheaper than the per-step kernel, uncached: when neither is
    cached (``none_cached``) and when the per-step one is (``step_cached``); 0 when always, inf when never."""
    (c_step, r_step), (c_chain, r_chain) = costs["step"], costs["chain"]
    gain = 1.0 / r_step - 1.0 / r_chain  # seconds saved per grain-step on the chain kernel
    out = {}
    for name, extra in (("none_cached", c_chain - c_step), ("step_cached", c_chain)):
        out[name] = 0.0 if extra <= 0 else (extra / gain if gain > 0 else math.inf)
    return out


def cpu_auto_config(features, grain_steps: float, device, costs: dict = CPU_COSTS) -> SolverConfig:
    """``auto`` on a CPU for features the chain kernel supports: the kernel of the fewer estimated seconds
    (:func:`cpu_seconds`), a kernel in Warp's kernel cache counting no compile; the chain kernel on a tie. So a
    cached chain kernel always runs, and a short run on a cold cache takes whichever compiles and runs sooner."""
    if math.isinf(grain_steps) or in_kernel_cache(chain_kernel(features).module, device):
        return CHAIN
    step_cached = in_kernel_cache(step_kernel(features).module, device)
    chain_s = cpu_seconds("chain", grain_steps, False, costs)
    return STEP if cpu_seconds("step", grain_steps, step_cached, costs) < chain_s else CHAIN


def step_reason(model: Model, run_steps: int | None = None) -> str | None:
    """Why ``auto`` picks the per-step kernel for ``model`` (one line), or None when it picks a fused one."""
    work = model.chain_count * model.grain_count * (run_steps if run_steps is not None else math.inf)
    return step_reason_of(model.features, model.device.is_cpu, work)


def is_calibrated(model: Model) -> bool:
    """Whether the calibration cache holds a choice for this model's (device, features, grains, chain-count
    bucket)."""
    return _cache_key(model) in _read_cache()


# ---- candidate launch shapes ----------------------------------------------------------------------

REGISTERS = {2: 96, 4: 128, 8: 232, 16: 255}
"""Registers per thread of the gear4 float64 fused kernel for G grains per lane, padded/windowed variants
(ptxas for sm_90 reports 122, 216 and 255 for the plain variants at G = 4, 8, 16; G = 2 is an estimate, used
only for one-warp windows, where any count fits; launches of 264 lanes at G = 8 and 528 at
G = 4 were refused on the H100, so windowed variants use a little more)."""


def _fits(lanes: int, G: int, registers: int = 65536) -> bool:
    """Whether a block of ``lanes`` threads at G grains per lane fits in ``registers`` (whole warps count)."""
    return -(-lanes // 32) * 32 * REGISTERS[G] <= registers


def _sm_count(model: Model) -> int:
    return (getattr(model.device, "sm_count", 0) or 1) if model.device.is_cuda else 1


def whole_chain_configs(model: Model) -> list[SolverConfig]:
    """Whole-chain shapes worth timing for this model (block ≤ 1024 threads, registers permitting)."""
    f, n, c = model.features, model.grain_count, model.chain_count
    plans = []
    # event-aware steps: G = 16 and a 168-register cap spill the event kernel (sm_90, ptxas: 3.9 kB of spill stores
    # at G = 16), so only G = 8 and 4 are timed
    shapes = ((8, 0), (4, 0)) if f.event_window > 0 else ((8, 0), (4, 0), (8, 168), (16, 0))
    for G, regs in shapes:
        lanes = -(-n // G)
        if -(-lanes // 32) * 32 * (regs or REGISTERS[G]) > 65536:
            continue
        per_block = 1
        while per_block * 2 * lanes <= 128 and per_block * 2 <= c:
            per_block *= 2  # short chains: several per block, blocks of ≥ 64–128 threads
        for cpb in sorted({1, per_block}):
            try:
                plans.append(
                    config_of(
                        plan_tile(
                            f, n, c, grains_per_lane=G, chains_per_block=cpb, steps_per_launch=64, max_registers=regs
                        )
                    )
                )
            except ValueError:
                pass
    return plans


ONE_WARP_WINDOWS = ((4, 32), (4, 16), (2, 16))
"""(G, K) of the one-warp windows timed for few chains: 32 lanes, so a step waits for no other warp."""


def window_configs(model: Model) -> list[SolverConfig]:
    """Windowed shapes worth timing: with many chains the fewest blocks per chain that fit an SM, or two per SM
    (G = 4 or 8, K = 32 or 64); with few chains, enough blocks to fill the GPU, or half as many, or two per SM
    where those fill it (G = 4, K = 16 or 32), and windows of one warp (ONE_WARP_WINDOWS), whose step is the shortest: a few chains are
    latency-bound, one step after another."""
    f, n, c = model.features, model.grain_count, model.chain_count
    sms = _sm_count(model)
    plans = []
    many = c >= sms
    for G in (8, 4) if many else (4,):
        for K in (32, 64) if many else (16, 32):
            b_max = n // (2 * K)  # keep the interior at least twice the ghost zone
            b_min = 2
            while b_min <= b_max and not _fits(-(-(-(-n // b_min) + 2 * K) // G), G):
                b_min += 1
            if b_min > b_max:
                continue
            b_fill = min(b_max, max(b_min, -(-2 * sms // c)))
            b_mid = max(b_min, min(b_fill, round(math.sqrt(b_min * b_fill))))
            b_two = b_min  # two blocks per SM: half an SM's registers per block
            while b_two < b_max and not _fits(-(-(-(-n // b_two) + 2 * K) // G), G, 32768):
                b_two += 1
            few_blocks = {b_mid, b_fill} | ({b_two} if b_two * c >= sms else set())  # two blocks an SM, if they fill it
            for b in sorted({b_min, b_two} if many else few_blocks):
                interior = -(-n // b)
                lanes = -(-(interior + 2 * K) // G)
                try:
                    plans.append(
                        config_of(
                            plan_tile(
                                f, n, c, grains_per_lane=G, lanes_per_chain=lanes, steps_per_launch=K, windowed=True
                            )
                        )
                    )
                except ValueError:
                    pass
    if not many:
        for G, K in ONE_WARP_WINDOWS:
            if (
                32 * G - 2 * K >= K and 32 * G < n
            ):  # an interior of at least the ghost zone; a chain too long for one warp
                try:
                    plans.append(
                        config_of(
                            plan_tile(f, n, c, grains_per_lane=G, lanes_per_chain=32, steps_per_launch=K, windowed=True)
                        )
                    )
                except ValueError:
                    pass
    return list(dict.fromkeys(plans))


def default_config(model: Model) -> SolverConfig:
    """A shape chosen without timing: whole chains when they fill the GPU, else windows."""
    n, c = model.grain_count, model.chain_count
    sms = getattr(model.device, "sm_count", 132) or 132
    whole = [p for p in whole_chain_configs(model) if p.shape.max_registers == 0]
    if n <= 1024 and c >= 2 * sms and whole:
        return whole[0]
    windows = window_configs(model)
    if windows:
        return windows[0]
    return whole[0]


# ---- measuring --------------------------------------------------------------------------------------


def time_solver(solver, *, steps: int, repeats: int = 3, states: tuple[State, State] | None = None) -> float:
    """Median seconds per step of ``solver`` (warm-up excluded), on ``states`` or a scratch pair made from the
    model's initial state (the content is overwritten)."""
    m = solver.model
    pair = states or m.state_pair()
    solver.load()

    def advance(current: State) -> State:
        return solver.advance(current, pair[1] if current is pair[0] else pair[0], steps)

    current = advance(pair[0])  # warm-up (and graph capture)
    wp.synchronize_device(m.device)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        current = advance(current)
        wp.synchronize_device(m.device)
        times.append(time.perf_counter() - start)
    return statistics.median(times) / steps


def cache_path() -> Path:
    """Where calibrations are remembered (``$HERTZIAN_CACHE`` or ``~/.cache/hertzian/calibration.json``)."""
    return Path(os.environ.get("HERTZIAN_CACHE", Path.home() / ".cache" / "hertzian" / "calibration.json"))


def _cache_key(model: Model) -> str:
    c = model.chain_count
    bucket = 1 << max(0, math.ceil(math.log2(c)))  # chain counts within a factor 2 share a choice
    return json.dumps(
        [CALIBRATION_VERSION, wp.__version__, model.device.name, asdict(model.features), model.grain_count, bucket]
    )


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


def calibrate(
    model: Model,
    *,
    configs: list[SolverConfig] | None = None,
    steps: int | None = None,
    states: tuple[State, State] | None = None,
    log=None,
) -> tuple[SolverConfig, list[tuple[SolverConfig, float]]]:
    """Time candidate fused shapes on ``model`` and return (fastest config, [(config, seconds per step)]).

    ``states``: a state pair to time on (overwritten); default: a fresh pair from the initial state.
    """
    if configs is None:
        configs = whole_chain_configs(model)
        if not configs or model.chain_count < _sm_count(model) or model.grain_count > 1024:
            configs = configs + window_configs(model)
    states = states or model.state_pair()
    try:  # every candidate compiled at once before the first is timed
        load_variants(
            [v for c in configs for v in solver_variants(c, model.features, model.grain_count, model.chain_count)],
            model.device,
        )
    except Exception:  # noqa: BLE001 - a candidate that fails to build fails again below, where it is reported
        pass
    results, failures = [], []
    for config in configs:
        k = config.steps_per_launch
        n_steps = steps or k * max(2, -(-256 // k))
        try:
            solver = TileSolver(model, config)
            seconds = time_solver(solver, steps=n_steps, states=states)
        except Exception as err:  # a shape the device refuses (registers, shared memory) is skipped
            failures.append(f"{config.describe()}: {type(err).__name__}: {err}")
            if log:
                log(f"  {failures[-1]}")
            continue
        results.append((config, seconds))
        if log:
            log(f"  {solver.describe()}: {model.chain_count * model.grain_count / seconds:.3g} grain-steps/s")
    if not results:
        raise RuntimeError("no fused launch shape ran on this device: " + "; ".join(failures))
    best = min(results, key=lambda r: r[1])[0]
    return best, results


def cached_config(model: Model) -> SolverConfig | None:
    """The calibration cache's choice for this model's (device, features, grains, chain-count bucket), or None."""
    entry = _read_cache().get(_cache_key(model))
    if entry is None:
        return None
    try:
        return SolverConfig.from_dict(entry)
    except (KeyError, TypeError, ValueError):
        return None


def calibrated_config(model: Model, *, states: tuple[State, State] | None = None, log=None) -> SolverConfig:
    """The cached calibration for this model's (device, features, grains, chain-count bucket); calibrate once."""
    cached = cached_config(model)
    if cached is not None:
        return cached
    key = _cache_key(model)
    best, _ = calibrate(model, states=states, log=log)
    entries = _read_cache()
    entries[key] = best.to_dict()
    _write_cache(entries)
    return best


def choose_config(
    model: Model,
    kernel: str = "auto",
    *,
    run_steps: int | None = None,
    calibrate_now: bool = True,
    states: tuple[State, State] | None = None,
    log=None,
) -> SolverConfig:
    """The SolverConfig to use for ``model``.

    ``kernel`` is one of KERNELS; a forced kind that cannot run these features raises ValueError.
    ``run_steps`` (steps of the run) lets ``auto`` keep short runs on the per-step solver. ``states``:
    a state pair a calibration may overwrite (default: a fresh one).
    """
    if kernel not in KERNELS:
        raise ValueError(f"kernel = {kernel!r}: one of {', '.join(KERNELS)}")
    f = model.features
    if kernel == "step":
        return STEP
    if f.damping == "contact" and f.compensation:
        # the contact dashpot in compensated float32 exists in the per-step kernel and the CPU chain kernel only
        if model.device.is_cpu:
            if kernel in ("tile", "window"):
                raise ValueError(
                    f"kernel = {kernel!r}: damping (damping.model = 'contact' in compensated float32) runs "
                    "only on the per-step and chain solvers; use --kernel step, chain or auto"
                )
        else:
            if kernel not in ("auto", "fused"):
                raise ValueError(
                    f"kernel = {kernel!r}: damping (damping.model = 'contact' in compensated float32) runs "
                    "only on the per-step solver; use --kernel step or auto"
                )
            return STEP
    if kernel == "chain":
        if not model.device.is_cpu:
            raise ValueError("kernel = 'chain': a CPU kernel; use --device cpu")
        if not chain_kernel_supports(stepping_features(f)):
            raise ValueError(f"kernel = 'chain': not implemented for features {f}")
        return CHAIN
    if kernel in ("tile", "window"):
        if f.method in SUBSTEP_WEIGHTS:
            raise ValueError(
                f"kernel = {kernel!r}: not implemented for integrator.method = {f.method!r}; use "
                f"--kernel step{', chain' if model.device.is_cpu else ''} or auto"
            )
        if not fusable(stepping_features(f)):
            raise ValueError(f"kernel = {kernel!r}: not implemented for surface = {f.surface!r} (features {f})")
        configs = whole_chain_configs(model) if kernel == "tile" else window_configs(model)
        if not configs:
            raise ValueError(f"kernel = {kernel!r}: no launch shape fits {model.grain_count} grains")
        if model.device.is_cuda and calibrate_now and len(configs) > 1:
            return calibrate(model, configs=configs, states=states, log=log)[0]
        return configs[0]
    if kernel == "fused":
        if fused_lacks(f, model.device.is_cpu):
            return STEP
        if model.device.is_cpu:
            return CHAIN
        return calibrated_config(model, states=states, log=log) if calibrate_now else default_config(model)
    # auto
    if step_reason(model, run_steps):
        return STEP
    work = model.chain_count * model.grain_count * (run_steps if run_steps is not None else math.inf)
    if model.device.is_cpu:
        return cpu_auto_config(f, work, model.device)
    if work < AUTO_MIN_GRAIN_STEPS_GPU:  # short: no calibration, a shape timed before or the default one
        return cached_config(model) or default_config(model)
    return calibrated_config(model, states=states, log=log) if calibrate_now else default_config(model)


def states_equal(a: np.ndarray, b: np.ndarray) -> float:
    """Largest |a − b| relative to the largest |b| (0 when bitwise equal)."""
    scale = float(np.max(np.abs(b))) or 1.0
    return float(np.max(np.abs(a - b))) / scale
