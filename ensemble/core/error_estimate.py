"""Per-chain error estimate of a run (SPEC §12): a shadow ensemble at twice the step, and Richardson.

The measure is the one ``hertzian accuracy`` reports: max over records and grains of
|u − u_exact| / max|u_exact|. A run with ``record.error_estimate = true`` also integrates every chain
at ``SHADOW_FACTOR``·dt (the same scenes, positions only, no traces, energy or response windows:
about half the run's steps), and estimates, per chain,

    err(dt) ≈ max |u_dt − u_2dt| / (2^p − 1) / max |u_dt|,

with ``p`` the order the method shows on that scene (:func:`assumed_order`): its order on a smooth
chain where no contact can open; 4 for Gear steps with event-aware steps where contacts open
(kernels/events.py caps gear5/gear6 near 4 there); 2 where contacts open with plain steps
(docs/stability.md §6 measures 2.3 for every Gear order). Choosing p below the true order
overestimates the error by (2^p_true − 1)/(2^p − 1); above it, underestimates by the same ratio.

Limits: two levels cannot measure p per chain, so where convergence is erratic (a plain Gear step
straddling a contact opening, docs/stability.md §6b) the 2·dt run can be much worse than the run
and the estimate overestimates, sometimes by more than 3×. Where trajectories part (a chaotic
drive) the difference is of the order of the motion itself and the estimate is ~1: the run has no
accuracy left to report. At round-off (estimates ≲ 1e-13) the difference measures rounding, not
truncation.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace

import numpy as np
import warp as wp
from hertzian.core.chains import ChainSet, ChainStack
from hertzian.core.check import ACCURATE_STEPS_PER_CONTACT_TIME, check_scene
from hertzian.core.model import Model, chains_can_open, contact_can_open
from hertzian.core.scene import AUTO_METHOD, Scene
from hertzian.core.scene import SHADOW_STEP_FACTOR as SHADOW_FACTOR
from hertzian.core.static import static_arrays, static_state
from hertzian.core.status import Status

ERROR_ESTIMATE_MEANING = (
    "estimated max over records and grains of |u - u_exact| / max|u_exact| (2*dt shadow, Richardson)"
)
"""What ``error_estimate`` holds (store attribute ``long_name``)."""

SMOOTH_ORDER = {"gear4": 4.0, "gear5": 5.0, "gear6": 6.0, "verlet": 2.0, "yoshida4": 4.0}
"""Order of the positions where no contact opens (tests/core/test_order_of_accuracy.py, docs/stability.md §2c, §6)."""
EVENT_ORDER = 4.0
"""Gear methods with event-aware steps where contacts open (docs/stability.md §6b: 3.5–4.1)."""
OPEN_ORDER = 2.0
"""Plain steps where contacts open (docs/stability.md §6: 2.0–2.4 for every Gear order and Verlet)."""


def shadow_overrides(scene: Scene) -> dict:
    """Scene keys that turn a run's scene into its shadow's: twice the step, positions at the same records."""
    return {
        "integrator.dt": SHADOW_FACTOR * scene.integrator.dt,
        "record.fields": ["u"],
        "record.traces": [],
        "record.trace_every": None,
        "record.energy": False,
        "record.response_start": None,
        "record.error_estimate": False,
    }


def shadow_chains(scenes: "Sequence[Scene] | ChainSet | ChainStack"):
    """The shadow ensemble of ``scenes`` (a list of scenes, a ChainSet or a ChainStack), in the same order."""
    if isinstance(scenes, ChainStack):
        return ChainStack([shadow_chains(part) for part in scenes.parts])
    if isinstance(scenes, ChainSet):
        template = scenes.template.with_overrides(shadow_overrides(scenes.template))
        return ChainSet(template=template, values=scenes.values, count=scenes.count)
    return [s.with_overrides(shadow_overrides(s)) for s in scenes]


def shadow_model(model: Model) -> Model:
    """The shadow of a built model: its uploaded per-chain arrays reused, twice the step, no traces. The
    initial state of a float64 ChainSet model is the run's scaled by 2^k per Nordsieck row k (exact in binary);
    otherwise the shadow computes its own."""
    features = replace(model.features, traces=False)
    start = None
    if model._start is not None and not model.features.compensation:
        scale = float(SHADOW_FACTOR) ** np.arange(model._start[1].shape[0])
        start = (features, model._start[1] * scale[:, None, None])
    return replace(
        model,
        scenes=shadow_chains(model.scenes),
        features=features,
        dt=SHADOW_FACTOR * model.dt,
        trace_slot=wp.zeros(0, dtype=wp.int32, device=model.device),
        _start=start,
    )


def assumed_order(method: str, *, can_open, events: bool):
    """The convergence order p of the positions used by the Richardson estimate (module docstring); ``can_open``
    a bool or a per-chain bool array (then p is per chain)."""
    opened = min(EVENT_ORDER, SMOOTH_ORDER[method]) if events else min(OPEN_ORDER, SMOOTH_ORDER[method])
    order = np.where(can_open, opened, SMOOTH_ORDER[method])
    return float(order) if order.ndim == 0 else order


def ensemble_can_open(scenes: "Sequence[Scene] | ChainSet | ChainStack") -> np.ndarray:
    """Per chain, whether a contact may open during the run (hertzian.core.model.contact_can_open), bool (chains,)."""
    if isinstance(scenes, ChainStack):
        return np.concatenate([ensemble_can_open(part) for part in scenes.parts])
    if isinstance(scenes, ChainSet):
        return chains_can_open(scenes, static_arrays(scenes))
    return np.array([contact_can_open(s, static_state(s)) for s in scenes], dtype=bool)


def model_order(model: Model) -> np.ndarray:
    """:func:`assumed_order` per chain of an ensemble: the method's smooth order on chains where no contact can
    open, the event or plain-step order where one can."""
    events = model.features.event_window > 0
    return assumed_order(model.features.method, can_open=ensemble_can_open(model.scenes), events=events)


def richardson_error(u: np.ndarray, u_shadow: np.ndarray, order, factor: int = SHADOW_FACTOR) -> np.ndarray:
    """Per chain, max |u − u_shadow| / (factor^order − 1) / max |u| over records and grains [relative].

    ``u``, ``u_shadow``: positions at the same records, shape (chains, records, grains); ``order``: one number, or
    one per chain. A chain whose ``u`` or shadow is not finite gets inf; a chain at rest (max |u| = 0) gets the
    absolute difference."""
    u = np.asarray(u, dtype=np.float64)
    u_shadow = np.asarray(u_shadow, dtype=np.float64)
    if u.shape != u_shadow.shape:
        raise ValueError(f"positions of shape {u.shape} and {u_shadow.shape} are not at the same records")
    axes = tuple(range(1, u.ndim))
    with np.errstate(invalid="ignore"):
        difference = np.max(np.abs(u - u_shadow), axis=axes)
        scale = np.max(np.abs(u), axis=axes)
    estimate = difference / (factor**order - 1.0) / np.where(scale > 0, scale, 1.0)
    return np.where(np.isfinite(estimate), estimate, math.inf)


TOLERANCE_CANDIDATES = (("gear4", "auto"), ("gear4", "off"), ("gear6", "auto"), ("verlet", "auto"))
"""(method, events) tried by ``integrator.method = "auto"`` with a tolerance."""
MAX_HALVINGS = 12
"""Most halvings (or doublings) of the step a tolerance search takes from its start."""


@dataclass(frozen=True)
class PilotRun:
    """One run of a tolerance search."""

    method: str
    events: str
    dt: float
    """Step [time]."""
    estimate: float
    """Largest error estimate over the chains [relative]."""
    seconds: float
    """Wall seconds of the run, its shadow included."""


@dataclass(frozen=True)
class ToleranceChoice:
    """What ``integrator.tolerance`` chose: the run kept (it met TOL, or the finest tried) and every run tried."""

    tolerance: float
    result: object
    """The RunResult kept; its scenes carry the chosen dt, method and events."""
    pilot: tuple[PilotRun, ...]

    def attrs(self) -> dict:
        """Store attributes: the tolerance, the choice and the pilot's figures (JSON-ready)."""
        scene = self.result.scenes[0]
        return {
            "tolerance": self.tolerance,
            "tolerance_choice": {
                "dt": scene.integrator.dt,
                "method": scene.integrator.method,
                "events": scene.integrator.events,
            },
            "tolerance_pilot": [asdict(p) for p in self.pilot],
        }


