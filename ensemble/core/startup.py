"""Exact start of the Nordsieck vector: x_k = dt^k/k! · u^(k)(0) for every value a method keeps.

Starting Gear with x3 = x4 = x5 = 0 throws away the jerk (and higher derivatives) that an
impact or a drive creates at t = 0 in a precompressed chain, and every Gear method then
converges at order 2. Here the Taylor coefficients u_k = u^(k)(0)/k! come from power-series
arithmetic on the equation of motion: u_{k+2} = A_k / ((k+1)(k+2)), where A_k is the k-th
coefficient of the acceleration series, built from the overlap series of each contact by the
power rule w = δ^p ⇒ w_k = Σ_{j=1..k} ((p+1) j − k) δ_j w_{k−j} / (k δ_0).
A contact with no static overlap (δ_0 = 0) is not analytic at t = 0 (F ∝ t^(n−1)); its series
is taken as zero. Damping enters linearly: −γ v_k (viscous, v_k = (k+1) u_{k+1}) in the acceleration
series, +γ δ̇_k (a dashpot, δ̇_k = (k+1) δ_{k+1}) in each loaded contact's force series; a start
without it would cost Gear its order (an O(dt) error in the first step's velocity).

gear4 starts in the form its corrector keeps in steady state (kernels/events.py restarts it in the same form):
x1 = dt·v + dt⁴/24·u⁗ and x3 = dt³/6·u‴ − dt⁴/12·u⁗. An event-aware step takes the velocity as x1 − dt⁴/24·u⁗;
from the plain Taylor value x1 = dt·v, a first step near an event (an impact on a contact of small static
overlap) would start from a velocity wrong by dt³/24·u⁗, and the run would converge at order 3.
"""

from __future__ import annotations

import math

import numpy as np
from hertzian.core.chains import per_unique
from hertzian.core.modes import overlap_changes, start
from hertzian.core.potentials import law_of
from hertzian.core.scene import Scene
from hertzian.core.static import StaticState, static_arrays, static_state
from hertzian.kernels.features import GEAR_VALUES


def _power_series(delta: np.ndarray, p: float) -> np.ndarray:
    """Coefficients of δ(t)^p from those of δ(t) (rows: orders, columns: contacts); δ_0 > 0."""
    order = delta.shape[0]
    w = np.zeros_like(delta)
    w[0] = delta[0] ** p
    for k in range(1, order):
        acc = np.zeros_like(delta[0])
        for j in range(1, k + 1):
            acc += ((p + 1.0) * j - k) * delta[j] * w[k - j]
        w[k] = acc / (k * delta[0])
    return w


def _composed_series(delta: np.ndarray, derivatives: np.ndarray, k: int) -> np.ndarray:
    """Coefficient k ≥ 1 of F(δ(t)) from δ's coefficients (rows 0 … k) and F^(m)(δ_0) (rows m):
    Σ_{m=1..k} F^(m)/m! · [(δ − δ_0)^m]_k, the powers by repeated products of the series."""
    shift = delta[: k + 1].copy()
    shift[0] = 0.0
    power = shift.copy()
    total = derivatives[1] * power[k]
    for m in range(2, k + 1):
        product = np.zeros_like(power)
        for j in range(k + 1):
            product[j] = sum(power[i] * shift[j - i] for i in range(j + 1))
        power = product
        total = total + derivatives[m] / math.factorial(m) * power[k]
    return total


