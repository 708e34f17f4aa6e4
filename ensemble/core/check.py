"""Is a scene's time step safe? An estimate of the stiffest contact time scale, before running.

The Hertz force ``F = n a δ^(n−1)`` stiffens with the overlap: the linearised stiffness of a
contact is ``k = dF/dδ = n (n−1) a_c δ^(n−2)``, so the fastest motion in a run is set by the
largest overlap the run can reach. That overlap is bounded by energy, scene by scene:

* **static overlaps** ``δ0`` of every contact (precompression, gravity at the bottom of a column,
  impurity constants): :func:`hertzian.core.static.static_state`;
* **an impact** puts ``E = ½ m_0 v_imp²`` into the chain. The energy relative to the static state
  is ``Σ ½ m v² + Σ_c [V(δ_c) − V(δ0_c) − V'(δ0_c)(δ_c − δ0_c)]`` (docs/architecture.md), a sum of
  non-negative terms (V is convex) that is conserved, so no contact's excess potential can exceed
  ``E``: solving ``V(δ0 + d) − V(δ0) − V'(δ0) d = E`` for each contact gives a rigorous upper bound
  ``δ0 + d`` on its overlap;
* **a drive** ``u_0 = A sin(2πt/τ)`` can push the first contact by up to ``A`` and throw grain 1
  off at up to twice the drive's top speed ``Aω``; its energy budget is taken as
  ``½ m_1 (2Aω)²`` (an estimate, not a bound: a resonant drive can pump more in over many periods).

Each contact's period ``T_c = 2π sqrt(m_red/k_c)`` (``m_red`` = reduced mass of the two grains, the
grain's own mass at a wall or against a held grain) gives the **contact time** ``T = min_c T_c``;
``T/dt`` is the number of steps per contact time. Two criteria use them:

* **stability** — the explicit methods are stable on a linear chain while ``ω_max·dt`` stays below
  a limit per method (:data:`STABLE_OMEGA_DT`), ``ω_max`` being the chain's highest normal-mode
  frequency with every contact at its largest overlap at once (bounded above by Gershgorin's
  theorem on ``M^(−1/2) K M^(−1/2)``; exact for two grains between walls, and ``√2·2π/T`` for a
  uniform chain). The limits come from the spectral radius ρ of each method's one-step
  amplification matrix on ``ü = −ω² u`` (:func:`amplification_matrix`): velocity Verlet ρ = 1 up to
  ``ω dt = 2``; yoshida4 (three Verlet substeps) ρ = 1 up to ``ω dt = 1.5734``; gear4 is damped (ρ < 1) up to ``√2``; gear5 and gear6 grow weakly at any step
  (ρ slightly above 1, ~1e-6 per period at ω dt ≈ 0.1) and break down at 1.12 and 0.85, where the
  growth reaches 10 % per period. ``tests/core/test_check.py`` confirms each limit with the Warp kernels
  on a linear (n = 2) chain on either side of it.
* **accuracy** — the energy error falls as a power of ``dt/T``. The steps per contact time that kept
  it below 1e-6 in every extreme case of the stability suite (impact speeds 1e-6 … 10, l0 = 0 …
  1e-2, impurity mass and a ratios 1e-3 … 1e3, n = 2 … 3, g = 100) are
  :data:`ACCURATE_STEPS_PER_CONTACT_TIME` (docs/stability.md): 400 for gear4 and gear6, 300 for
  gear5, 3200 for Verlet (second order), 400 for yoshida4 (whose step costs three force evaluations). The suggested dt is ``T`` divided by that number, rounded
  down to 1, 1.25, 1.6, 2, 2.5, 3.2, 4, 5, 6.4 or 8 × a power of ten, and never above the stability
  limit (with a factor 2 of margin).

The estimates are conservative (every contact at its bound at once); a real run reaches smaller
overlaps, so a scene flagged inaccurate may still meet the tolerance. ``hertzian accuracy``
measures it.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np
from hertzian.core.modes import injected_energy
from hertzian.core.potentials import law_of
from hertzian.core.scene import VALIDITY_FRACTION, Scene
from hertzian.core.static import static_state, validity_scale
from hertzian.kernels.features import GEAR_CORRECTOR, SUBSTEP_WEIGHTS

STABLE_OMEGA_DT = {
    "verlet": 2.0,
    "gear4": math.sqrt(2.0),
    "gear5": 1.12,
    "gear6": 0.85,
    "yoshida4": 1.5734,
    "yoshida6": 2.2690,
}
"""Largest ω_max·dt for which each method is stable on a linear chain (see the module docstring).
yoshida4: the one-step matrix on ü = −ω²u is the product of its three velocity-Verlet substep matrices
(w1, w0, w1)·dt (:func:`amplification_matrix`); it has determinant 1 on (u, v), so it is stable while
|trace/2| ≤ 1. Bisection of |trace/2| = 1 gives ω dt = 1.573402 (first crossing; rounded down here,
recomputed by tests/core/test_check.py). yoshida6 likewise, over its seven substeps: ω dt = 2.269058."""

ACCURATE_STEPS_PER_CONTACT_TIME = {
    "gear4": 400.0,
    "gear5": 300.0,
    "gear6": 400.0,
    "verlet": 3200.0,
    "yoshida4": 400.0,
    "yoshida6": 150.0,
}
"""Steps per contact time T/dt that keep the energy error below 1e-6 in every case of the extreme-case suite with
either event setting (the larger of the two: the check does not ask which one a run takes; hertzian.studies.thresholds,
record docs/records/accuracy/composed.json, keys thresholds_gear_verlet and thresholds; docs/stability.md §3
"Accuracy thresholds", §5 and §2c)."""

STABILITY_MARGIN = 2.0
"""The suggested dt stays this factor below the stability limit."""


@dataclass(frozen=True)
class StepCheck:
    """What :func:`check_scene` found; lengths, masses and times in program units."""

    method: str
    dt: float
    """The scene's time step [time]."""
    largest_overlap: float
    """Largest overlap any contact can reach (static + impact/drive bound) [length]; where the radii differ, that
    of the contact nearest its own validity limit (:attr:`validity_contact`)."""
    stiffest_contact: int
    """Padded index of the contact with the shortest period: k joins grains k−1 and k (0, N: walls)."""
    stiffness: float
    """Linearised stiffness n(n−1) a_c δ^(n−2) of that contact at its largest overlap [force/length]."""
    reduced_mass: float
    """Reduced mass of that contact [mass]."""
    contact_time: float
    """T = 2π sqrt(m_red/k) of the stiffest contact [time]."""
    highest_frequency: float
    """Upper bound on the chain's highest angular frequency ω_max [1/time]."""
    validity_overlap: float
    """That contact's validity limit VALIDITY_FRACTION·2·min(R_i, R_j) [length]: VALIDITY_FRACTION·diameter
    (ChainSpec.validity_overlap) for equal grains."""
    notes: tuple[str, ...] = field(default_factory=tuple)
    validity_contact: int = -1
    """Padded index of the contact whose overlap bound is the largest fraction of its own validity limit (k joins
    grains k−1 and k; 0, N: walls); -1 when nothing touches."""
    accepted_steps: float | None = None
    """The scene's ``integrator.accepted_steps_per_contact`` (None: the method's accuracy rule only)."""
    pulse_rule: bool = True
    """Whether the accuracy rule (steps per contact time, measured on Hertz pulses) applies; a lattice law's dt is
    judged by stability only."""

    @property
    def steps_per_contact_time(self) -> float:
        """T/dt."""
        return self.contact_time / self.dt

    @property
    def omega_dt(self) -> float:
        """ω_max·dt, compared with STABLE_OMEGA_DT[method]."""
        return self.highest_frequency * self.dt

    @property
    def stable(self) -> bool:
        """ω_max·dt below the method's linear stability limit."""
        return self.omega_dt <= STABLE_OMEGA_DT[self.method]

    @property
    def accurate(self) -> bool:
        """Enough steps per contact time for an energy error below ~1e-6 (see ACCURATE_STEPS_PER_CONTACT_TIME)."""
        return self.steps_per_contact_time >= ACCURATE_STEPS_PER_CONTACT_TIME[self.method]

    @property
    def beyond_validity(self) -> bool:
        """Whether the largest overlap may exceed the validity overlap (Hertz law not trusted there)."""
        return self.largest_overlap > self.validity_overlap

    @property
    def suggested_dt(self) -> float:
        """T / (accurate steps per contact time), capped by the stability limit / STABILITY_MARGIN [time]."""
        if not math.isfinite(self.contact_time):
            return math.inf
        accurate = self.contact_time / ACCURATE_STEPS_PER_CONTACT_TIME[self.method] if self.pulse_rule else math.inf
        stable = STABLE_OMEGA_DT[self.method] / STABILITY_MARGIN / self.highest_frequency
        return _round_down(min(accurate, stable))

    @property
    def verdict(self) -> str:
        """'unstable', 'inaccurate', 'accepted' (inaccurate by the rule, with at least the scene's accepted steps per
        contact time) or 'ok'."""
        if not self.stable:
            return "unstable"
        if self.accurate or not self.pulse_rule:
            return "ok"
        if self.accepted_steps is not None and self.steps_per_contact_time >= self.accepted_steps:
            return "accepted"
        return "inaccurate"

    def warning(self) -> str | None:
        """One line when dt looks unsafe (unstable, or inaccurate and not accepted by the scene), else None."""
        if self.verdict in ("ok", "accepted"):
            return None
        what = (
            "unstable: ω_max·dt = {:.3g} > {:.3g}".format(self.omega_dt, STABLE_OMEGA_DT[self.method])
            if self.verdict == "unstable"
            else "inaccurate: {:.3g} steps per contact time < {:.0f}".format(
                self.steps_per_contact_time, ACCURATE_STEPS_PER_CONTACT_TIME[self.method]
            )
        )
        return (
            f"integrator.dt = {self.dt:g} looks {what} for {self.method} "
            f"(contact time {self.contact_time:.3g}); suggested dt ≤ {self.suggested_dt:.3g} "
            "(hertzian check for details)"
        )

    def to_dict(self) -> dict:
        """Plain data (JSON-ready), derived values included."""
        return {
            "method": self.method,
            "dt": self.dt,
            "largest_overlap": self.largest_overlap,
            "validity_overlap": self.validity_overlap,
            "beyond_validity": self.beyond_validity,
            "validity_contact": self.validity_contact,
            "stiffest_contact": self.stiffest_contact,
            "stiffness": self.stiffness,
            "reduced_mass": self.reduced_mass,
            "contact_time": self.contact_time,
            "steps_per_contact_time": self.steps_per_contact_time,
            "highest_frequency": self.highest_frequency,
            "omega_dt": self.omega_dt,
            "stable_omega_dt": STABLE_OMEGA_DT[self.method],
            "stable": self.stable,
            "accurate_steps_per_contact_time": ACCURATE_STEPS_PER_CONTACT_TIME[self.method],
            "accurate": self.accurate,
            "accepted_steps_per_contact": self.accepted_steps,
            "verdict": self.verdict,
            "suggested_dt": self.suggested_dt,
            "notes": list(self.notes),
        }


