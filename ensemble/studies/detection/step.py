"""The forward model's step from the signal's noise (docs/detection.md): model error well below σ.

Ladder: dt = spacing / k, k = 1, 2, 4, … (every sample on a step). The clean chain (BASE) is traced at each
step; the step kept is the largest whose trace differs from the trace at 2·dt by at most σ / NOISE_FRACTION
over the analysed samples (k = 1 against 2·spacing on the even samples). That difference bounds the error of
the trace at dt (Richardson: the error at dt is the difference / (2^p − 1) for a method of order p), so the
model's error stays at or below σ/10 at the step kept. σ is the noise given, or the rms of signal − clean
trace before the earliest possible echo (scoring.estimate_noise); with neither, no step is picked.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from hertzian.core.scene import Scene
from hertzian.studies.detection.forward import forward_scene, run_candidates
from hertzian.studies.detection.scoring import estimate_noise
from hertzian.studies.detection.signal import Signal

NOISE_FRACTION = 10.0
"""The kept step's trace differs from the trace at twice the step by at most σ / NOISE_FRACTION."""
COSTLY_FACTOR = 10.0
"""Warn when BASE's step is more than this many times smaller than the rule's (the library costs ∝ 1/dt)."""
MAX_HALVINGS = 12
"""The finest step tried is spacing / 2^MAX_HALVINGS."""


@dataclass(frozen=True)
class StepChoice:
    """The step the noise asks for, and the one the forward model uses (program units)."""

    dt: float
    """The rule's step [time]."""
    difference: float
    """max |v_dt − v_2dt| over the analysed samples at that step [length/time]."""
    sigma: float
    """σ the rule used [length/time]."""
    used: float
    """The forward model's step [time]: the rule's, or BASE's when BASE sets one."""
    given: bool
    """Whether BASE (its file or --set) sets integrator.dt."""

    def warning(self) -> str | None:
        """One line when BASE's step makes the library more than COSTLY_FACTOR× costlier than the rule's."""
        if not self.given or self.dt <= COSTLY_FACTOR * self.used:
            return None
        return (
            f"BASE integrator.dt gives the forward model dt = {self.used:g}, {self.dt / self.used:.0f}× smaller than "
            f"the noise needs (dt = {self.dt:g} keeps the model within σ/10 = {self.sigma / NOISE_FRACTION:.3g}): "
            "the library costs that much more; leave dt out of BASE to use the rule"
        )

    def to_dict(self) -> dict:
        return asdict(self)


def clean_trace(base: Scene, every: float, count: int, dt: float, device: str) -> np.ndarray:
    """Grain 0's velocity of BASE at t = k·every, k < count, integrated at step ``dt`` (a divisor of ``every``)."""
    forward = forward_scene(base.with_overrides({"integrator.dt": dt}), every, count)
    return run_candidates(forward, [(-1, 1.0)], 1, device)[0][0]


def noise_step(
    signal: Signal,
    base: Scene,
    fronts: np.ndarray,
    first_depth: int,
    noise: float | None,
    device: str,
    *,
    given: float | None = None,
) -> StepChoice | None:
    """The largest ladder step whose clean trace is within σ/10 of the trace at twice the step (module docstring);
    the finest tried when none is; None when σ is neither given nor estimable before the earliest echo. ``given``:
    the forward model's step when BASE sets one [time] (None: the rule's step is used)."""
    spacing, count = signal.spacing, signal.sample_count
    coarse = clean_trace(base, 2 * spacing, (count + 1) // 2, 2 * spacing, device)
    previous, dt = None, spacing
    for _ in range(MAX_HALVINGS + 1):
        v = clean_trace(base, spacing, count, dt, device)
        sigma = noise if noise is not None else estimate_noise(signal, v, fronts, first_depth)[0]
        if sigma is None:
            return None
        difference = float(np.max(np.abs(v[::2] - coarse) if previous is None else np.abs(v - previous)))
        if difference <= sigma / NOISE_FRACTION:
            break
        previous, dt = v, dt / 2
    else:
        dt *= 2
    used = dt if given is None else given
    return StepChoice(dt=dt, difference=difference, sigma=float(sigma), used=used, given=given is not None)
