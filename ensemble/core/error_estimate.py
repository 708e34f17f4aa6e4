"""Per-chain error estimate of a run (docs/accuracy.md): a shadow ensemble at twice the step, and Richardson.

The measure is the one ``hertzian accuracy`` reports: max over records and grains of
|u − u_exact| / max|u_exact|. A run with ``record.error_estimate = true`` also integrates every chain
at ``SHADOW_FACTOR``·dt (the same scenes, positions only, no traces, energy or response windows:
about half the run's steps), and estimates, per chain,

    err(dt) ≈ max |u_dt − u_2dt| / (2^p − 1) / max |u_dt|,

with ``p`` the order the method shows on that chain (:func:`chain_orders`): its order on a smooth
chain where no contact opens; 4 for Gear steps with event-aware steps where contacts can open
(kernels/events.py caps gear5/gear6 near 4 there); n (2.5 for Hertz) where a contact opened with plain
steps, n the exponent of the contact potential V ∝ δ^n. That last order follows from the force:
F ∝ δ_+^(n−1) has a (t − t_open)^(n−1) kink in time, so a step that straddles an opening integrates the
acceleration with a local error O(dt^n) in the velocity, and the finitely many openings add up to a
global error O(dt^n). Choosing p below the true order
overestimates the error by (2^p_true − 1)/(2^p − 1); above it, underestimates by the same ratio.

Where a contact opened with plain steps the estimate is marked ``Status.ESTIMATE_UNCERTAIN``: the error
of such a step depends on where in the step the contact opens, a phase that differs between dt and 2·dt,
so |u_dt − u_2dt| / |u − u_exact| scatters over a factor ~30 from chain to chain and no divisor (no
order) puts 95 % of such chains within 3× (docs/accuracy.md). A chain counts as opened when an overlap
is ≤ 0 at a record of the run or its shadow (contacts that open only between records are missed); a
driven chain whose contacts can open counts as opened.

Limits: where trajectories part (a chaotic drive) the difference is of the order of the motion itself
and the estimate is ~1: the run has no accuracy left to report. At round-off (estimates ≲ 1e-13) the
difference measures rounding, not truncation.
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

SMOOTH_ORDER = {"gear4": 4.0, "gear5": 5.0, "gear6": 6.0, "verlet": 2.0, "yoshida4": 4.0, "yoshida6": 6.0}
"""Order of the positions where no contact opens (tests/core/test_order_of_accuracy.py, docs/stability.md §2c, §6)."""
EVENT_ORDER = 4.0
"""Gear methods with event-aware steps where contacts open (docs/stability.md §6b: 3.5–4.1)."""


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
    otherwise, and for gear4 (whose steady-state start has dt⁴ terms in rows 1 and 3, startup.py), the shadow
    computes its own."""
    features = replace(model.features, traces=False)
    start = None
    if model._start is not None and not model.features.compensation and model.features.method != "gear4":
        scale = float(SHADOW_FACTOR) ** np.arange(model._start[1].shape[0])
        start = (features, model._start[1] * scale[:, None, None], None)
    return replace(
        model,
        scenes=shadow_chains(model.scenes),
        features=features,
        dt=SHADOW_FACTOR * model.dt,
        trace_slot=wp.zeros(0, dtype=wp.int32, device=model.device),
        _start=start,
    )


def chain_orders(method: str, *, can_open, opened, exponent, events: bool) -> np.ndarray:
    """Per chain, the convergence order p of the positions used by the Richardson estimate (module docstring):
    ``can_open``, ``opened`` (bool) and ``exponent`` (n) per chain; with ``events`` the event-aware order where
    a contact can open, else n (the potential's exponent) where one opened; the method's smooth order elsewhere."""
    smooth = SMOOTH_ORDER[method]
    if events:
        return np.where(can_open, min(EVENT_ORDER, smooth), smooth)
    return np.where(opened, np.minimum(exponent, smooth), smooth)


def ensemble_can_open(scenes: "Sequence[Scene] | ChainSet | ChainStack") -> np.ndarray:
    """Per chain, whether a contact may open during the run (hertzian.core.model.contact_can_open), bool (chains,)."""
    if isinstance(scenes, ChainStack):
        return np.concatenate([ensemble_can_open(part) for part in scenes.parts])
    if isinstance(scenes, ChainSet):
        return chains_can_open(scenes, static_arrays(scenes))
    return np.array([contact_can_open(s, static_state(s)) for s in scenes], dtype=bool)


def ensemble_contacts(scenes: "Sequence[Scene] | ChainSet | ChainStack") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(δ0 [length], a_c, n) of every chain's padded contacts: shapes (chains, N + 1), (chains, N + 1), (chains,)."""
    if isinstance(scenes, ChainStack):
        parts = [ensemble_contacts(part) for part in scenes.parts]
        return tuple(np.concatenate([p[k] for p in parts]) for k in range(3))
    if isinstance(scenes, ChainSet):
        static = static_arrays(scenes)
        return static.static_overlap, static.contact_constant, np.asarray(static.exponent)
    states = [static_state(s) for s in scenes]
    return (
        np.array([st.static_overlap for st in states]),
        np.array([st.contact_constant for st in states]),
        np.array([st.exponent for st in states], dtype=np.float64),
    )


