"""The forward model of a detection: BASE traced at the signal's sample times, candidate chains with one impurity
block, the clean chain's pulse front, and the surface traces of many candidates from ensemble runs (program units)."""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace

import numpy as np
from hertzian.core.chains import ChainSet
from hertzian.core.devices import init_warp
from hertzian.core.model import build_model, features_of, prepare_model, stack_prepared
from hertzian.core.runner import Runner
from hertzian.core.scene import ImpuritySpec, Scene, SceneError
from hertzian.core.solvers.prepare import Need
from hertzian.core.startup import taylor_window
from hertzian.core.status import Status
from hertzian.kernels.features import GEAR_VALUES
from hertzian.kernels.library import library_kernels

FRONT_THRESHOLD = 1e-4
"""The pulse front reaches a grain when its velocity first exceeds this fraction of v_imp."""


LIBRARY_BATCH = {"cpu": 4096, "cuda": 16384}
"""Default chains per ensemble run of :func:`run_candidates`: a GPU needs many chains to be busy (a 1000-grain
library of ≈ 13 300 candidates is then one run, its traces ≈ 1.2 GB), the CPU chain kernel does not."""


def default_batch_size(device: str) -> int:
    return LIBRARY_BATCH["cuda" if str(device).startswith("cuda") else "cpu"]


def check_base(base: Scene) -> None:
    """BASE must be an impact on a Hertz chain without impurities (the host chain)."""
    from hertzian.core.model import refuse_per_scene_only

    refuse_per_scene_only(base)
    if base.impurities:
        raise SceneError("BASE impurities", len(base.impurities), "the host chain must have no impurities")
    if base.boundary.surface == "driven" or not base.excitation.impact > 0:
        raise SceneError(
            "BASE excitation.impact", base.excitation.impact, "detection needs an impact (> 0) at grain 0, not a drive"
        )


def bare_base(base: Scene) -> Scene:
    """BASE without its own records (a detection replaces them): its step can then change freely, where its traces
    every 0.01, say, would refuse a step of 0.02."""
    return base.with_overrides(
        {
            "record.every": base.integrator.duration,
            "record.fields": [],
            "record.traces": [],
            "record.trace_every": None,
        }
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


def prepare_candidates(forward: Scene, candidates: list[tuple], block: int):
    """The host half of one ensemble of candidates: (HostModel of a ChainStack, order) where ``order[i]`` is the
    candidate run as chain i, or (None, None) when the candidates need the per-scene path.

    Candidates of one depth and contact constant differ only in the impurity's mass, a per-chain scalar: each
    such group is one ChainSet (template: BASE with that impurity block, mass per chain), prepared with numpy
    over the group, the groups stacked (``hertzian.core.model.stack_prepared``): no scene per candidate,
    the same arrays as building every candidate's scene (``tests/studies/test_detection.py`` checks the traces bit for
    bit). The clean chain joins the first group as mass ratio 1 (the kernel is the impurity chains' anyway).
    """

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

    window = taylor_window(forward.chain.grains, max(GEAR_VALUES.values()))  # every method's, at most
    return a_ratio == 1.0 and forward.chain.gravity == 0.0 and depth > window


def _moved_impurity(moved, chains, depth: int, block: int):
    """The HostModel of ``chains`` (one group: an impurity block at ``depth``, mass per chain) from ``moved``, a
    prepared group's HostModel, with the block moved — or None when the impurity cannot move there
    (:func:`_impurity_can_move`) or the masses differ in number. Every array but 1/m is the prepared group's; 1/m is
    1/m_host outside the block (the prepared group's own value) and 1.0 / mass in it, numpy's division as in
    prepare_model: the same bits as preparing the group (``tests/studies/test_detection.py`` compares the traces)."""

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
    return replace(part, chains=chains, arrays={**part.arrays, "inverse_mass": new_inverse}, seconds=0.0)


def run_candidates(
    forward: Scene, candidates: list[tuple], block: int, device: str, *, batch_size: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Surface traces of candidate (depth, mass ratio[, a ratio]) chains (ensembles of ≤ batch_size chains,
    default :data:`LIBRARY_BATCH` of the device).

    Returns (traces (C, S), ok (C,)); a depth < 0, or mass ratio 1 with a ratio 1, means the clean chain.
    The next batch is prepared on the host (numpy, :func:`prepare_candidates`) while the current one runs.
    """

    init_warp()
    if batch_size is None:
        batch_size = default_batch_size(device)
    count = len(candidates)
    traces = np.empty((count, forward.trace_sample_count)) if count > batch_size else None
    ok = np.empty(count, dtype=bool)
    starts = list(range(0, count, batch_size))
    with ThreadPoolExecutor(max_workers=1) as pool:
        pending = pool.submit(prepare_candidates, forward, candidates[:batch_size], block)
        for n, start in enumerate(starts):
            batch = candidates[start : start + batch_size]
            prepared, order = pending.result()
            if n + 1 < len(starts):
                pending = pool.submit(
                    prepare_candidates, forward, candidates[starts[n + 1] : starts[n + 1] + batch_size], block
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
            # kernel (compiled once, cached) or on a GPU a tile/window kernel (the shape `hertzian tune` chose, else
            # the shipped rule's), each writing the surface trace inside its launches
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


def detect_needs(base: Scene, candidates: int = 64) -> list:
    """The runs of a first ``hertzian detect`` with BASE, named for :func:`hertzian.core.solvers.prepare.prepare_kernels`:
    the clean forward run, an ensemble of ``candidates`` impurity chains, and the library's assembly kernels (the
    signal's spacing changes no compiled code)."""
    forward = forward_scene(base, base.integrator.dt, 2)
    grains = forward.chain.grains
    impure = impurity_scene(forward, grains // 2, 2.0)
    return [
        Need(features_of([forward]), grains, 1, None, "fused"),
        Need(features_of([forward, impure]), grains, candidates, None, "fused"),
        *library_kernels(forward.integrator.precision),
    ]
