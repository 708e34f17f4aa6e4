"""Checks of the per-point error estimate (ensemble/core/error_estimate.py) against the true error, and its cost.

**Check.** Every point of a sweep is run with ``record.error_estimate`` (once per event setting) and, as
reference, with gear6 at the step divided by ``reference_divisor`` (event-aware steps), itself checked
against gear6 at twice that step (Richardson at order 4, the event-aware order where contacts open:
an upper bound of the reference's error where the order is 6). The true error of a point is
max over records and grains |u − u_ref| / max|u_ref|; a point passes when estimate / true error lies in
[1/3, 3]. The fraction is also given apart for points whose estimate is marked ESTIMATE_UNCERTAIN (a contact
opened with plain steps) and the others. Points whose true error is within ``RESOLVED_FACTOR`` of the reference's own error are not
resolved by the reference: they are listed and left out of the fraction.

**Cost.** The same ensemble run with and without the estimate, alternately, ``repeats`` times; the ratio of
the median totals (run, shadow and their set-up; kernel compilation done before).
"""

from __future__ import annotations

import statistics
import time

import numpy as np
from hertzian.core.devices import default_device, init_warp
from hertzian.core.error_estimate import ensemble_can_open
from hertzian.core.model import build_model
from hertzian.core.runner import Runner, run_ensemble
from hertzian.core.scene import Scene
from hertzian.core.status import Status
from hertzian.studies.accuracy import REFERENCE_METHOD, RESOLVED_FACTOR, TimeToTarget, time_to_target, work_precision

ESTIMATE_FACTOR = 3.0
"""An estimate within this factor of the true error passes (issue target: on ≥ 95 % of the points)."""


def chain_errors(u: np.ndarray, u_ref: np.ndarray) -> np.ndarray:
    """Per chain, max |u − u_ref| / max |u_ref| over records and grains [relative]; ``u`` (chains, records, grains)."""
    axes = tuple(range(1, np.ndim(u)))
    with np.errstate(invalid="ignore"):
        error = np.max(np.abs(np.asarray(u) - u_ref), axis=axes) / np.max(np.abs(u_ref), axis=axes)
    return np.where(np.isfinite(error), error, np.inf)