STEP_MANTISSAS = (8.0, 6.4, 5.0, 4.0, 3.2, 2.5, 2.0, 1.6, 1.25, 1.0)
"""Suggested steps are these × a power of ten: the paper's 1.25e-5 times powers of two, and 1, 2, 4, 5, 8."""


def _round_down(x: float) -> float:
    """x rounded down to a mantissa of STEP_MANTISSAS × a power of ten (a step a user would write)."""
    if not (x > 0 and math.isfinite(x)):
        return x
    exp = math.floor(math.log10(x))
    for mantissa in STEP_MANTISSAS:
        step = float(f"{mantissa}e{exp}")
        if step <= x * (1 + 1e-12):
            return step
    return float(f"1e{exp}")


def excess_potential(delta0: np.ndarray, d: np.ndarray, a_c: np.ndarray, n: float) -> np.ndarray:
    """V(δ0 + d) − V(δ0) − V'(δ0)·d for d ≥ 0 (V = a_c δ^n), elementwise [energy]."""
    delta0 = np.asarray(delta0, dtype=float)
    d = np.asarray(d, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(delta0 > 0, d / np.where(delta0 > 0, delta0, 1.0), np.inf)
        # (1 + r)^n − 1 − n r without cancellation for small r, via expm1/log1p
        small = np.abs(ratio) < 1e-3
        series = n * (n - 1) / 2 * ratio**2 * (1 + (n - 2) / 3 * ratio)
        big = np.expm1(n * np.log1p(np.where(small, 0.0, ratio))) - n * np.where(small, 0.0, ratio)
        relative = np.where(small, series, big)
        loaded = a_c * delta0**n * relative
    return np.where(delta0 > 0, loaded, a_c * d**n)


def overlap_reach(delta0: np.ndarray, a_c: np.ndarray, n: float, energy: float) -> np.ndarray:
    """d ≥ 0 with excess_potential(δ0, d) = energy, per contact (bisection on a log scale) [length]."""
    delta0 = np.asarray(delta0, dtype=float)
    a_c = np.asarray(a_c, dtype=float)
    if energy <= 0:
        return np.zeros_like(delta0)
    low = np.zeros_like(delta0)
    high = np.maximum((energy / a_c) ** (1.0 / n), delta0) * 2.0 + 1e-300
    while np.any(grow := excess_potential(delta0, high, a_c, n) < energy):
        high = np.where(grow, high * 4.0, high)
    for _ in range(200):
        mid = 0.5 * (low + high)
        below = excess_potential(delta0, mid, a_c, n) < energy
        low, high = np.where(below, mid, low), np.where(below, high, mid)
        if np.all(high - low <= 1e-13 * high):
            break
    return high


def lattice_stiffness(law, delta0: np.ndarray, a_c: np.ndarray, energy: float, drive: np.ndarray) -> np.ndarray:
    """The largest F'(δ) of each contact of a lattice law over the overlaps ``energy`` can reach from δ0, both ways
    (excess potential V(δ0 + d) − V(δ0) − F(δ0) d ≤ energy, bisection; 65 samples of F' in between), or over
    ±``drive`` where that is wider. Lennard-Jones contacts stop short of touching (ρ > 0)."""
    pairs, where = np.unique(np.stack([delta0, a_c, drive], axis=1), axis=0, return_inverse=True)
    out = np.zeros(len(pairs))
    for k, (d0, a, reach) in enumerate(pairs.tolist()):

        def excess(d: float, d0=d0, a=a) -> float:
            return float(law.potential(d0 + d, a) - law.potential(d0, a) - law.force(d0, a) * d)

        ends = []
        for sign in (1.0, -1.0):
            cap = law.rising_limit() - d0 if sign > 0 else math.inf
            cap = 0.999 * cap if math.isfinite(cap) else math.inf
            high = 1e-12
            while excess(sign * high) < energy and high < cap and high < 1e12:
                high *= 2.0
            high = min(high, cap)
            low = 0.0
            for _ in range(100):
                mid = 0.5 * (low + high)
                low, high = (mid, high) if excess(sign * mid) < energy else (low, mid)
            ends.append(max(high, reach))
        grid = d0 + np.linspace(-ends[1], ends[0], 65)
        out[k] = float(np.max(law.stiffness(grid, a)))
    return out[np.ravel(where)]


def injected_energy_bound(scene: Scene, mass: np.ndarray) -> tuple[float, list[str]]:
    """Energy an excitation can put into contacts (impact: exact; drive: estimate) [energy], with notes."""
    e = scene.excitation
    if scene.boundary.surface == "driven":
        omega = 2.0 * math.pi / e.drive_period
        speed = 2.0 * e.drive_amplitude * omega
        return 0.5 * mass[1] * speed**2, [
            f"drive: energy budget ½ m_1 (2Aω)² = {0.5 * mass[1] * speed**2:.3g} is an estimate "
            "(a resonant drive can pump in more over many periods)"
        ]
    if e.modes or e.thermal:
        return injected_energy(scene), []
    return 0.5 * mass[0] * e.impact**2, []


def check_scene(scene: Scene) -> StepCheck:
    """Estimate the stiffest contact time scale of ``scene`` and judge its dt (see the module docstring)."""
    st = static_state(scene)
    n = st.exponent
    n_grains = st.grain_count
    mass = st.mass
    a_c = st.contact_constant
    delta0 = st.static_overlap
    driven = scene.boundary.surface == "driven"
    fixed = scene.boundary.bottom == "fixed"
    notes: list[str] = []

    # which grains move: a driven surface grain and a fixed bottom grain are held (infinite mass)
    inverse_mass = 1.0 / mass
    if driven:
        inverse_mass[0] = 0.0
    if fixed:
        inverse_mass[-1] = 0.0
    # padded contact k joins grains k-1 and k; walls are held
    ring = scene.boundary.surface == "periodic"  # the end slots are the contact of grains N − 1 and 0
    above = np.concatenate([[inverse_mass[-1] if ring else 0.0], inverse_mass])
    below = np.concatenate([inverse_mass, [inverse_mass[0] if ring else 0.0]])
    inverse_reduced = above + below
    exists = (a_c > 0) & (inverse_reduced > 0)

    energy, excitation_notes = injected_energy_bound(scene, mass)
    notes += excitation_notes
    law = law_of(scene.chain)
    reach = np.zeros_like(delta0)
    if not law.lattice:
        reach[exists] = overlap_reach(delta0[exists], a_c[exists], n, energy)
    if driven and exists[1]:
        reach[1] = max(reach[1], scene.excitation.drive_amplitude)
    largest = delta0 + reach

    with np.errstate(divide="ignore", invalid="ignore"):
        if law.lattice:
            stiffness = np.zeros_like(delta0)
            stiffness[exists] = lattice_stiffness(law, delta0[exists], a_c[exists], energy, reach[exists])
        elif n >= 2.0:
            stiffness = n * (n - 1.0) * a_c * largest ** (n - 2.0)
        else:
            # n < 2: k = n(n−1)aδ^(n−2) grows without bound as δ → 0; use the secant F(δ)/δ at δ_max
            stiffness = n * a_c * largest ** (n - 2.0)
            notes.append(
                "n < 2: the contact stiffness is unbounded at zero overlap; the estimate uses "
                "F(δ)/δ at the largest overlap and may be optimistic"
            )
    stiffness = np.where(exists & np.isfinite(stiffness), stiffness, 0.0)
    omega2 = stiffness * inverse_reduced
    if not np.any(omega2 > 0):
        notes.append("no loaded contact: nothing ever touches with a positive stiffness")
        return StepCheck(
            method=scene.integrator.method,
            dt=scene.integrator.dt,
            largest_overlap=0.0,
            stiffest_contact=-1,
            stiffness=0.0,
            reduced_mass=math.inf,
            contact_time=math.inf,
            highest_frequency=0.0,
            validity_overlap=scene.chain.validity_overlap,
            notes=tuple(notes),
            accepted_steps=scene.integrator.accepted_steps_per_contact,
        )
    k_star = int(np.argmax(omega2))

    # Gershgorin bound on the highest eigenvalue of M^(-1/2) K M^(-1/2) (moving grains only)
    sqrt_inv = np.sqrt(inverse_mass)
    k_above, k_below = stiffness[:-1], stiffness[1:]
    diagonal = (k_above + k_below) * inverse_mass
    off = np.zeros(n_grains)
    off[1:] += k_above[1:] * sqrt_inv[1:] * sqrt_inv[:-1]
    off[:-1] += k_below[:-1] * sqrt_inv[:-1] * sqrt_inv[1:]
    if ring:
        off[0] += k_above[0] * sqrt_inv[0] * sqrt_inv[-1]
        off[-1] += k_below[-1] * sqrt_inv[-1] * sqrt_inv[0]
    omega_max = math.sqrt(float(np.max(diagonal + off)))

    if law.lattice:
        notes.append(
            "the accuracy rule (steps per contact time) was measured on Hertz pulses: for a lattice law only "
            "stability is judged; check accuracy by halving dt"
        )
    if n > 3.0 and not law.lattice:
        notes.append(f"exponent n = {n:g} is outside the range the accuracy thresholds were measured on (2 … 3)")
    worst, validity = _nearest_validity(scene, largest)
    if largest[worst] > validity and not law.lattice:
        notes.append(
            f"largest overlap {largest[worst]:.3g} may exceed {_limit_name(scene)} = {validity:g}, "
            "beyond where the Hertz law holds (status OVERLAP_BEYOND_VALIDITY)"
        )
    return StepCheck(
        method=scene.integrator.method,
        dt=scene.integrator.dt,
        largest_overlap=float(largest[worst]),
        stiffest_contact=k_star,
        stiffness=float(stiffness[k_star]),
        reduced_mass=float(1.0 / inverse_reduced[k_star]),
        contact_time=float(2.0 * math.pi / math.sqrt(omega2[k_star])),
        highest_frequency=omega_max,
        validity_overlap=validity,
        notes=tuple(notes),
        validity_contact=worst,
        accepted_steps=scene.integrator.accepted_steps_per_contact,
        pulse_rule=not law.lattice,
    )


def _nearest_validity(scene: Scene, largest: np.ndarray) -> tuple[int, float]:
    """(padded contact, its validity limit [length]) of the contact whose overlap bound ``largest`` is the largest
    fraction of its own limit VALIDITY_FRACTION·2·min(R_i, R_j): the largest overlap for equal grains."""
    ratios = scene.chain.radius_ratios
    if ratios is None:
        return int(np.argmax(largest)), scene.chain.validity_overlap
    scale = validity_scale(ratios)
    worst = int(np.argmax(largest * scale))
    return worst, scene.chain.validity_overlap / float(scale[worst])


def _limit_name(scene: Scene) -> str:
    """How the validity limit reads in a note: of the diameter, or of the contact's smaller grain."""
    if scene.chain.radius_ratios is None:
        return f"{VALIDITY_FRACTION:g}·diameter"
    return f"its contact's limit {VALIDITY_FRACTION:g}·(smaller grain's diameter)"


def dt_warning(scene: Scene) -> str | None:
    """One warning line when the scene's dt looks unstable or inaccurate for its method, else None.

    For ``run`` and ``sweep`` to print before they start (and to refuse with ``--strict``).
    """
    return check_scene(scene).warning()


def amplification_matrix(method: str, omega_dt: float) -> np.ndarray:
    """One step of ``method`` on ü = −ω²u, acting on the scaled Nordsieck vector (u, dt·v, dt²/2·a, …).

    The same predictor–corrector (Allen & Tildesley coefficients) and velocity Verlet the kernels
    run; its spectral radius decides linear stability (STABLE_OMEGA_DT).
    """
    z2 = omega_dt * omega_dt
    if method == "verlet":
        position = np.array([1.0, 1.0, 1.0])
        acceleration = -z2 / 2.0 * position
        return np.stack([position, np.array([0.0, 1.0, 1.0]) + acceleration, acceleration])
    if method in SUBSTEP_WEIGHTS:
        # composed: the product of velocity-Verlet substeps of w·dt on the full-dt scaled vector,
        # u' = u + w x1 + w² x2, x2' = −z²/2 u', x1' = x1 + w (x2 + x2') (kernels/gear.py)
        matrix = np.eye(3)
        for w in SUBSTEP_WEIGHTS[method]:
            position = np.array([1.0, w, w * w])
            acceleration = -z2 / 2.0 * position
            substep = np.stack([position, np.array([0.0, 1.0, w]) + w * acceleration, acceleration])
            matrix = substep @ matrix
        return matrix
    corrector = np.array([p / q for p, q in GEAR_CORRECTOR[method]])
    q = corrector.size
    pascal = np.array([[math.comb(j, i) for j in range(q)] for i in range(q)], dtype=float)
    residual = np.zeros(q)
    residual[0] = -z2 / 2.0  # dt²/2·a at the predicted position, minus the predicted dt²/2·a
    residual[2] = -1.0
    return (np.eye(q) + np.outer(corrector, residual)) @ pascal


def growth_per_period(method: str, omega_dt: float) -> float:
    """ρ^(2π/(ω dt)) − 1: relative amplitude change per oscillation period on ü = −ω²u."""
    rho = float(np.max(np.abs(np.linalg.eigvals(amplification_matrix(method, omega_dt)))))
    return rho ** (2.0 * math.pi / omega_dt) - 1.0


# ---- can it run at all? (before anything is allocated) -------------------------------------------

HOST_SETUP_ARRAYS = 16
"""Per-grain float64 arrays the host builds while setting a chain up (static state, Nordsieck start)."""


def memory_needed(scene: Scene, chains: int = 1) -> dict[str, int]:
    """Bytes a run of ``chains`` chains of ``scene`` allocates, by part, computed without allocating.

    ``state``: two state buffers of Nordsieck values plus per-grain constants and the trace ring (on the
    device); ``records``: snapshots, energy and work (on the host, float64 at most); ``traces``: trace
    samples (host); ``setup``: host arrays used to build the chain.
    """
    # kernels.gear loads Warp (≈ 0.6 s), which the other checks do without
    from hertzian.kernels.gear import GEAR_VALUES, state_rows

    item = 8 if scene.integrator.precision == "float64" else 4
    n, traced = scene.chain.grains, len(scene.record.traces)
    records = scene.record_count
    ring = scene.steps_per_record // scene.trace_stride if traced else 0
    # float32 state rows include the low parts of u and dt·v (compensated, kernels/gear.py)
    method = scene.integrator.method
    # "auto" (with integrator.tolerance): the pilot may pick any method; size for the largest state
    methods = list(GEAR_VALUES) if method not in GEAR_VALUES else [method]
    rows = max(state_rows(m, scene.integrator.precision, True) for m in methods)
    state = chains * (2 * rows * n + 3 * n + 2 + 2 * ring * traced) * item
    return {
        "state": state,
        "records": chains * (len(scene.record.fields) * n + 2) * records * 8,
        "traces": chains * 2 * scene.trace_sample_count * traced * 8,
        "setup": HOST_SETUP_ARRAYS * n * 8,
    }


def available_host_bytes() -> int:
    """Memory the operating system can give this process now (MemAvailable), in bytes."""
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")


def memory_refusal(scene: Scene, device: str | None = None, chains: int = 1) -> str | None:
    """One line (key = value: bytes needed vs available) when a run cannot fit in memory, else None.

    Always checks the host: it builds the state before uploading it and keeps the results (on a CPU
    the state lives there too). With a CUDA ``device`` also checks the state against its free memory.
    Needs no Warp for the host check, so it can run before any device is touched.
    """
    need = memory_needed(scene, chains)
    checks = [("state and results", sum(need.values()), available_host_bytes(), "available on the host")]
    if device is not None and str(device).startswith("cuda"):
        # Warp only for a CUDA device: the host checks (``hertzian check``) run without loading it
        import warp as wp

        checks.append(("state", need["state"], int(wp.get_device(device).free_memory), f"free on {device}"))
    for what, needed, limit, where in checks:
        if needed > limit:
            part = max(("state", "records", "traces"), key=need.get)
            key, value = {
                "state": ("chain.grains", scene.chain.grains),
                "records": ("record.every", scene.record.every),
                "traces": ("record.trace_every", scene.record.trace_every),
            }[part]
            if value is None:
                key, value = "chain.grains", scene.chain.grains
            needed = float(needed) if needed < 1e300 else float("inf")  # an int past float range prints as inf
            return (
                f"{key} = {value!r}: the run needs {needed:.3g} bytes of memory for its {what} "
                f"({scene.chain.grains} grains, {scene.record_count} records), more than the {limit:.3g} "
                f"bytes {where}"
            )
    return None