def step_ladder(scene: Scene, method: str) -> tuple[float, int]:
    """(base interval [time], start exponent j): candidate steps are base/2^j, which put every record on an
    even step; j starts at the first step ``hertzian check`` calls accurate for ``method``."""
    base = scene.record.every if scene.record.every is not None else scene.integrator.duration
    accurate = check_scene(scene.with_overrides({"integrator.method": method, "integrator.tolerance": None}))
    start = accurate.contact_time / ACCURATE_STEPS_PER_CONTACT_TIME[method]
    j = max(1, math.ceil(math.log2(base / start))) if math.isfinite(start) and start > 0 else 1
    return base, j


def search_step(scenes: list[Scene], method: str, events: str, run, pilot: list) -> tuple[object, bool]:
    """The run at the largest ladder step whose estimate meets the tolerance (``run(scenes) → RunResult``),
    and whether one did; appends each run to ``pilot``."""
    tolerance = scenes[0].integrator.tolerance
    base, j = step_ladder(scenes[0], method)
    tried: dict[int, object] = {}

    def attempt(k: int):
        overrides = {"integrator.tolerance": None, "integrator.method": method, "integrator.events": events}
        overrides |= {"integrator.dt": base / 2**k, "record.error_estimate": True}
        result = run([s.with_overrides(overrides) for s in scenes])
        worst = float(np.max(result.error_estimate))
        pilot.append(
            PilotRun(method, events, base / 2**k, worst, result.wall_seconds + result.timing["error_estimate"])
        )
        tried[k] = result
        return worst <= tolerance

    step = -1 if attempt(j) else 1
    for _ in range(MAX_HALVINGS):
        k = max(tried) + 1 if step > 0 else min(tried) - 1
        if k < 1:
            break
        met = attempt(k)
        if (step < 0 and not met) or (step > 0 and met):
            break
    meeting = [k for k, r in tried.items() if np.max(r.error_estimate) <= tolerance]
    return (tried[min(meeting)], True) if meeting else (tried[max(tried)], False)


def meet_tolerance(scenes: list[Scene], run) -> ToleranceChoice:
    """Run ``scenes`` (sharing ``integrator.tolerance``) at the largest step of the ladder meeting it; with
    ``integrator.method = "auto"`` for each of TOLERANCE_CANDIDATES, keeping the fastest. Chains whose estimate
    misses the tolerance get status TOLERANCE_MISSED."""
    integrator = scenes[0].integrator
    candidates = TOLERANCE_CANDIDATES if integrator.method == AUTO_METHOD else ((integrator.method, integrator.events),)
    pilot: list[PilotRun] = []
    found = [search_step(list(scenes), method, events, run, pilot) for method, events in candidates]
    met = [r for r, ok in found if ok] or [r for r, _ in found]
    result = min(met, key=lambda r: r.wall_seconds)
    missed = (result.status == Status.OK) & ~(result.error_estimate <= integrator.tolerance)
    result.status[missed] = Status.TOLERANCE_MISSED
    return ToleranceChoice(tolerance=integrator.tolerance, result=result, pilot=tuple(pilot))
