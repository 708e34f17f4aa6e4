"""Soliton spectroscopy: locate and identify a buried impurity from the surface grain's velocity.

The measurement is the velocity ``v(t)`` of grain 0 after an impact at t = 0, sampled uniformly.
The host chain without impurities (BASE) is known. The unknowns are the class (``none``, ``light``,
``heavy``), the depth ``d`` (index of the impurity grain; of the first grain of a block of ``block``
grains) and the mass ratio ``μ = m_impurity / m_host`` (self-constant a as the host's; with ``fit_a``
also ``a / a_host``, fitted at the depth found and its neighbours: :func:`fit_contact`).

**Forward model.** BASE plus one impurity block at depth d with mass μ·m, impact at grain 0, grain 0's
velocity traced at exactly the signal's sample times: the step is the largest ``dt' ≤ dt_BASE`` that
divides the sample spacing (no interpolation). A whole library of candidate chains (depth × mass
ratio, coarse) is one ensemble run (:func:`hertzian.core.runner.run_ensemble`), cached per BASE under
``$HERTZIAN_DETECT_CACHE`` (default ``~/.cache/hertzian/detect/``).

**Window.** The samples up to the return of the pulse reflected by the bottom, ``t ≤ 2 t_front(N − 1)``,
are analysed (``window`` to change it), where ``t_front(d)`` is the time the pulse front (``v_d > 1e-4
v_imp``) reaches grain d in the BASE chain's own clean run. After that time the surface signal is
dominated by the bottom reflection, whose timing depends so strongly on the impurity that the
likelihood becomes rugged in μ. Depths whose echo cannot start inside the window are not searched.

**Fine scan.** If the refined best fit still leaves σ above FINE_SCAN_MISFIT times the noise (σ before the
earliest echo, or ``noise``), its minimum may be a needle narrower than the library's and Gauss–Newton's steps
(a light grain next to the impact, whose collision sequence changes with μ): ln μ is then scanned every
FINE_SCAN_SPACING over the class's range at that depth (one ensemble run) and refined by Gauss–Newton from the
best point; the lower RSS is kept (``Detection.fine_scan`` says what ran). If the fit is still poor, both classes
are scanned more coarsely (WIDE_SCAN_SPACING) at the depths within WIDE_SCAN_DEPTHS grains, and the best (class,
depth) of that scan is scanned finely in turn (``fine_scan["wide"]``).

**Noise model.** i.i.d. Gaussian noise of standard deviation σ: ``--noise σ``, or estimated twice. First
as the rms of ``v − v_clean`` over the samples before the earliest possible echo, ``t < 2 t_front(d_min)``
(``d_min`` the shallowest depth searched; an echo cannot return faster than the pulse that causes it
travels out), or, when fewer than NOISE_MIN_SAMPLES samples precede it, from the best library
candidate's residual; this σ picks the depths to refine. Then from every sample, ``RSS_best / (S − 2)``
of the best candidate after refinement; the posterior uses this one.

**Posterior.** Likelihood ∝ exp(−‖v − v_model‖² / 2σ²); priors: the three classes equally likely,
depth uniform over the searched depths, ``x = ln μ`` uniform over ``[ln μ_min, 0)`` (light) or
``(0, ln μ_max]`` (heavy); ``none`` is the clean chain. For each depth and class the residual sum of
squares is modelled as a quadratic in x (Gauss–Newton: ``RSS(x) ≈ RSS(x0) − 2 J·r (x − x0) + J·J (x − x0)²``
with ``J = ∂v/∂x``), integrated in closed form over the class's range (a truncated Gaussian). From the
library, x0 is the best of the traces interpolated in x (local cubic through the library's ratios and
the clean chain at x = 0) and J the interpolant's derivative; the best ``refine`` depths of each class are
then refined by Gauss–Newton with J by central differences, each iteration one more ensemble run of
three chains per candidate (x0 − h, x0, x0 + h). Class probabilities are the normalised class evidences;
the depth is the posterior mode, with the central 95 % interval of the depth posterior; the mass
ratio is exp(x) at the mode's Gauss–Newton optimum, with the central 95 % interval of the class's
posterior over x (a mixture over depths of truncated Gaussians).

Units: program units (time 1.0102e-3 s, length 1e-5 m), as the scenes.
"""

from __future__ import annotations

import csv
import functools
import hashlib
import json
import math
import os
import shutil
import tempfile
import time
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from hertzian.core.scene import ImpuritySpec, Scene, SceneError

CLASSES = ("none", "light", "heavy")
FRONT_THRESHOLD = 1e-4
"""The pulse front reaches a grain when its velocity first exceeds this fraction of v_imp."""
NOISE_MIN_SAMPLES = 8
"""Fewest samples before the earliest possible echo from which σ is estimated."""
CREDIBLE = 0.95
"""Probability inside the reported intervals."""
LIBRARY_VERSION = 2
"""Bumped when the cached library's content or layout changes (2: a directory of ``.npy`` files holding the
echoes and their Gram matrices; version 1's ``.npz`` files are not read)."""


# ---- the signal ------------------------------------------------------------------------


@dataclass(frozen=True)
class Signal:
    """Surface grain velocity sampled uniformly from the impact at t = 0 (program units)."""

    t: np.ndarray
    """Sample times [time], shape (S,), t[0] = 0, uniform spacing."""
    v: np.ndarray
    """Velocity of grain 0 [length/time], positive toward the bottom, shape (S,)."""
    source: str = ""

    @property
    def spacing(self) -> float:
        """Sample spacing [time]."""
        return float(self.t[1] - self.t[0])

    @property
    def sample_count(self) -> int:
        return int(self.t.size)


def signal_from_arrays(t, v, source: str = "signal") -> Signal:
    """Check and wrap sampled data: finite, at least 3 samples, uniform t from 0 (relative 1e-6)."""
    t = np.asarray(t, dtype=np.float64).ravel()
    v = np.asarray(v, dtype=np.float64).ravel()
    if t.size != v.size:
        raise SceneError(source, f"{t.size} times, {v.size} values", "t and v must have the same length")
    if t.size < 3:
        raise SceneError(source, f"{t.size} samples", "needs at least 3 samples")
    for name, values in (("t", t), ("v", v)):
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise SceneError(f"{source}: {name}[{bad[0]}]", float(values[bad[0]]), "values must be finite numbers")
    spacing = (t[-1] - t[0]) / (t.size - 1)
    if not spacing > 0:
        raise SceneError(f"{source}: t", f"{t[0]} … {t[-1]}", "times must increase")
    steps = np.diff(t)
    worst = int(np.argmax(np.abs(steps - spacing)))
    if abs(steps[worst] - spacing) > 1e-6 * spacing:
        raise SceneError(
            f"{source}: t[{worst + 1}] − t[{worst}]",
            float(steps[worst]),
            f"samples must be uniform (spacing {spacing:.6g}, tolerance 1e-6 relative)",
        )
    if abs(t[0]) > 1e-6 * spacing:
        raise SceneError(f"{source}: t[0]", float(t[0]), "the signal must start at the impact, t = 0")
    return Signal(t=np.arange(t.size) * spacing, v=v, source=source)


def read_signal(path: str | Path) -> Signal:
    """A CSV file with the header ``t,v``, or a hertzian store (Zarr) with a trace of grain 0."""
    path = Path(path)
    if not path.exists():
        raise SceneError("SIGNAL", str(path), "no such file or store")
    if path.is_dir():
        return _signal_from_store(path)
    try:
        with path.open(newline="") as handle:
            rows = list(csv.reader(handle))
    except (OSError, UnicodeDecodeError) as err:
        raise SceneError("SIGNAL", str(path), f"cannot be read as a CSV text file ({err.__class__.__name__})") from None
    rows = [row for row in rows if row and any(cell.strip() for cell in row)]
    if not rows:
        raise SceneError("SIGNAL", str(path), "is empty; expected a header line t,v and samples")
    header = [cell.strip().lower() for cell in rows[0]]
    if header != ["t", "v"]:
        raise SceneError(f"{path}: header", ",".join(rows[0]), "the first line must be the header t,v")
    t, v = [], []
    for number, row in enumerate(rows[1:], start=2):
        if len(row) != 2:
            raise SceneError(f"{path}: line {number}", ",".join(row), "must hold two numbers t,v")
        try:
            t.append(float(row[0]))
            v.append(float(row[1]))
        except ValueError:
            raise SceneError(f"{path}: line {number}", ",".join(row), "must hold two numbers t,v") from None
    return signal_from_arrays(t, v, source=str(path))