def _reference(scenes: list[Scene], divisor: int, device: str) -> tuple[np.ndarray, np.ndarray, float]:
    """(u_ref, its estimated error per chain, seconds): gear6 at dt/divisor, checked against dt/(divisor/2)."""
    clock = time.perf_counter()
    runs = []
    for d in (divisor, divisor // 2):
        overrides = {"integrator.method": REFERENCE_METHOD, "integrator.events": "auto", "record.error_estimate": False}
        overrides["integrator.dt"] = scenes[0].integrator.dt / d
        runs.append(run_ensemble([s.with_overrides(overrides) for s in scenes], device).u)
    return runs[0], chain_errors(runs[1], runs[0]) / (2.0**4 - 1.0), time.perf_counter() - clock


def estimate_check(
    scenes: list[Scene], *, device: str | None = None, events=("auto", "off"), reference_divisor: int = 16
) -> dict:
    """Estimate against true error on every scene (an ensemble: they share the step and records), per event
    setting; JSON-ready (module docstring)."""
    init_warp()
    device = device or default_device()
    u_ref, ref_error, ref_seconds = _reference(scenes, reference_divisor, device)
    can_open = ensemble_can_open(scenes)
    out = {
        "points": len(scenes),
        "device": device,
        "method": scenes[0].integrator.method,
        "dt": scenes[0].integrator.dt,
        "reference": {"method": REFERENCE_METHOD, "dt": scenes[0].integrator.dt / reference_divisor},
        "reference_seconds": ref_seconds,
        "can_open": can_open.tolist(),
        "factor": ESTIMATE_FACTOR,
        "events": {},
    }
    for setting in events:
        result = run_ensemble(
            [s.with_overrides({"integrator.events": setting, "record.error_estimate": True}) for s in scenes], device
        )
        true = chain_errors(result.u, u_ref)
        ratio = result.error_estimate / true
        resolved = true > RESOLVED_FACTOR * ref_error
        within = (ratio <= ESTIMATE_FACTOR) & (ratio >= 1 / ESTIMATE_FACTOR)
        uncertain = result.status == Status.ESTIMATE_UNCERTAIN
        out["events"][setting] = {
            "fraction_within": float(np.mean(within[resolved])) if resolved.any() else None,
            "resolved_points": int(resolved.sum()),
            "fraction_within_where_contacts_open": _fraction(within, resolved & can_open),
            "fraction_within_where_none_open": _fraction(within, resolved & ~can_open),
            "ratio_range": [float(np.min(ratio[resolved])), float(np.max(ratio[resolved]))] if resolved.any() else None,
            "uncertain_points": int(uncertain.sum()),
            "fraction_within_where_not_uncertain": _fraction(within, resolved & ~uncertain),
            "fraction_within_where_uncertain": _fraction(within, resolved & uncertain),
            "uncertain": uncertain.tolist(),
            "estimate": result.error_estimate.tolist(),
            "true_error": true.tolist(),
            "reference_error": ref_error.tolist(),
            "seconds": result.wall_seconds,
            "estimate_seconds": result.timing["error_estimate"],
        }
    return out


def _fraction(within: np.ndarray, where: np.ndarray) -> float | None:
    return float(np.mean(within[where])) if where.any() else None


def estimate_cost(scenes: list[Scene], *, device: str | None = None, kernel: str = "auto", repeats: int = 3) -> dict:
    """Median wall seconds of the ensemble with and without ``record.error_estimate`` (alternating, after one
    untimed pass that compiles both), and their ratio; JSON-ready."""
    init_warp()
    device = device or default_device()
    totals: dict[bool, list[float]] = {False: [], True: []}
    kernel_name = ""
    for rep in range(repeats + 1):
        for estimate in (False, True):
            clock = time.perf_counter()
            model = build_model([s.with_overrides({"record.error_estimate": estimate}) for s in scenes], device)
            result = Runner(model, kernel=kernel).run()
            if rep:
                totals[estimate].append(time.perf_counter() - clock)
            kernel_name = result.kernel
    plain, with_estimate = statistics.median(totals[False]), statistics.median(totals[True])
    return {
        "device": device,
        "kernel": kernel_name,
        "chains": len(scenes),
        "grains": scenes[0].chain.grains,
        "steps": scenes[0].step_count,
        "seconds_without": totals[False],
        "seconds_with": totals[True],
        "ratio": with_estimate / plain,
    }


def cost_scenes(chains: int = 64, grains: int = 200, duration: float = 1.0) -> list[Scene]:
    """The cost case: the shipped impact example cut to ``grains`` grains and ``duration`` [time], no traces,
    ``chains`` impact speeds from 1e-2 to 1.63e-2 (l0 = 1e-4, gear4, dt = 5e-5)."""
    from hertzian.core.scene import load_scene
    from hertzian.core.shipped import example_path

    base = load_scene(example_path("impact")).with_overrides(
        {"chain.grains": grains, "integrator.duration": duration, "record.every": duration / 10}
        | {"record.traces": [], "record.trace_every": None}
    )
    return [base.with_overrides({"excitation.impact": 1e-2 * (1 + 0.01 * i)}) for i in range(chains)]


COST_FEATURES = {
    "walls": {},
    "gravity, impurities": {"chain.gravity": 1.0},
    "drive": {
        "boundary.surface": "driven",
        "excitation.impact": 0.0,
        "excitation.drive_amplitude": 1e-4,
        "excitation.drive_period": 1.0,
    },
    "viscous damping": {"damping.model": "viscous", "damping.gamma": 0.01},
    "contact damping": {"damping.model": "contact", "damping.gamma": 0.01},
}
"""The feature cases of :func:`feature_costs`: overrides of the cost case (whose ends are walls); the gravity case
also buries three light grains (mass 0.5, a = 2000, harmonic contacts) at grains 100-102."""
COST_IMPURITIES = [{"grains": [100, 101, 102], "mass": 0.5, "a": 2000.0, "contact": "harmonic"}]


def feature_cost_scenes(case: str, chains: int = 64) -> list[Scene]:
    """The cost case (:func:`cost_scenes`) with the features of ``COST_FEATURES[case]``."""
    from hertzian.core.scene import scene_from_dict

    scenes = [s.with_overrides(COST_FEATURES[case]) for s in cost_scenes(chains)]
    if case != "gravity, impurities":
        return scenes
    return [scene_from_dict({**s.to_dict(), "impurities": COST_IMPURITIES}) for s in scenes]


def feature_costs(device: str, kernels: list[str], chains: int, repeats: int = 3, progress=None) -> list[dict]:
    """:func:`estimate_cost` of every ``COST_FEATURES`` case on each of ``kernels``: one row per (case, kernel),
    with ``case`` and ``kernel_asked`` added; JSON-ready."""
    rows = []
    for case in COST_FEATURES:
        for kernel in kernels:
            if progress:
                progress(f"{case}, kernel {kernel}")
            row = estimate_cost(feature_cost_scenes(case, chains), device=device, kernel=kernel, repeats=repeats)
            rows.append({"case": case, "kernel_asked": kernel, **row})
    return rows


DEFAULTS_TARGETS = (1e-4, 1e-6, 1e-8)
"""Position-error targets of the defaults study (max |u − u_ref| / max|u_ref|)."""
DEFAULTS_METHODS = ("gear4", "gear6", "verlet")
DEFAULTS_STEPS = (1e-3, 5e-4, 2.5e-4, 1.25e-4, 6.25e-5)
"""Steps of the defaults study [time]; the gear6 reference runs at the smallest / 4."""


def defaults_scenes() -> dict[str, Scene]:
    """The defaults study's scenes (program units, positions every 0.1, no traces): the shipped impact example
    cut to 400 grains, its pulse still in the bulk at the end (l0 = 1e-4, duration 10); the same chain loose
    (l0 = 0: contacts open behind the pulse); the precompressed chain cut to 100 grains, its pulse striking the
    bottom wall and coming back (duration 16)."""
    from hertzian.core.scene import load_scene
    from hertzian.core.shipped import example_path

    base = load_scene(example_path("impact")).with_overrides(
        {"chain.grains": 400, "record.every": 0.1, "record.fields": ["u"], "record.traces": []}
        | {"record.trace_every": None, "integrator.duration": 10.0}
    )
    return {
        "impact": base,
        "loose": base.with_overrides({"chain.l0": 0.0}),
        "wall": base.with_overrides({"chain.grains": 100, "integrator.duration": 16.0}),
    }


def defaults_study(
    device: str | None = None,
    *,
    scenes: dict[str, Scene] | None = None,
    methods=DEFAULTS_METHODS,
    dts=DEFAULTS_STEPS,
    targets=DEFAULTS_TARGETS,
    progress=None,
) -> dict:
    """Time to accuracy per scene: every method × events (auto, off) × dt run against a gear6 reference
    (hertzian.studies.accuracy.work_precision, float64), and per target the cheapest (method, events, dt) whose
    position error meets it (time_to_target, measure "error"), overall and per event setting; JSON-ready."""
    init_warp()
    device = device or default_device()
    out = {"device": device, "date": time.strftime("%Y-%m-%d"), "targets": list(targets), "scenes": {}}
    for name, scene in (scenes or defaults_scenes()).items():
        if progress:
            progress(name)
        records, reference, _ = work_precision(
            scene, list(methods), list(dts), ["float64"], device=device, events=["auto", "off"]
        )
        rows = time_to_target(records, list(targets), "error")
        out["scenes"][name] = {
            "grains": scene.chain.grains,
            "l0": scene.chain.l0,
            "duration": scene.integrator.duration,
            "reference": {"dt": reference.dt, "error_estimate": reference.error_estimate},
            "records": [r.to_dict() for r in records],
            "cheapest": {str(t): _cheapest(rows, t) for t in targets},
            "cheapest_per_events": {
                str(t): {e: _cheapest([r for r in rows if r.events == e], t) for e in ("auto", "off")} for t in targets
            },
        }
    return out


def _cheapest(rows: list[TimeToTarget], target: float) -> dict | None:
    """The first (cheapest) row of ``target`` that met it, as a dict, or None."""
    met = [r for r in rows if r.target == target and r.dt is not None]
    return met[0].to_dict() if met else None