CHAIN_BLOCK = 256
"""Chains :func:`opened_at_records` and :func:`richardson_error` take at a time: their temporaries stay a few MB
(records × grains × CHAIN_BLOCK values) instead of the ensemble's size, which a 10 000-chain run paid in page faults
(2.3 s for one call at 10 000 × 11 × 500 against 0.2 s in blocks)."""


def opened_at_records(u: np.ndarray, static_overlap: np.ndarray, contact_constant: np.ndarray) -> np.ndarray:
    """Per chain, whether some present contact's overlap is ≤ 0 at some record: ``u`` (chains, records, grains)
    the positions, ``static_overlap`` and ``contact_constant`` (chains, grains + 1) the padded contacts (0 the top
    wall, N the bottom wall, both at rest); bool (chains,)."""
    out = np.zeros(len(u), dtype=bool)
    for lo in range(0, len(u), CHAIN_BLOCK):
        block = np.asarray(u[lo : lo + CHAIN_BLOCK], dtype=np.float64)
        relative = np.concatenate([-block[:, :, :1], block[:, :, :-1] - block[:, :, 1:], block[:, :, -1:]], axis=2)
        overlap = static_overlap[lo : lo + CHAIN_BLOCK, None, :] + relative
        present = contact_constant[lo : lo + CHAIN_BLOCK, None, :] > 0
        out[lo : lo + CHAIN_BLOCK] = np.any((overlap <= 0) & present, axis=(1, 2))
    return out


def model_orders(model: Model, u: np.ndarray, u_shadow: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(:func:`chain_orders` per chain of an ensemble, whether each chain opened a contact with plain steps)
    from the run's positions ``u`` and its shadow's (chains, records, grains)."""
    scenes = model.scenes
    can_open = ensemble_can_open(scenes)
    overlap, present, exponent = ensemble_contacts(scenes)
    seen = opened_at_records(u, overlap, present) | opened_at_records(u_shadow, overlap, present)
    driven = _template(scenes).boundary.surface == "driven"
    opened = can_open & (seen | driven)
    events = model.features.event_window > 0
    orders = chain_orders(model.features.method, can_open=can_open, opened=opened, exponent=exponent, events=events)
    return orders, opened & (not events)


def _template(scenes) -> Scene:
    """A scene of the ensemble (they share the boundary)."""
    if isinstance(scenes, ChainStack):
        return _template(scenes.parts[0])
    return scenes.template if isinstance(scenes, ChainSet) else scenes[0]


def mark_uncertain(status: np.ndarray, uncertain: np.ndarray) -> None:
    """Set ``Status.ESTIMATE_UNCERTAIN`` on the chains of ``uncertain`` still OK (in place)."""
    status[(status == Status.OK) & uncertain] = Status.ESTIMATE_UNCERTAIN


def richardson_error(u: np.ndarray, u_shadow: np.ndarray, order, factor: int = SHADOW_FACTOR) -> np.ndarray:
    """Per chain, max |u − u_shadow| / (factor^order − 1) / max |u| over records and grains [relative].

    ``u``, ``u_shadow``: positions at the same records, shape (chains, records, grains); ``order``: one number, or
    one per chain. A chain whose ``u`` or shadow is not finite gets inf; a chain at rest (max |u| = 0) gets the
    absolute difference."""
    if np.shape(u) != np.shape(u_shadow):
        raise ValueError(f"positions of shape {np.shape(u)} and {np.shape(u_shadow)} are not at the same records")
    chains = np.shape(u)[0]
    difference, scale = np.empty(chains), np.empty(chains)
    axes = tuple(range(1, np.ndim(u)))
    with np.errstate(invalid="ignore"):
        for lo in range(0, chains, CHAIN_BLOCK):
            block = np.asarray(u[lo : lo + CHAIN_BLOCK], dtype=np.float64)
            shadow = np.asarray(u_shadow[lo : lo + CHAIN_BLOCK], dtype=np.float64)
            difference[lo : lo + CHAIN_BLOCK] = np.max(np.abs(block - shadow), axis=axes)
            scale[lo : lo + CHAIN_BLOCK] = np.max(np.abs(block), axis=axes)
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
    """(base interval [time], start exponent j): candidate steps are base/2^j, which put every record (and every
    trace sample: the base is ``record.trace_every`` when set, which divides ``every``) on an even step; j starts at
    the first step ``hertzian check`` calls accurate for ``method``."""
    record = scene.record
    base = next(x for x in (record.trace_every, record.every, scene.integrator.duration) if x is not None)
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
    still_ok = (result.status == Status.OK) | (result.status == Status.ESTIMATE_UNCERTAIN)
    missed = still_ok & ~(result.error_estimate <= integrator.tolerance)
    result.status[missed] = Status.TOLERANCE_MISSED
    return ToleranceChoice(tolerance=integrator.tolerance, result=result, pilot=tuple(pilot))