def _signal_from_store(path: Path) -> Signal:
    from hertzian.sweeping.store import open_store

    try:
        group = open_store(path)
    except (ValueError, FileNotFoundError, OSError) as err:
        raise SceneError("SIGNAL", str(path), f"is not a hertzian store ({err})") from None
    members = set(group.array_keys())
    if not {"trace_t", "trace_v", "traced_grain"} <= members:
        raise SceneError("SIGNAL", str(path), "the store has no traces (record.traces = [0] in its scene)")
    traced = list(np.asarray(group["traced_grain"][...]))
    if 0 not in traced:
        raise SceneError("SIGNAL", str(path), f"the store traces grains {traced}, not grain 0")
    data = np.asarray(group["trace_v"][...])
    if data.ndim != 2 and int(np.prod(data.shape[:-2])) != 1:
        raise SceneError(
            "SIGNAL", str(path), f"the store holds {int(np.prod(data.shape[:-2]))} points; give a store of one run"
        )
    data = data.reshape(data.shape[-2:])
    return signal_from_arrays(np.asarray(group["trace_t"][...]), data[:, traced.index(0)], source=str(path))


def write_signal_csv(path: str | Path, signal: Signal) -> None:
    """Write a signal as CSV with the header ``t,v`` (full float64 precision)."""
    with Path(path).open("w") as handle:
        handle.write("t,v\n")
        for t, v in zip(signal.t, signal.v):
            handle.write(f"{float(t)!r},{float(v)!r}\n")


# ---- forward model ------------------------------------------------------------------------


def check_base(base: Scene) -> None:
    """BASE must be an impact on a chain without impurities (the host chain)."""
    if base.impurities:
        raise SceneError("BASE impurities", len(base.impurities), "the host chain must have no impurities")
    if base.boundary.surface == "driven" or not base.excitation.impact > 0:
        raise SceneError(
            "BASE excitation.impact", base.excitation.impact, "detection needs an impact (> 0) at grain 0, not a drive"
        )


def forward_scene(base: Scene, spacing: float, sample_count: int) -> Scene:
    """BASE set up to trace grain 0's velocity at t = k·spacing, k = 0 … sample_count − 1.

    The step becomes spacing / ceil(spacing / dt_BASE) (≤ BASE's dt) so that samples fall on steps.
    """
    check_base(base)
    steps_per_sample = max(1, math.ceil(spacing / base.integrator.dt * (1 - 1e-9)))
    dt = spacing / steps_per_sample
    duration = spacing * (sample_count - 1)
    return base.with_overrides(
        {
            "integrator.dt": dt,
            "integrator.duration": duration,
            "record.every": duration,
            "record.fields": [],
            "record.traces": [0],
            "record.trace_every": spacing,
            "record.energy": True,
        }
    )


def impurity_scene(forward: Scene, depth: int, mass_ratio: float, block: int = 1, a_ratio: float = 1.0) -> Scene:
    """``forward`` with grains depth … depth + block − 1 of mass mass_ratio · m_host and self-constant
    a_ratio · a_host (their contacts follow the scene's impurity rule: the harmonic mean of the two
    self-constants)."""
    grains = tuple(range(int(depth), int(depth) + int(block)))
    a = None if a_ratio == 1.0 else float(a_ratio) * forward.chain.a
    return replace(forward, impurities=(ImpuritySpec(grains=grains, mass=float(mass_ratio) * forward.chain.mass, a=a),))