def taylor_coefficients(scene: Scene, order: int, static: StaticState | None = None) -> np.ndarray:
    """u_k = u^(k)(0)/k! for k = 0 … order, shape (order + 1, grains), float64."""
    st = static or static_state(scene)
    n_grains = scene.chain.grains
    n = st.exponent
    u = np.zeros((order + 1, n_grains))
    driven = scene.boundary.surface == "driven"
    fixed = scene.boundary.bottom == "fixed"
    if driven:
        amplitude = scene.excitation.drive_amplitude
        omega = 2.0 * math.pi / scene.excitation.drive_period
        for k in range(1, order + 1):
            # d^k/dt^k sin(ωt) at 0 = ω^k sin(kπ/2)
            u[k, 0] = amplitude * omega**k * round(math.sin(k * math.pi / 2)) / math.factorial(k)
    elif order >= 1:
        u[1, 0] = scene.excitation.impact
    modal = start(scene)
    if modal is not None:  # displacements and velocities of every grain (hertzian.core.modes)
        u[0] = modal[0]
        if order >= 1:
            u[1] = modal[1]
    a_c, delta0 = st.contact_constant, st.static_overlap
    # the overlaps at t = 0 (the static ones unless the start displaces grains)
    ring = scene.boundary.surface == "periodic"
    overlap = delta0 + overlap_changes(u[:1], ring)[0]
    loaded = (a_c > 0) & (overlap > 0)
    law = law_of(scene.chain)
    strength = np.where(a_c > 0, a_c, 1.0)
    if law.lattice:  # F^(m) at the overlaps at t = 0, m < order: the force series of a smooth law (Faà di Bruno)
        derivatives = law.derivatives(overlap, strength, max(order, 1))
    # the excess force at t = 0 (zero unless the start displaces grains)
    force0 = np.where(a_c > 0, law.force(overlap, strength) - law.force(delta0, strength), 0.0)
    inv_mass = 1.0 / st.mass
    damping, gamma = scene.damping.model, scene.damping.gamma
    for k in range(0, order - 1):
        # overlap series of every padded contact up to order k
        d = np.zeros((k + 1, n_grains + 1))
        d[0] = overlap
        d[1:] = overlap_changes(u[1 : k + 1], ring)
        force_k = force0.copy() if k == 0 else np.zeros(n_grains + 1)
        if law.lattice and k >= 1:
            force_k = np.where(a_c > 0, _composed_series(d, derivatives, k), 0.0)
        elif k >= 1 and np.any(loaded):
            w = _power_series(d[:, loaded], n - 1.0)
            force_k[loaded] = n * a_c[loaded] * w[k]
        if damping == "contact":
            rate = overlap_changes(u[k + 1 : k + 2], ring)[0]  # δ̇_k = (k+1) δ_{k+1}
            force_k = force_k + np.where(loaded, gamma * (k + 1) * rate, 0.0)
        accel_k = (force_k[:-1] - force_k[1:]) * inv_mass
        if damping == "viscous":
            accel_k = accel_k - gamma * (k + 1) * u[k + 1]
        if driven:
            accel_k[0] = u[k + 2, 0] * (k + 1) * (k + 2)
        if fixed:
            accel_k[-1] = 0.0
        u[k + 2] = accel_k / ((k + 1) * (k + 2))
    return u


GEAR4_VALUES = GEAR_VALUES["gear4"]
"""The Nordsieck values of gear4, the one method of that many."""


def start_order(values: int) -> int:
    """The Taylor order the start of a method of ``values`` Nordsieck values reads: values − 1, and u⁗ for gear4's
    steady-state form."""
    return 4 if values == GEAR4_VALUES else values - 1


def scaled_start(coeffs: np.ndarray, values: int, dt: float, *, driven: bool, steady: bool = True) -> np.ndarray:
    """The Nordsieck vector x_k = dt^k u_k (k < values) of Taylor coefficients ``coeffs`` (rows: orders up to
    :func:`start_order`; last axis: grains); with ``steady``, gear4's in the steady-state form of the module
    docstring except for a ``driven`` surface grain, which the kernels hold at its drive's exact derivatives."""
    scale = (dt ** np.arange(values)).reshape((values,) + (1,) * (coeffs.ndim - 1))
    x = coeffs[:values] * scale
    if steady and values == GEAR4_VALUES:
        quartic = dt**4 * coeffs[4]  # dt⁴/24·u⁗
        if driven:
            quartic[..., 0] = 0.0
        x[1] += quartic
        x[3] -= 2.0 * quartic
    return x


def initial_nordsieck(
    scene: Scene, values: int, dt: float, static: StaticState | None = None, *, steady: bool = True
) -> np.ndarray:
    """Scaled Nordsieck vector at t = 0, shape (values, grains): :func:`scaled_start`."""
    coeffs = taylor_coefficients(scene, start_order(values), static)
    return scaled_start(coeffs, values, dt, driven=scene.boundary.surface == "driven", steady=steady)


# ---- many chains at once -------------------------------------------------------------------


def _drive_coefficient(amplitude: float, period: float, k: int) -> float:
    omega = 2.0 * math.pi / period
    return amplitude * omega**k * round(math.sin(k * math.pi / 2)) / math.factorial(k)


def taylor_window(grains: int, order: int) -> int:
    """Grains from the surface that can move in the Taylor start up to ``order``.

    At t = 0 only the surface grain moves (an impact, or the drive); each order of the recursion
    carries a nonzero derivative at most one contact further every two orders (u_{k+2} from the
    overlaps of orders ≤ k). So u_k = 0 exactly beyond grain k/2: the coefficients of the first
    ``order + 2`` grains, cut there as if the next grain stood still, are the whole chain's.
    """
    return min(grains, order + 2)


