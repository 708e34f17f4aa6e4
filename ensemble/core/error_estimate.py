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

import numpy as np
from hertzian.core.chains import ChainSet, ChainStack
from hertzian.core.model import Model, chain_set_can_open, contact_can_open
from hertzian.core.scene import SHADOW_STEP_FACTOR as SHADOW_FACTOR
from hertzian.core.scene import Scene
from hertzian.core.static import static_arrays, static_state

ERROR_ESTIMATE_MEANING = "estimated max over records and grains of |u - u_exact| / max|u_exact| (2*dt shadow, Richardson)"
"""What ``error_estimate`` holds (store attribute ``long_name``)."""

SMOOTH_ORDER = {"gear4": 4.0, "gear5": 5.0, "gear6": 6.0, "verlet": 2.0, "yoshida4": 4.0}
"""Order of the positions where no contact opens (tests/test_order.py, docs/stability.md §2c, §6)."""
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


def assumed_order(method: str, *, can_open: bool, events: bool) -> float:
    """The convergence order p of the positions used by the Richardson estimate (module docstring)."""
    if not can_open:
        return SMOOTH_ORDER[method]
    if events:
        return min(EVENT_ORDER, SMOOTH_ORDER[method])
    return min(OPEN_ORDER, SMOOTH_ORDER[method])


def ensemble_can_open(scenes: "Sequence[Scene] | ChainSet | ChainStack") -> bool:
    """Whether a contact of any chain may open during the run (hertzian.core.model.contact_can_open)."""
    if isinstance(scenes, ChainStack):
        return any(ensemble_can_open(part) for part in scenes.parts)
    if isinstance(scenes, ChainSet):
        return chain_set_can_open(scenes, static_arrays(scenes))
    return any(contact_can_open(s, static_state(s)) for s in scenes)


def model_order(model: Model) -> float:
    """:func:`assumed_order` of an ensemble's method, contacts and event setting."""
    events = model.features.event_window > 0
    can_open = events or ensemble_can_open(model.scenes)
    return assumed_order(model.features.method, can_open=can_open, events=events)


def richardson_error(u: np.ndarray, u_shadow: np.ndarray, order: float, factor: int = SHADOW_FACTOR) -> np.ndarray:
    """Per chain, max |u − u_shadow| / (factor^order − 1) / max |u| over records and grains [relative].

    ``u``, ``u_shadow``: positions at the same records, shape (chains, records, grains). A chain whose
    ``u`` or shadow is not finite gets inf; a chain at rest (max |u| = 0) gets the absolute difference."""
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