def front_times(forward: Scene, device: str) -> np.ndarray:
    """When the pulse front reaches each grain in the clean chain [time], shape (N,); inf if never.

    One clean run tracing about 50 grains; the front is where v first exceeds FRONT_THRESHOLD · v_imp;
    grains in between are interpolated linearly.
    """
    from hertzian.core.devices import init_warp
    from hertzian.core.model import build_model
    from hertzian.core.runner import Runner

    n = forward.chain.grains
    stride = max(1, n // 50)
    traced = sorted(set(range(0, n, stride)) | {n - 1})
    init_warp()
    # the fused kernels, as the library's runs (``auto`` would take the per-step kernel for one chain's short run)
    model = build_model([replace(forward, record=replace(forward.record, traces=tuple(traced)))], device)
    result = Runner(model, kernel="fused", trace_values=("v",)).run()
    v = result.traces["v"][0]
    t = result.trace_t
    threshold = FRONT_THRESHOLD * forward.excitation.impact
    times = np.full(len(traced), np.inf)
    for k, grain in enumerate(traced):
        hit = np.flatnonzero(v[:, k] > threshold)
        times[k] = 0.0 if grain == 0 else (t[hit[0]] if hit.size else np.inf)
    finite = np.isfinite(times)
    out = np.full(n, np.inf)
    grains = np.asarray(traced)
    last = grains[finite][-1]
    out[: last + 1] = np.interp(np.arange(last + 1), grains[finite], times[finite])
    return out


# ---- the library --------------------------------------------------------------------------


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


LIBRARY_BATCH = {"cpu": 4096, "cuda": 16384}
"""Default chains per ensemble run of :func:`run_candidates`: a GPU needs many chains to be busy (a 1000-grain
library of ≈ 13 300 candidates is then one run, its traces ≈ 1.2 GB), the CPU chain kernel does not."""


def default_batch_size(device: str) -> int:
    return LIBRARY_BATCH["cuda" if str(device).startswith("cuda") else "cpu"]


def _prepare_candidates(forward: Scene, candidates: list[tuple], block: int):
    """The host half of one ensemble of candidates: (HostModel of a ChainStack, order) where ``order[i]`` is the
    candidate run as chain i, or (None, None) when the candidates need the per-scene path.

    Candidates of one depth and contact constant differ only in the impurity's mass, a per-chain scalar: each
    such group is one ChainSet (template: BASE with that impurity block, mass per chain), prepared with numpy
    over the group, the groups stacked (``hertzian.core.model.stack_prepared``): no scene per candidate,
    the same arrays as building every candidate's scene (``tests/test_detect.py`` checks the traces bit for
    bit). The clean chain joins the first group as mass ratio 1 (the kernel is the impurity chains' anyway).
    """
    from hertzian.core.chains import ChainSet
    from hertzian.core.model import prepare_model, stack_prepared

    groups: dict[tuple[int, float], list[tuple[int, float]]] = {}
    clean = []
    for index, candidate in enumerate(candidates):
        depth, mass_ratio, a_ratio = (*candidate, 1.0)[:3]
        if depth < 0 or (mass_ratio == 1.0 and a_ratio == 1.0):
            clean.append(index)
        else:
            groups.setdefault((int(depth), float(a_ratio)), []).append((index, float(mass_ratio)))
    if not groups:
        return None, None
    keys = list(groups)
    groups[keys[0]] = [(index, 1.0) for index in clean] + groups[keys[0]]
    parts, order = [], []
    movable: dict = {}  # group size → a prepared group (HostModel) whose impurity can move to another depth
    for depth, a_ratio in keys:
        members = groups[(depth, a_ratio)]
        template = impurity_scene(forward, depth, 1.0, block, a_ratio)
        masses = [mass_ratio * forward.chain.mass for _, mass_ratio in members]  # impurity_scene's arithmetic
        chains = ChainSet.of(template, {"impurities.0.mass": masses}, len(members))
        moved = movable.get(len(members))
        part = _moved_impurity(moved, chains, depth, block) if moved is not None else None
        if part is None:
            part = prepare_model(chains)
            if moved is None and _impurity_can_move(forward, depth, a_ratio):
                movable[len(members)] = part
        parts.append(part)
        order += [index for index, _ in members]
    if len({part.features for part in parts}) > 1:
        return None, None  # the groups need different kernels: one scene per candidate, one kernel for all
    return stack_prepared(parts), np.asarray(order)


def _impurity_can_move(forward: Scene, depth: int, a_ratio: float) -> bool:
    """Whether a block of the host's contact constant at ``depth`` changes nothing but its grains' masses in the
    prepared arrays: no gravity (the static forces, hence overlaps, are then the same on every contact whatever the
    masses) and below the grains that move at t = 0 (startup.taylor_window: the Taylor start reads only their
    masses), so that moving it to another such depth moves only its 1/m entries."""
    from hertzian.core.startup import taylor_window
    from hertzian.kernels.features import GEAR_VALUES

    window = taylor_window(forward.chain.grains, max(GEAR_VALUES.values()))  # every method's, at most
    return a_ratio == 1.0 and forward.chain.gravity == 0.0 and depth > window


def _moved_impurity(moved, chains, depth: int, block: int):
    """The HostModel of ``chains`` (one group: an impurity block at ``depth``, mass per chain) from ``moved``, a
    prepared group's HostModel, with the block moved — or None when the impurity cannot move there
    (:func:`_impurity_can_move`) or the masses differ in number. Every array but 1/m is the prepared group's; 1/m is
    1/m_host outside the block (the prepared group's own value) and 1.0 / mass in it, numpy's division as in
    prepare_model: the same bits as preparing the group (``tests/test_detect.py`` compares the traces)."""
    import dataclasses

    part = moved
    if (
        len(chains) != len(part.chains)
        or not _impurity_can_move(chains.template, depth, 1.0)
        or chains.template.impurities[0].a is not None
    ):
        return None
    inverse = part.arrays["inverse_mass"]
    new_inverse = np.repeat(inverse[:, :1], inverse.shape[1], axis=1)  # grain 0 is the host's (above the window)
    mass = chains.values["impurities.0.mass"]
    new_inverse[:, depth : depth + block] = (1.0 / mass)[:, None].astype(inverse.dtype)
    return dataclasses.replace(part, chains=chains, arrays={**part.arrays, "inverse_mass": new_inverse}, seconds=0.0)


def run_candidates(
    forward: Scene, candidates: list[tuple], block: int, device: str, *, batch_size: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Surface traces of candidate (depth, mass ratio[, a ratio]) chains (ensembles of ≤ batch_size chains,
    default :data:`LIBRARY_BATCH` of the device).

    Returns (traces (C, S), ok (C,)); a depth < 0, or mass ratio 1 with a ratio 1, means the clean chain.
    The next batch is prepared on the host (numpy, :func:`_prepare_candidates`) while the current one runs.
    """
    from concurrent.futures import ThreadPoolExecutor

    from hertzian.core.devices import init_warp
    from hertzian.core.model import build_model
    from hertzian.core.runner import Runner
    from hertzian.core.status import Status

    init_warp()
    if batch_size is None:
        batch_size = default_batch_size(device)
    count = len(candidates)
    traces = np.empty((count, forward.trace_sample_count)) if count > batch_size else None
    ok = np.empty(count, dtype=bool)
    starts = list(range(0, count, batch_size))
    with ThreadPoolExecutor(max_workers=1) as pool:
        pending = pool.submit(_prepare_candidates, forward, candidates[:batch_size], block)
        for n, start in enumerate(starts):
            batch = candidates[start : start + batch_size]
            prepared, order = pending.result()
            if n + 1 < len(starts):
                pending = pool.submit(
                    _prepare_candidates, forward, candidates[starts[n + 1] : starts[n + 1] + batch_size], block
                )
            if prepared is None:
                scenes = []
                for candidate in batch:
                    depth, mass_ratio, a_ratio = (*candidate, 1.0)[:3]
                    is_clean = depth < 0 or (mass_ratio == 1.0 and a_ratio == 1.0)
                    scenes.append(forward if is_clean else impurity_scene(forward, depth, mass_ratio, block, a_ratio))
                model, order = build_model(scenes, device), np.arange(len(batch))
            else:
                model = build_model(prepared.chains, device, prepared=prepared)
            # a detection runs many small ensembles of one host chain (the refinement: a few candidates per
            # iteration), each too short for ``auto`` to leave the per-step kernel: ``fused`` takes the CPU chain kernel
            # kernel (compiled once, cached) or on a GPU the calibrated tile/window kernel (calibrated and compiled
            # on first use, cached after), each writing the surface trace inside its launches
            result = Runner(model, kernel="fused", trace_values=("v",)).run()
            v = result.traces["v"][:, :, 0]
            if traces is None and np.array_equal(order, np.arange(count)):
                traces = v if v.dtype == np.float64 else v.astype(np.float64)  # one batch in order: no copy
            else:
                if traces is None:
                    traces = np.empty((count, forward.trace_sample_count))
                traces[start + order] = v
            ok[start + order] = result.status == Status.OK
            del result, model
    return traces, ok


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


CACHED_ARRAYS = ("clean", "echoes", "ok", "fronts", "gram", "first_echo_ends", "first_echo_gram")
"""The library's arrays, each saved as ``<name>.npy`` in the library's cache directory."""


SAVE_THREADS = 8
"""Threads that copy a large array into its ``.npy`` file (a 1000-grain library's echoes are ≈ 1.2 GB: written by one
thread, their save took ≈ 0.47 s on the H100 host, and a detection returns once its library is saved)."""
SAVE_PIECE_BYTES = 64 << 20


def _save_array(path: Path, array: np.ndarray) -> None:
    """``np.save(path, array)``; an array over SAVE_PIECE_BYTES is copied into the file's memory map by up to
    SAVE_THREADS threads, a share of its rows each (numpy releases the GIL while it copies). Same file."""
    if array.nbytes <= SAVE_PIECE_BYTES or array.ndim == 0 or not array.flags.c_contiguous:
        np.save(path, array)
        return
    from concurrent.futures import ThreadPoolExecutor

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
    import warp as wp
    from hertzian.core.devices import init_warp
    from hertzian.core.model import build_model
    from hertzian.core.runner import Runner
    from hertzian.core.status import Status
    from hertzian.kernels.library import library_kernels

    init_warp()
    if len(candidates) > (batch_size or default_batch_size(device)) or forward.record_count != 2:
        return None
    prepared, order = _prepare_candidates(forward, candidates, grid.block)
    if prepared is None:
        return None
    model = build_model(prepared.chains, device, prepared=prepared)
    depths, ratios, samples = len(grid.depths), len(grid.log_mass_ratio), forward.trace_sample_count
    host = {}

    def allocate() -> None:  # while the run executes: page-locked allocation costs ≈ 0.4 s per GB on the H100 host
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


ASSEMBLE_ON_DEVICE: bool | None = None
"""Whether :func:`build_library` assembles the library on the device (:func:`_library_on_device`); None: on CUDA
devices (on a CPU the host path is as fast; tests set True to check the two paths agree)."""


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
    import warp as wp

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
            from concurrent.futures import ThreadPoolExecutor

            pool = ThreadPoolExecutor(max_workers=1)
            library.saving = pool.submit(save_library, path, library)
            pool.shutdown(wait=False)
        else:
            save_library(path, library)
    return library


# ---- Gaussian helpers ----------------------------------------------------------------------


def bisect_increasing(f, target: float, lo: float, hi: float, steps: int = 80) -> float:
    """x in [lo, hi] where the non-decreasing ``f`` crosses ``target``, by ``steps`` halvings."""
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        if f(mid) < target:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def log_normal_cdf(z: float) -> float:
    """log Φ(z), accurate in the far left tail."""
    if z > -30.0:
        return math.log(0.5 * math.erfc(-z / math.sqrt(2.0)))
    # asymptotic series: Φ(z) ≈ φ(z)/|z| (1 − 1/z² + 3/z⁴)
    return -0.5 * z * z - math.log(-z) - 0.5 * math.log(2 * math.pi) + math.log1p(-1 / z**2 + 3 / z**4)


def log_normal_mass(lo: float, hi: float) -> float:
    """log(Φ(hi) − Φ(lo)) for lo < hi, stable in both tails."""
    if lo > 0:  # use symmetry so the difference is taken in the left tail
        lo, hi = -hi, -lo
    a, b = log_normal_cdf(lo), log_normal_cdf(hi)
    if b - a < 1e-300:
        return -math.inf
    return b + math.log(-math.expm1(a - b))


def logsumexp(values) -> float:
    values = np.asarray(values, dtype=float)
    if values.size == 0 or not np.any(np.isfinite(values)):
        return -math.inf
    top = np.max(values[np.isfinite(values)])
    return float(top + math.log(np.sum(np.exp(values[np.isfinite(values)] - top))))


@dataclass
class Quadratic:
    """RSS(x) ≈ rss0 − 2 g (x − x0) + H (x − x0)² near x0 (Gauss–Newton model of one depth and class)."""

    x0: float
    rss0: float
    g: float
    """J·r, r = signal − model(x0)."""
    H: float
    """J·J."""

    @property
    def optimum(self) -> float:
        return self.x0 + self.g / self.H if self.H > 0 else self.x0

    @property
    def rss_min(self) -> float:
        return max(self.rss0 - self.g * self.g / self.H, 0.0) if self.H > 0 else self.rss0

    def log_integral(self, lo: float, hi: float, sigma: float) -> float:
        """log ∫_lo^hi exp(−RSS(x)/2σ²) dx / (hi − lo) (the prior-averaged likelihood, without constants)."""
        width = hi - lo
        if self.H <= 0 or sigma / math.sqrt(self.H) > 1e6 * width:
            return -self.rss0 / (2 * sigma**2)
        s = sigma / math.sqrt(self.H)
        m = self.optimum
        return (
            -self.rss_min / (2 * sigma**2)
            + math.log(math.sqrt(2 * math.pi) * s)
            + log_normal_mass((lo - m) / s, (hi - m) / s)
            - math.log(width)
        )

    def cdf(self, x: float, lo: float, hi: float, sigma: float) -> float:
        """Posterior CDF of x on [lo, hi] under this quadratic (a truncated Gaussian)."""
        if self.H <= 0:
            return min(max((x - lo) / (hi - lo), 0.0), 1.0)
        s = sigma / math.sqrt(self.H)
        m = self.optimum
        total = log_normal_mass((lo - m) / s, (hi - m) / s)
        if x <= lo or total == -math.inf:
            return 0.0 if x <= lo else min(max((x - lo) / (hi - lo), 0.0), 1.0)
        if x >= hi:
            return 1.0
        return math.exp(log_normal_mass((lo - m) / s, (x - m) / s) - total)


def quadratic_at(signal: np.ndarray, x0: float, model: np.ndarray, jacobian: np.ndarray) -> Quadratic:
    r = signal - model
    return Quadratic(x0=float(x0), rss0=float(r @ r), g=float(jacobian @ r), H=float(jacobian @ jacobian))


# ---- detection ------------------------------------------------------------------------------


@dataclass
class Detection:
    """What the surface signal says about an impurity (program units)."""

    kind: str
    """none | light | heavy."""
    class_probability: dict
    """Posterior probability of each class (equal prior odds)."""
    log_evidence: dict
    """ln of each class's evidence p(signal | class) (Gaussian noise model, σ below)."""
    depth: int | None
    """Posterior mode of the depth (first grain of the block) for the class found; None for none."""
    depth_interval: tuple[int, int] | None
    mass_ratio: float | None
    """m_impurity / m_host at the mode; 1 for none."""
    mass_ratio_interval: tuple[float, float] | None
    noise: float
    """σ used [length/time]."""
    noise_source: str
    """'given' or how it was estimated."""
    noise_before_echo: float | None
    """σ estimated from the samples before the earliest possible echo (None with --noise)."""
    depths_searched: tuple[int, int]
    window: float
    """Samples with t ≤ window were analysed [time]."""
    block: int
    best_fit: np.ndarray
    """Model surface velocity of the best candidate (the clean chain for none), shape (S,)."""
    depth_posterior: dict
    """Per class (light, heavy): p(depth | class), shape (D,)."""
    seconds: dict = field(default_factory=dict)
    """Wall seconds: library (0 if cached), refinement, total."""
    library_from_cache: bool = False
    dt: float = 0.0
    """Step of the forward model [time]."""
    refined_depths: dict = field(default_factory=dict)
    fine_scan: dict | None = None
    """When the refined best fit left σ > FINE_SCAN_MISFIT × the noise (a needle-shaped minimum in μ): the scan of
    ln μ at its depth (depth, class, points, spacing, RSS before and after; None if no scan ran)."""
    fit_a: dict | None = None
    """With --fit-a: a_ratio = a_impurity / a_host and its 95 % interval, the RSS of the joint fit and of the
    best fit with a = a_host, σ of the joint fit (None without --fit-a, or for class none)."""

    @property
    def misfit_ratio(self) -> float | None:
        """σ of the best fit over σ before the earliest echo: ≫ 1 means the best model misses the signal."""
        return None if not self.noise_before_echo else self.noise / self.noise_before_echo

    def to_dict(self) -> dict:
        return {
            "class": self.kind,
            "depth": self.depth,
            "depth_interval": list(self.depth_interval) if self.depth_interval else None,
            "mass_ratio": self.mass_ratio,
            "mass_ratio_interval": list(self.mass_ratio_interval) if self.mass_ratio_interval else None,
            "log_evidence": self.log_evidence,
            "class_probability": self.class_probability,
            "noise": self.noise,
            "noise_source": self.noise_source,
            "noise_before_echo": self.noise_before_echo,
            "misfit_ratio": self.misfit_ratio,
            "depths_searched": list(self.depths_searched),
            "window": self.window,
            "block": self.block,
            "credible": CREDIBLE,
            "dt": self.dt,
            "seconds": self.seconds,
            "library_from_cache": self.library_from_cache,
            "refined_depths": self.refined_depths,
            "fine_scan": self.fine_scan,
            **(self.fit_a if self.fit_a is not None else {}),
        }


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


def estimate_noise(signal: Signal, clean: np.ndarray, fronts: np.ndarray, first_depth: int) -> tuple[float | None, str]:
    """rms of (signal − clean model) before the earliest possible echo, t < 2 t_front(first_depth).

    None when fewer than NOISE_MIN_SAMPLES samples precede it.
    """
    end = 2 * fronts[first_depth]
    window = signal.t < end
    count = int(window.sum())
    if count < NOISE_MIN_SAMPLES:
        return None, f"only {count} samples before the earliest possible echo (t < {end:.4g})"
    residual = signal.v[window] - clean[window]
    sigma = float(np.sqrt(np.mean(residual**2)))
    return sigma, f"{count} samples before the earliest possible echo (t < {end:.4g})"


def _class_bounds(grid: Grid) -> dict:
    low, high = grid.mass_ratio_range
    return {"light": (math.log(low), 0.0), "heavy": (0.0, math.log(high))}


INTERPOLATION_POINTS = 8
"""Points per library interval in ln μ at which the cubic interpolant of the traces is evaluated."""


def lagrange_weights(nodes: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Local cubic Lagrange interpolation on increasing ``nodes``: values and x-derivatives at ``points``.

    Returns W, dW of shape (P, n) so that f(points) ≈ W @ f(nodes), f'(points) ≈ dW @ f(nodes); each
    point uses the 4 nodes around it (3 or 2 where fewer exist).
    """
    n = nodes.size
    width = min(4, n)
    W = np.zeros((points.size, n))
    dW = np.zeros((points.size, n))
    for p, x in enumerate(points):
        i = int(np.clip(np.searchsorted(nodes, x) - 1, 0, n - 1))
        first = int(np.clip(i - 1, 0, n - width))
        idx = range(first, first + width)
        for a in idx:
            others = [b for b in idx if b != a]
            denominator = np.prod([nodes[a] - nodes[b] for b in others])
            W[p, a] = np.prod([x - nodes[b] for b in others]) / denominator
            dW[p, a] = sum(np.prod([x - nodes[c] for c in others if c != b]) for b in others) / denominator
    return W, dW


@functools.lru_cache(maxsize=16)
def _fine_interpolation(nodes: tuple[float, ...], points: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The fine x grid over increasing ``nodes`` (``points`` per interval) and the local-cubic weights W and
    derivatives dW on it, read-only (kept: a detection asks four times for the same nodes, a study every time)."""
    xs = np.array(nodes)
    fine = np.linspace(xs[0], xs[-1], (xs.size - 1) * points + 1)
    W, dW = lagrange_weights(xs, fine)
    for array in (fine, W, dW):
        array.flags.writeable = False
    return fine, W, dW


def _class_interpolation(library: Library, kind: str):
    """The class's library columns, their order in x = ln μ (the clean chain appended at x = 0), the fine
    x grid (INTERPOLATION_POINTS per interval) and the local-cubic weights W and derivatives dW on it."""
    grid = library.grid
    columns = grid.light if kind == "light" else grid.heavy
    xs = np.concatenate([grid.log_mass_ratio[columns], [0.0]])
    order = np.argsort(xs)
    fine, W, dW = _fine_interpolation(tuple(xs[order].tolist()), INTERPOLATION_POINTS)
    return columns, order, fine, W, dW


def rss_from_projections(
    residual_norm2: float | np.ndarray, projections: np.ndarray, gram: np.ndarray, W: np.ndarray
) -> np.ndarray:
    """|e − W @ D|² per row of W, from e's projections on the rows of D and their Gram matrix alone.

    RSS = |e|² − 2 W (D e) + diag(W (D Dᵀ) Wᵀ). ``residual_norm2``: |e|² (a number, or one per leading index);
    ``projections``: D e, shape (..., n); ``gram``: D Dᵀ, shape (..., n, n); W: shape (P, n). Returns shape (..., P),
    clipped at 0 (rounding can leave a perfect fit slightly negative)."""
    quadratic = np.einsum("pi,...ip->...p", W, gram @ W.T)
    rss = np.asarray(residual_norm2)[..., None] - 2.0 * (projections @ W.T) + quadratic
    return np.maximum(rss, 0.0)


def interpolated_rss(signal: np.ndarray, models: np.ndarray, clean: np.ndarray, W: np.ndarray) -> np.ndarray:
    """|signal − W @ models|² per row of W, without forming the (rows × samples) interpolated traces.

    With e = signal − clean and D = models − clean (each row of W sums to 1, so W @ models − clean =
    W @ D): RSS = |e|² − 2 W (D e) + diag(W (D Dᵀ) Wᵀ) (:func:`rss_from_projections`). D Dᵀ is a small Gram
    matrix (nodes × nodes), so the cost is O(nodes² · samples) instead of O(rows · nodes · samples);
    subtracting the clean chain first keeps the cancellation to the size of the echoes, not of the whole
    signal."""
    e = signal - clean
    D = models - clean[None]
    return rss_from_projections(float(e @ e), D @ e, D @ D.T, W)


def _class_rss(
    residual_norm2: float | np.ndarray, projections: np.ndarray, gram: np.ndarray, library: Library, kind: str
):
    """Per depth, the RSS of the class's interpolated library against the signal, at every fine x.

    ``projections``: the echoes' projections on the clean chain's residual e = signal − clean, shape (D, M);
    ``gram``: the echoes' Gram matrices over the same samples, shape (D, M, M); ``residual_norm2``: |e|² over
    them (a number, or shape (D,)). Returns the fine x grid (P,), the weights W and derivatives dW (P, n), the
    class's nodes' projections (D, n) and Gram matrices (D, n, n) in x order (the clean chain a node of echo 0),
    and the RSS (D, P), inf at points whose interpolation weighs a candidate that did not run OK."""
    columns, order, fine, W, dW = _class_interpolation(library, kind)
    depths, n = projections.shape[0], columns.size + 1
    node_projections = np.zeros((depths, n))
    node_projections[:, :-1] = projections[:, columns]
    node_gram = np.zeros((depths, n, n))
    node_gram[:, :-1, :-1] = gram[:, columns[:, None], columns]
    ok = np.ones((depths, n), dtype=bool)
    ok[:, :-1] = library.ok[:, columns]
    node_projections, node_gram, ok = node_projections[:, order], node_gram[:, order][:, :, order], ok[:, order]
    unusable = ((np.abs(W) > 0)[None] & ~ok[:, None, :]).any(axis=-1)
    rss = np.where(unusable, np.inf, rss_from_projections(residual_norm2, node_projections, node_gram, W))
    return fine, W, dW, node_projections, node_gram, rss


def _echo_projections(residual: np.ndarray, library: Library) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """The library's echoes projected on the clean chain's residual e = signal − clean [(length/time)²]: over all
    samples, shape (D, M), and over each depth's first-echo window, (|e|² there, shape (D,); the projections,
    shape (D, M)). One pass over the echoes, depth by depth (the window and the rest of one depth's echoes while
    they are in cache: faster than a product with a masked copy of e per depth)."""
    projections = np.empty(library.ok.shape)
    first_norm2 = np.empty(library.ok.shape[0])
    first_projections = np.empty(library.ok.shape)
    for k, end in enumerate(library.first_echo_ends.tolist()):
        echoes, head = library.echoes[k], residual[:end]
        first_norm2[k] = head @ head
        first_projections[k] = echoes[:, :end] @ head
        projections[k] = first_projections[k] + echoes[:, end:] @ residual[end:]
    return projections, (first_norm2, first_projections)


def _candidate_rss(residual_norm2: float, projections: np.ndarray, library: Library) -> np.ndarray:
    """RSS of every library candidate against the signal, |e − echo|², shape (D, M); inf where it did not run OK."""
    rss = residual_norm2 - 2.0 * projections + np.einsum("dmm->dm", library.gram)
    return np.where(library.ok, np.maximum(rss, 0.0), np.inf)


def _library_quadratics(
    residual_norm2: float, projections: np.ndarray, library: Library, kind: str
) -> list[Quadratic | None]:
    """Per depth, the Gauss–Newton quadratic at the best point of the class's interpolated library.

    The traces are interpolated in x = ln μ (local cubic through the library's ratios and the clean
    chain at x = 0) at INTERPOLATION_POINTS points per interval; x0 is the point of least RSS, J the
    interpolant's derivative there. All from the residual e = signal − clean (|e|², and the echoes'
    projections on it, shape (D, M)) and the library's Gram matrices: with w, w' the weights and derivatives
    at x0 and G, b the class's nodes' Gram matrix and projections, J·r = w'·(b − G w), J·J = w'·G w'.
    """
    fine, W, dW, b, G, rss = _class_rss(residual_norm2, projections, library.gram, library, kind)
    rows = np.arange(rss.shape[0])
    j = np.argmin(rss, axis=1)
    w, dw = W[j], dW[j]
    g = np.einsum("di,di->d", dw, b - np.einsum("dij,dj->di", G, w))
    H = np.einsum("di,dij,dj->d", dw, G, dw)
    return [
        Quadratic(x0=x0, rss0=rss0, g=gk, H=Hk) if usable else None
        for x0, rss0, gk, Hk, usable in zip(
            fine[j].tolist(), rss[rows, j].tolist(), g.tolist(), H.tolist(), np.isfinite(rss).any(axis=1).tolist()
        )
    ]


FIRST_ECHO_GRAINS = 10
"""The first-echo score of depth d uses the samples before the echo from depth d + this could start. The
library caches Gram matrices over these windows (``Library.first_echo_gram``): a cached library built with
another value is rebuilt."""


def _first_echo_scores(
    first_echo: tuple[np.ndarray, np.ndarray], library: Library, kind: str
) -> tuple[np.ndarray, np.ndarray]:
    """Per depth: how much the class's interpolated library reduces the RSS of the clean chain over the
    samples before 2 t_front(d + FIRST_ECHO_GRAINS) (its first echo and little else), and the best x there
    (-inf and 0 for a window of fewer than 2 samples). ``first_echo``: |e|² and the echoes' projections over
    each depth's window (:func:`_echo_projections`)."""
    norm2, projections = first_echo
    fine, _, _, _, _, rss = _class_rss(norm2, projections, library.first_echo_gram, library, kind)
    j = np.argmin(rss, axis=1)
    windowed = library.first_echo_ends >= 2
    gain = np.where(windowed, norm2 - rss[np.arange(rss.shape[0]), j], -np.inf)
    return gain, np.where(windowed, fine[j], 0.0)


def detect(
    signal: Signal,
    base: Scene,
    *,
    block: int = 1,
    noise: float | None = None,
    device: str = "cpu",
    depth_range: tuple[int, int] | None = None,
    mass_ratio_range=(0.25, 4.0),
    mass_steps: int = 7,
    refine: int = 3,
    iterations: int = 2,
    step: float = 0.02,
    window: float | None = None,
    use_cache: bool = True,
    batch_size: int | None = None,
    fit_a: bool = False,
    a_ratio_range: tuple[float, float] = (0.25, 4.0),
) -> tuple[Detection, Library]:
    """Class, depth and mass ratio of an impurity in BASE from a surface signal (see the module docstring).

    ``refine``: depths per class refined by Gauss–Newton (0: the library alone); ``iterations``: ensemble
    runs of refinement; ``step``: finite-difference step in ln μ; ``window``: the samples with t ≤ window
    are analysed (default: until the pulse reflected by the bottom returns, 2 t_front(N − 1)); ``fit_a``:
    at the depth found, fit ln μ and ln(a/a_host) jointly (:func:`fit_contact`, a/a_host in ``a_ratio_range``)
    and report a_ratio with its interval; the mass ratio and its interval then come from the joint fit.
    """
    started = time.perf_counter()
    if block < 1 or block >= base.chain.grains:
        raise SceneError("--block", block, f"must be an integer 1 … {base.chain.grains - 1}")
    if noise is not None and not (noise > 0 and math.isfinite(noise)):
        raise SceneError("--noise", noise, "must be a number > 0 (σ of the noise, program velocity)")
    if refine < 0:
        raise SceneError("--refine", refine, "must be an integer ≥ 0")
    if iterations < 1:
        raise SceneError("--iterations", iterations, "must be an integer ≥ 1")
    if window is not None and not window > 0:
        raise SceneError("--window", window, "must be a time > 0")
    if fit_a:
        a_low, a_high = a_ratio_range
        if not (0 < a_low < 1 < a_high and math.isfinite(a_high)):
            raise SceneError(
                "--a-range",
                f"{a_low},{a_high}",
                "must be two numbers a_min < 1 < a_max, both > 0 (prior range of a_impurity / a_host)",
            )
    # the pulse fronts of the clean chain (cached under a key of BASE and the sample times)
    fronts = _cached_fronts(forward_scene(base, signal.spacing, signal.sample_count), device, use_cache)
    end = 2 * float(fronts[-1]) if window is None else float(window)
    count = min(signal.sample_count, int(np.searchsorted(signal.t, end * (1 + 1e-12), side="right")))
    if count < 3:
        raise SceneError("--window", f"{end:g}", "leaves fewer than 3 samples")
    signal = Signal(t=signal.t[:count], v=signal.v[:count], source=signal.source)
    depths = default_depths(fronts, float(signal.t[-1]), base.chain.grains, block, depth_range)
    forward = forward_scene(base, signal.spacing, signal.sample_count)
    library = build_library(
        forward,
        make_grid(depths, mass_ratio_range, mass_steps, block),
        device,
        fronts=fronts,
        use_cache=use_cache,
        batch_size=batch_size,
        save_in_background=True,
    )
    library_seconds = library.build_seconds
    grid = library.grid
    depths = grid.depths
    s = signal.v
    residual = s - library.clean
    rss_clean = float(residual @ residual)
    projections, first_echo = _echo_projections(residual, library)
    floor = 1e-12 * float(np.max(np.abs(library.clean)))
    if noise is None:
        # first estimate (picks the depths to refine): before the earliest possible echo, else the
        # best library candidate's residual
        window_sigma, window_text = estimate_noise(signal, library.clean, library.fronts, int(depths[0]))
        if window_sigma is not None:
            sigma = window_sigma
        else:
            best = min(float(np.min(_candidate_rss(rss_clean, projections, library))), rss_clean)
            sigma = math.sqrt(best / (signal.sample_count - 2))
        sigma = max(sigma, floor)
    else:
        sigma, noise_source = float(noise), "given (--noise)"

    refine_start = time.perf_counter()
    bounds = _class_bounds(grid)
    quads = {kind: _library_quadratics(rss_clean, projections, library, kind) for kind in ("light", "heavy")}
    log_prior_depth = -math.log(len(depths))

    def depth_logz(kind: str) -> np.ndarray:
        lo, hi = bounds[kind]
        return np.array([q.log_integral(lo, hi, sigma) if q is not None else -math.inf for q in quads[kind]])

    refined: dict[str, list[int]] = {"light": [], "heavy": []}
    if refine > 0:
        # candidates per class: the best `refine` depths by their library evidence over the window, and the
        # best `refine` by how much of the first echo they explain (robust where later reverberations make
        # the library's interpolation in μ poor); Gauss–Newton starts from each one's own best x
        todo = []
        for kind in ("light", "heavy"):
            lo, hi = bounds[kind]
            logz = depth_logz(kind)
            starts = [(int(k), quads[kind][k].optimum) for k in np.argsort(-logz)[:refine] if np.isfinite(logz[k])]
            gain, first_x = _first_echo_scores(first_echo, library, kind)
            starts += [(int(k), first_x[k]) for k in np.argsort(-gain)[:refine] if np.isfinite(gain[k])]
            for k, x in starts:
                x0 = min(max(x, lo + step), hi - step)
                if not any(kk == k and cc == kind and abs(xx - x0) < 2 * step for cc, kk, xx in todo):
                    todo.append((kind, k, x0))
        final: dict[tuple[str, int], Quadratic] = {}
        for _ in range(iterations):
            candidates = []
            for kind, k, x0 in todo:
                candidates += [(int(depths[k]), math.exp(x0 + dx)) for dx in (-step, 0.0, step)]
            traces, ok = run_candidates(forward, candidates, grid.block, device, batch_size=batch_size)
            nxt = []
            for n, (kind, k, x0) in enumerate(todo):
                minus, centre, plus = traces[3 * n : 3 * n + 3]
                if not ok[3 * n : 3 * n + 3].all():
                    continue
                q = quadratic_at(s, x0, centre, (plus - minus) / (2 * step))
                best = final.get((kind, k))
                if best is None or q.rss0 < best.rss0:
                    final[(kind, k)] = q
                lo, hi = bounds[kind]
                nxt.append((kind, k, min(max(q.optimum, lo + step), hi - step)))
            todo = nxt
        for (kind, k), q in final.items():
            quads[kind][k] = q  # the simulated quadratic replaces the library's estimate
            refined[kind].append(int(depths[k]))
    refine_seconds = time.perf_counter() - refine_start

    fine = None
    reference = noise if noise is not None else window_sigma
    fitted = [(q.rss0, kind, k) for kind in quads for k, q in enumerate(quads[kind]) if q is not None]
    if refine > 0 and reference is not None and fitted:
        rss_best, kind_best, k_best_fit = min(fitted)
        misfit = math.sqrt(rss_best / max(signal.sample_count - 2, 1)) / reference
        if rss_best < rss_clean and misfit > FINE_SCAN_MISFIT:
            scan_start = time.perf_counter()
            q_scan, points = fine_scan(
                s, forward, grid.block, int(depths[k_best_fit]), bounds[kind_best], device, batch_size=batch_size
            )
            improved = q_scan is not None and q_scan.rss0 < rss_best
            if improved:
                quads[kind_best][k_best_fit] = q_scan
            fine = {
                "depth": int(depths[k_best_fit]),
                "class": kind_best,
                "points": points,
                "spacing": FINE_SCAN_SPACING,
                "misfit_before": misfit,
                "rss_before": rss_best,
                "rss_after": q_scan.rss0 if improved else rss_best,
                "improved": improved,
            }
            rss_now = q_scan.rss0 if improved else rss_best
            misfit_now = math.sqrt(rss_now / max(signal.sample_count - 2, 1)) / reference
            if misfit_now > FINE_SCAN_MISFIT:
                # still a poor fit: the needle may be the other class's, or a few grains off (a heavy grain at 100
                # fit as a light one at 103): both classes scanned at the depths around, then the best one finely
                kind_w, depth_w, rss_w, points_w = wide_scan(
                    s, forward, grid.block, int(depths[k_best_fit]), depths, bounds, device, batch_size=batch_size
                )
                wide = {
                    "depths": [
                        max(int(depths[0]), int(depths[k_best_fit]) - WIDE_SCAN_DEPTHS),
                        min(int(depths[-1]), int(depths[k_best_fit]) + WIDE_SCAN_DEPTHS),
                    ],
                    "points": points_w,
                    "spacing": WIDE_SCAN_SPACING,
                    "misfit_before": misfit_now,
                    "best": None if kind_w is None else {"class": kind_w, "depth": depth_w},
                    "improved": False,
                }
                if kind_w is not None and rss_w < rss_now:
                    k_w = int(np.searchsorted(depths, depth_w))
                    q_w, _ = fine_scan(s, forward, grid.block, depth_w, bounds[kind_w], device, batch_size=batch_size)
                    current = quads[kind_w][k_w]
                    if q_w is not None and q_w.rss0 < rss_now and (current is None or q_w.rss0 < current.rss0):
                        quads[kind_w][k_w] = q_w
                        wide["improved"] = True
                        fine["rss_after"] = q_w.rss0
                fine["wide"] = wide
            fine["seconds"] = time.perf_counter() - scan_start
    if noise is None:
        # second estimate, from every sample: the best candidate's residual (2 fitted parameters)
        best_rss = min([rss_clean] + [q.rss0 for kind in quads for q in quads[kind] if q is not None])
        sigma = max(math.sqrt(best_rss / (signal.sample_count - 2)), floor)
        noise_source = f"rms residual of the best candidate over all {signal.sample_count} samples, RSS/(S − 2); " + (
            f"rms of signal − clean chain before the earliest echo: {window_sigma:.4g} over {window_text}"
            if window_sigma is not None
            else window_text
        )
    norm = -0.5 * signal.sample_count * math.log(2 * math.pi * sigma**2)
    per_depth = {kind: depth_logz(kind) + log_prior_depth for kind in ("light", "heavy")}
    log_z = {
        "none": norm - rss_clean / (2 * sigma**2),
        "light": norm + logsumexp(per_depth["light"]),
        "heavy": norm + logsumexp(per_depth["heavy"]),
    }
    total = logsumexp(list(log_z.values()))
    probability = {kind: math.exp(log_z[kind] - total) for kind in CLASSES}
    kind = max(CLASSES, key=lambda c: log_z[c])
    posterior = {}
    for c in ("light", "heavy"):
        w = per_depth[c] - logsumexp(per_depth[c])
        posterior[c] = np.exp(w)

    depth = depth_interval = mass_ratio = mass_interval = None
    best_fit = library.clean
    if kind == "none":
        mass_ratio = 1.0
    else:
        p = posterior[kind]
        k_best = int(np.argmax(p))
        depth = int(depths[k_best])
        cdf = np.cumsum(p)
        tail = (1 - CREDIBLE) / 2
        depth_interval = (
            int(depths[int(np.searchsorted(cdf, tail))]),
            int(depths[min(int(np.searchsorted(cdf, 1 - tail)), len(depths) - 1)]),
        )
        lo, hi = bounds[kind]
        q = quads[kind][k_best]
        x_best = min(max(q.optimum, lo), hi)
        mass_ratio = math.exp(x_best)
        weights = [(p[k], quads[kind][k]) for k in range(len(depths)) if p[k] > 1e-12 and quads[kind][k] is not None]
        wsum = sum(w for w, _ in weights)

        def mixture_cdf(x: float) -> float:
            return sum(w * qq.cdf(x, lo, hi, sigma) for w, qq in weights) / wsum

        mass_interval = (
            math.exp(bisect_increasing(mixture_cdf, tail, lo, hi)),
            math.exp(bisect_increasing(mixture_cdf, 1 - tail, lo, hi)),
        )
        best_fit = run_candidates(forward, [(depth, mass_ratio)], grid.block, device)[0][0]
    fit_a_result = None
    if fit_a and kind != "none":
        fit_start = time.perf_counter()
        # a ≠ a_host can shift the echo's best depth with a = a_host by a grain: fit the neighbours too
        fit_depths = [
            d for d in range(depth - FIT_A_DEPTHS, depth + FIT_A_DEPTHS + 1) if int(depths[0]) <= d <= int(depths[-1])
        ]
        fits = [
            (
                d,
                fit_contact(
                    s,
                    forward,
                    grid.block,
                    d,
                    bounds[kind],
                    a_ratio_range,
                    device,
                    noise=noise,
                    step=step,
                    batch_size=batch_size,
                ),
            )
            for d in fit_depths
        ]
        fits = [(d, c) for d, c in fits if c is not None]
        fit_depth, contact = min(fits, key=lambda dc: dc[1].rss) if fits else (depth, None)
        rss_host_a = float((s - best_fit) @ (s - best_fit))
        if contact is not None and contact.rss < rss_host_a:
            depth = fit_depth
            z = 1.959963984540054
            sx, sy = (math.sqrt(contact.covariance[i, i]) for i in (0, 1))
            lo, hi = bounds[kind]
            a_lo, a_hi = (math.log(r) for r in a_ratio_range)
            mass_ratio = math.exp(contact.x)
            mass_interval = (math.exp(max(contact.x - z * sx, lo)), math.exp(min(contact.x + z * sx, hi)))
            best_fit = contact.trace
            fit_a_result = {
                "a_ratio": math.exp(contact.y),
                "a_ratio_interval": [math.exp(max(contact.y - z * sy, a_lo)), math.exp(min(contact.y + z * sy, a_hi))],
                "rss": contact.rss,
                "rss_a_host": rss_host_a,
                "noise_fit_a": contact.sigma,
                "fit_a_depths": {str(d): c.rss for d, c in fits},
            }
        else:  # the joint fit did not improve on a = a_host
            fit_a_result = {
                "a_ratio": 1.0,
                "a_ratio_interval": None,
                "rss": rss_host_a,
                "rss_a_host": rss_host_a,
                "noise_fit_a": None,
                "fit_a_depths": {str(d): c.rss for d, c in fits},
            }
        fit_a_result["fit_a_seconds"] = time.perf_counter() - fit_start
    library.finish_saving()  # the cache is complete when detect returns (a second signal may read it)
    seconds = {
        "library": library_seconds,
        "refinement": refine_seconds,
        **({"fine_scan": fine["seconds"]} if fine else {}),
        "total": time.perf_counter() - started,
    }
    return Detection(
        kind=kind,
        class_probability=probability,
        log_evidence=log_z,
        depth=depth,
        depth_interval=depth_interval,
        mass_ratio=mass_ratio,
        mass_ratio_interval=mass_interval,
        noise=sigma,
        noise_source=noise_source,
        noise_before_echo=window_sigma if noise is None else None,
        depths_searched=(int(depths[0]), int(depths[-1])),
        window=float(signal.t[-1]),
        block=grid.block,
        best_fit=best_fit,
        depth_posterior=posterior,
        seconds=seconds,
        library_from_cache=library.from_cache,
        dt=forward.integrator.dt,
        refined_depths=refined,
        fine_scan=fine,
        fit_a=fit_a_result,
    ), library


FINE_SCAN_MISFIT = 2.0
"""A fine scan of ln μ runs at the best depth when the refined best fit leaves σ above this multiple of the
noise (the σ before the earliest echo, or --noise): the misfit of a needle-shaped minimum that the library
(ratios ~20 % apart) and Gauss–Newton steps of 2 % step over (docs/detection.md, failure 2). Chosen on the
CPU study's seed 2026 (the needle case left 2.4–2.9× at 20–26 dB, correct fits ≤ 2.2×), checked on seed 2027."""
FINE_SCAN_SPACING = 0.004
"""Spacing of that scan in ln μ (0.4 %): finer than the ±1.5 % width of the needle measured on a shallow light
grain, so one scan point falls inside it."""
FINE_SCAN_ITERATIONS = 2
"""Gauss–Newton iterations from the best scan point (finite differences of half the spacing)."""


WIDE_SCAN_DEPTHS = 4
"""When the fine scan leaves the fit poor (σ still above FINE_SCAN_MISFIT times the noise), both classes are scanned
at the depths within this many grains of the best one (:func:`wide_scan`): on the 1000-grain host at 26 dB a heavy
grain (μ = 2) at depth 100 was otherwise taken for a light one at 103 (μ 0.75, misfit 5.3-5.9×) in 4 of 4 noise
draws (docs/detection.md §6d)."""
WIDE_SCAN_SPACING = 0.01
"""ln μ spacing of that scan: within the ±1.5 % width of a needle, so one point falls inside it; the best (class,
depth) is then scanned every FINE_SCAN_SPACING (:func:`fine_scan`)."""


def wide_scan(
    s: np.ndarray,
    forward: Scene,
    block: int,
    depth: int,
    depths: np.ndarray,
    bounds: dict,
    device: str,
    *,
    batch_size: int | None = None,
) -> tuple[str | None, int | None, float, int]:
    """ln μ every WIDE_SCAN_SPACING over each class's range in ``bounds`` at every searched depth within
    WIDE_SCAN_DEPTHS of ``depth`` (one ensemble); returns (class, depth, RSS) of the lowest RSS and the points run."""
    searched = set(int(d) for d in depths)
    keys = []
    for kind in ("light", "heavy"):
        lo, hi = bounds[kind]
        xs = np.arange(lo + WIDE_SCAN_SPACING, hi - 0.5 * WIDE_SCAN_SPACING, WIDE_SCAN_SPACING)
        keys += [
            (kind, d, float(x))
            for d in range(depth - WIDE_SCAN_DEPTHS, depth + WIDE_SCAN_DEPTHS + 1)
            if d in searched
            for x in xs
        ]
    if not keys:
        return None, None, math.inf, 0
    traces, ok = run_candidates(forward, [(d, math.exp(x)) for _, d, x in keys], block, device, batch_size=batch_size)
    residual = s[None, :] - traces
    rss = np.where(ok, np.einsum("cs,cs->c", residual, residual), np.inf)
    i = int(np.argmin(rss))
    if not np.isfinite(rss[i]):
        return None, None, math.inf, len(keys)
    return keys[i][0], keys[i][1], float(rss[i]), len(keys)


def fine_scan(
    s: np.ndarray,
    forward: Scene,
    block: int,
    depth: int,
    x_bounds: tuple[float, float],
    device: str,
    *,
    batch_size: int | None = None,
) -> tuple[Quadratic | None, int]:
    """ln μ scanned every FINE_SCAN_SPACING over the class's range ``x_bounds`` at ``depth`` (one ensemble run),
    then Gauss–Newton from the best point; returns (the quadratic of lowest RSS, scan points)."""
    lo, hi = x_bounds
    xs = np.arange(lo + FINE_SCAN_SPACING, hi - 0.5 * FINE_SCAN_SPACING, FINE_SCAN_SPACING)
    traces, ok = run_candidates(forward, [(depth, math.exp(x)) for x in xs], block, device, batch_size=batch_size)
    residual = s[None, :] - traces
    rss = np.where(ok, np.einsum("cs,cs->c", residual, residual), np.inf)
    i = int(np.argmin(rss))
    if not np.isfinite(rss[i]):
        return None, len(xs)
    i = min(max(i, 1), len(xs) - 2)
    best = quadratic_at(s, xs[i], traces[i], (traces[i + 1] - traces[i - 1]) / (2 * FINE_SCAN_SPACING))
    h = 0.5 * FINE_SCAN_SPACING
    x = min(max(best.optimum, lo + h), hi - h)
    for _ in range(FINE_SCAN_ITERATIONS):
        (minus, centre, plus), fine_ok = run_candidates(
            forward, [(depth, math.exp(x + dx)) for dx in (-h, 0.0, h)], block, device
        )
        if not fine_ok.all():
            break
        q = quadratic_at(s, x, centre, (plus - minus) / (2 * h))
        if q.rss0 < best.rss0:
            best = q
        x = min(max(q.optimum, lo + h), hi - h)
    return best, len(xs)


FIT_A_DEPTHS = 1
"""``--fit-a``: the joint fit runs at the depth found with a = a_host and this many depths either side."""
A_STEPS = 9
"""``--fit-a``: grid points in ln(a/a_host) over its prior range (ends included)."""
X_STEPS = 9
"""``--fit-a``: grid points in ln μ over the class's prior range (ends included)."""
JOINT_ITERATIONS = 3
"""``--fit-a``: Gauss–Newton iterations in (ln μ, ln a/a_host) from the best grid point (5 chains each)."""


@dataclass
class ContactFit:
    """The fit of ln μ and y = ln(a / a_host) at one depth (``--fit-a``)."""

    x: float
    """ln μ at the best simulated point."""
    y: float
    """ln(a / a_host) at the best simulated point."""
    rss: float
    """Residual sum of squares of the simulated chain there."""
    covariance: np.ndarray
    """σ² (JᵀJ)⁻¹ of (x, y) there, shape (2, 2) (Laplace approximation of the posterior)."""
    sigma: float
    """σ used for the covariance: --noise, or RSS/(S − 3) (3 fitted parameters: depth, μ, a)."""
    trace: np.ndarray
    profile: list
    """(y, x, RSS): the grid's best x and its RSS at each grid value of y (the profile over a)."""


def fit_contact(
    s: np.ndarray,
    forward: Scene,
    block: int,
    depth: int,
    x_bounds: tuple[float, float],
    a_ratio_range: tuple[float, float],
    device: str,
    *,
    noise: float | None,
    step: float,
    batch_size: int | None = None,
) -> ContactFit | None:
    """Fit x = ln μ and y = ln(a/a_host) at ``depth``; μ and a trade off along a curved valley (the echo's
    impedance), so Gauss–Newton from afar zig-zags or overshoots. First a grid: X_STEPS × A_STEPS points
    over the class's range of x and the prior range of y, one ensemble; then JOINT_ITERATIONS Gauss–Newton
    steps from its best point (centre and ±step in x and y, J by central differences), each step kept
    inside the prior box.
    Returns the point of least simulated RSS with the Gauss–Newton covariance there; None if nothing ran."""
    y_lo, y_hi = math.log(a_ratio_range[0]), math.log(a_ratio_range[1])
    box = np.array([[x_bounds[0] + step, x_bounds[1] - step], [y_lo + step, y_hi - step]])
    ys = np.linspace(y_lo, y_hi, A_STEPS)
    xs = np.linspace(x_bounds[0], x_bounds[1], X_STEPS)
    best = None  # (rss, x, y, H, trace)

    def keep(rss, x, y, H, trace):
        nonlocal best
        if best is None or rss < best[0]:
            best = (rss, x, y, H, trace)

    grid = [(float(x), float(y)) for y in ys for x in xs if x != 0.0 or y != 0.0]
    traces, ok = run_candidates(
        forward, [(depth, math.exp(x), math.exp(y)) for x, y in grid], block, device, batch_size=batch_size
    )
    rss_grid = np.where(ok, np.einsum("cs,cs->c", s[None] - traces, s[None] - traces), np.inf)
    profile = []
    for y in ys:
        rows = [(rss_grid[c], x) for c, (x, yy) in enumerate(grid) if yy == float(y)]
        rss, x = min(rows)
        profile.append((float(y), float(x), float(rss)))
    k = int(np.argmin(rss_grid))
    if not np.isfinite(rss_grid[k]):
        return None
    p = np.clip(np.array(grid[k]), box[:, 0], box[:, 1])
    offsets = [(0.0, 0.0), (-step, 0.0), (step, 0.0), (0.0, -step), (0.0, step)]
    for _ in range(JOINT_ITERATIONS):
        candidates = [(depth, math.exp(p[0] + dx), math.exp(p[1] + dy)) for dx, dy in offsets]
        traces, ok = run_candidates(forward, candidates, block, device, batch_size=batch_size)
        if not ok.all():
            break
        J = np.stack([(traces[2] - traces[1]) / (2 * step), (traces[4] - traces[3]) / (2 * step)], axis=1)
        r = s - traces[0]
        H = J.T @ J
        keep(float(r @ r), float(p[0]), float(p[1]), H, traces[0])
        try:
            p = np.clip(p + np.linalg.solve(H, J.T @ r), box[:, 0], box[:, 1])
        except np.linalg.LinAlgError:
            break
    if best is None:
        return None
    rss, x, y, H, trace = best
    sigma = float(noise) if noise is not None else math.sqrt(rss / (s.size - 3))
    try:
        covariance = sigma**2 * np.linalg.inv(H)
    except np.linalg.LinAlgError:
        covariance = np.full((2, 2), np.inf)
    return ContactFit(x=x, y=y, rss=rss, covariance=covariance, sigma=sigma, trace=trace, profile=profile)


def _cached_fronts(forward: Scene, device: str, use_cache: bool) -> np.ndarray:
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


# ---- plot -------------------------------------------------------------------------------------


def plot_detection(signal: Signal, detection: Detection, library: Library, path: str | Path) -> None:
    """Signal, best fit and residual (top); posterior over depth of both classes (bottom)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 7), constrained_layout=True)
    count = detection.best_fit.size  # the analysed window
    signal = Signal(t=signal.t[:count], v=signal.v[:count], source=signal.source)
    top.plot(signal.t, signal.v, lw=0.8, color="0.5", label="signal")
    top.plot(signal.t, detection.best_fit, lw=0.9, color="C0", label="best fit")
    residual = signal.v - detection.best_fit
    top.plot(signal.t, residual, lw=0.6, color="C3", label="residual")
    scale = max(float(np.max(np.abs(signal.v - library.clean))), 5 * detection.noise)
    top.set_ylim(-3 * scale, 3 * scale)
    top.set_xlabel("t [program time, 1.0102e-3 s]")
    top.set_ylabel("v of grain 0 [program velocity]")
    what = (
        detection.kind
        if detection.kind == "none"
        else (
            f"{detection.kind}, depth {detection.depth} {list(detection.depth_interval)}, "
            f"μ = {detection.mass_ratio:.3g} [{detection.mass_ratio_interval[0]:.3g}, "
            f"{detection.mass_ratio_interval[1]:.3g}]"
        )
    )
    top.set_title(f"{signal.source}: {what}; σ = {detection.noise:.3g}", fontsize=9)
    top.legend(fontsize=8, loc="upper right")
    for kind, color in (("light", "C2"), ("heavy", "C1")):
        p = detection.depth_posterior[kind] * detection.class_probability[kind]
        bottom.bar(library.grid.depths, p, color=color, alpha=0.7, width=1.0, label=f"{kind}")
    bottom.set_xlabel("depth (first impurity grain)")
    bottom.set_ylabel("p(depth, class | signal)")
    bottom.set_title(f"p(none) = {detection.class_probability['none']:.3g}", fontsize=9)
    bottom.legend(fontsize=8)
    fig.savefig(path, dpi=110)
    plt.close(fig)