def taylor_coefficients_of(chains, order: int, static=None, *, whole: bool = True) -> np.ndarray:
    """:func:`taylor_coefficients` of every chain of a ChainSet, shape (order + 1, chains, grains),
    vectorised over chains with the same arithmetic per element (same bits), computed on the
    :func:`taylor_window` (zeros beyond, as the per-scene recursion gives them; ``whole=False``
    returns only the window's grains)."""
    scene = chains.template
    count, n_total = len(chains), scene.chain.grains
    n_grains = taylor_window(n_total, order)
    cut = n_grains < n_total
    st = static if static is not None else static_arrays(chains, grains=n_grains)
    u = np.zeros((order + 1, count, n_grains))
    driven = scene.boundary.surface == "driven"
    fixed = scene.boundary.bottom == "fixed"
    if driven:
        amplitude, period = chains.column("excitation.drive_amplitude"), chains.column("excitation.drive_period")
        for k in range(1, order + 1):
            u[k, :, 0] = per_unique(lambda a, p, k=k: _drive_coefficient(a, p, k), amplitude, period)
    elif order >= 1:
        u[1, :, 0] = chains.column("excitation.impact")
    a_c, delta0 = st.contact_constant[:, : n_grains + 1], st.static_overlap[:, : n_grains + 1]
    loaded = (a_c > 0) & (delta0 > 0)
    any_loaded = bool(np.any(loaded))
    inv_mass = 1.0 / st.mass[:, :n_grains]
    damping = scene.damping.model
    gamma = chains.column("damping.gamma") if damping != "none" else None
    exponents = np.unique(st.exponent).tolist()
    groups = [(slice(None), exponents[0])] if len(exponents) == 1 else [(st.exponent == n, n) for n in exponents]
    d = np.zeros((order, count, n_grains + 1))
    d[0] = delta0
    # the power series w = δ^(n−1) of each exponent group, grown one order per k: its rows 0…k−1 depend
    # on δ_0…δ_{k−1} only, so each is computed once, by the recurrence of _power_series, element by element
    series = []
    with np.errstate(divide="ignore", invalid="ignore"):
        for rows, n in groups:
            w = np.zeros((order, *delta0[rows].shape))
            w[0] = delta0[rows] ** (n - 1.0)
            series.append(w)
    for k in range(0, order - 1):
        # overlap series of every padded contact up to order k (rows 1…k rewritten each order)
        d[1 : k + 1, :, 1:n_grains] = u[1 : k + 1, :, :-1] - u[1 : k + 1, :, 1:]
        d[1 : k + 1, :, 0] = -u[1 : k + 1, :, 0]
        d[1 : k + 1, :, n_grains] = u[1 : k + 1, :, -1]  # the bottom wall, or the still grain past the cut
        force_k = np.zeros((count, n_grains + 1))
        if k >= 1 and any_loaded:
            for (rows, n), w in zip(groups, series):
                # every contact at once, then only the loaded ones kept: elementwise the same operations
                # as the per-scene code on its loaded contacts (n − 1 a Python float, as there)
                p = n - 1.0
                delta = d[:, rows] if not isinstance(rows, slice) else d
                with np.errstate(divide="ignore", invalid="ignore"):
                    acc = np.zeros_like(delta[0])
                    for j in range(1, k + 1):
                        acc += ((p + 1.0) * j - k) * delta[j] * w[k - j]
                    w[k] = acc / (k * delta[0])
                    force_k[rows] = np.where(loaded[rows], n * a_c[rows] * w[k], 0.0)
        if damping == "contact":
            rate = np.zeros((count, n_grains + 1))  # δ̇_k = (k+1) δ_{k+1}
            rate[:, 1:n_grains] = u[k + 1, :, :-1] - u[k + 1, :, 1:]
            rate[:, 0] = -u[k + 1, :, 0]
            rate[:, n_grains] = u[k + 1, :, -1]
            force_k = force_k + np.where(loaded, gamma[:, None] * (k + 1) * rate, 0.0)
        accel_k = (force_k[:, :-1] - force_k[:, 1:]) * inv_mass
        if damping == "viscous":
            accel_k = accel_k - gamma[:, None] * (k + 1) * u[k + 1]
        if driven:
            accel_k[:, 0] = u[k + 2, :, 0] * (k + 1) * (k + 2)
        if fixed and not cut:
            accel_k[:, -1] = 0.0
        u[k + 2] = accel_k / ((k + 1) * (k + 2))
    if not cut or not whole:
        return u
    out = np.zeros((order + 1, count, n_total))
    out[:, :, :n_grains] = u
    return out


def initial_nordsieck_of(
    chains, values: int, dt: float, static=None, *, whole: bool = True, steady: bool = True
) -> np.ndarray:
    """Scaled Nordsieck vectors of every chain at t = 0 (:func:`scaled_start`), shape (values, chains, grains)
    (``whole=False``: only the first :func:`taylor_window` grains; the others are zero)."""
    coeffs = taylor_coefficients_of(chains, start_order(values), static, whole=whole)
    return scaled_start(coeffs, values, dt, driven=chains.template.boundary.surface == "driven", steady=steady)


def initial_starts_of(chains, values: int, dt: float, static=None) -> tuple[np.ndarray, np.ndarray | None]:
    """(the start the run integrates from, the exact start where it differs, else None) of :func:`taylor_window`
    grains of every chain, from one set of Taylor coefficients: gear4's steady-state form and its exact Taylor
    values (the record at t = 0 keeps the latter); for other methods (the exact start, None)."""
    coeffs = taylor_coefficients_of(chains, start_order(values), static, whole=False)
    driven = chains.template.boundary.surface == "driven"
    steady = scaled_start(coeffs, values, dt, driven=driven)
    return steady, scaled_start(coeffs, values, dt, driven=driven, steady=False) if values == GEAR4_VALUES else None
