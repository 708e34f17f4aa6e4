"""Independent NumPy float64 reference simulator for a Hertzian granular chain.

This module is the *test oracle* for the Warp GPU simulator.  It is written from
the physics contract (docs/model.md §1–5 and §8) and the paper (Sen, Manciu &
Wright, PRE 57, 2386 (1998), section II) only; it deliberately imports nothing
from ``ensemble`` or ``kernels`` so that the two implementations can disagree
when one of them is wrong.

Model (all quantities in program units, float64 throughout):

* Grains ``0 .. N-1`` from the surface (grain 0) to the bottom; ``u_i`` is the
  displacement from static equilibrium, positive away from the surface.
* Inner contact ``i`` joins grains ``i`` and ``i+1``: overlap
  ``delta = delta0_i + u_i - u_{i+1}``.  Surface wall contact:
  ``delta = delta0_sw - u_0``.  Bottom wall contact: ``delta = delta0_bw + u_{N-1}``.
* ``V(delta) = a_c max(delta, 0)^n``; force ``n a_c max(delta, 0)^(n-1)``; no tension. With
  ``chain.potential`` a lattice law instead (docs/lattices.md), written here in the textbook form of the
  extension ``r = -delta`` with ``a`` its strength: FPUT ``a (r^2/2 + alpha r^3/3 + beta r^4/4)``, Toda
  ``(a/b) e^{-b r} + a r``, Morse ``a (1 - e^{-alpha r})^2``, Lennard-Jones ``4a ((s/rho)^12 - (s/rho)^6)`` at
  ``rho = 2^(1/6) s + r``, harmonic ``a r^2/2``; the force pushing the grains apart is ``-dV/dr``.
* Equation of motion, in the DIRECT form (no reformulation about the static
  state): ``m_i u_i'' = F_above - F_below + m_i g`` (+ ``F0`` on grain 0 for a
  surface ``load``).
* Static overlaps from the carried force: surface wall ``F0``; contact between
  grains ``k-1`` and ``k`` carries ``F0 + g sum_{j<k} m_j``; bottom wall
  ``F0 + g sum_j m_j``; ``delta0 = (carried / (n a_c))^(1/(n-1))``.
* Integrators: Gear 4/5/6-value Nordsieck predictor-corrector (Allen & Tildesley
  coefficients) and velocity Verlet.

Public API
----------
``reference_run(scene) -> dict`` of float64 arrays ``t, u, v, energy, work,
trace_t, trace_u, trace_v``; helpers ``static_overlaps``, ``contact_constants``,
``contact_force``, ``potential``, ``total_energy``.

``scene`` is the nested dict of docs/model.md §8 with every key present.
The ``integrator.precision`` key is ignored: the oracle is always float64.
"""

from __future__ import annotations

from math import comb

import numpy as np

__all__ = [
    "reference_run",
    "static_overlaps",
    "contact_constants",
    "contact_force",
    "potential",
    "total_energy",
    "GEAR_COEFFS",
    "default_scene",
]

_CUBE_ROOT_2 = 2.0 ** (1.0 / 3.0)
_W4 = 1.0 / (2.0 - _CUBE_ROOT_2)
_W6 = (-1.17767998417887, 0.235573213359357, 0.784513610477560)  # w1, w2, w3: Yoshida (1990), solution A
YOSHIDA = {
    "yoshida4": (_W4, -_CUBE_ROOT_2 * _W4, _W4),
    "yoshida6": (_W6[2], _W6[1], _W6[0], 1.0 - 2.0 * sum(_W6), _W6[0], _W6[1], _W6[2]),
}
"""Velocity-Verlet substep weights of the Yoshida compositions, from their published forms."""

# Allen & Tildesley corrector coefficients for a second-order ODE.
GEAR_COEFFS = {
    "gear4": (1.0 / 6.0, 5.0 / 6.0, 1.0, 1.0 / 3.0),
    "gear5": (19.0 / 120.0, 3.0 / 4.0, 1.0, 1.0 / 2.0, 1.0 / 12.0),
    "gear6": (3.0 / 20.0, 251.0 / 360.0, 1.0, 11.0 / 18.0, 1.0 / 6.0, 1.0 / 60.0),
}

SURFACES = ("wall", "load", "free", "driven", "periodic")
BOTTOMS = ("wall", "fixed", "free", "periodic")


# --------------------------------------------------------------------------
# contact law
# --------------------------------------------------------------------------


def contact_force(delta, a, n):
    """Repulsive force magnitude ``n a max(delta,0)^(n-1)`` (no tension)."""
    d = np.maximum(np.asarray(delta, dtype=np.float64), 0.0)
    return n * np.asarray(a, dtype=np.float64) * d ** (n - 1.0)


def potential(delta, a, n):
    """Contact energy ``a max(delta,0)^n``."""
    d = np.maximum(np.asarray(delta, dtype=np.float64), 0.0)
    return np.asarray(a, dtype=np.float64) * d**n


class _Lattice:
    """A lattice law in the extension r = -delta (module docstring): force -dV/dr, V, and d^m F/d delta^m."""

    def __init__(self, chain):
        self.name = chain["potential"]
        self.alpha, self.beta = float(chain.get("alpha", 0.0)), float(chain.get("beta", 0.0))
        self.b, self.sigma = float(chain.get("b", 1.0)), float(chain.get("sigma", 1.0))

    def _rho(self, r):
        return 2.0 ** (1.0 / 6.0) * self.sigma + r

    def force(self, delta, a):
        r = -np.asarray(delta, dtype=np.float64)
        if self.name == "fput":
            return -a * (r + self.alpha * r**2 + self.beta * r**3)
        if self.name == "toda":
            return a * (np.exp(-self.b * r) - 1.0)
        if self.name == "morse":
            return -2.0 * a * self.alpha * (np.exp(-self.alpha * r) - np.exp(-2.0 * self.alpha * r))
        if self.name == "lj":
            rho = self._rho(r)
            return 24.0 * a / rho * (2.0 * (self.sigma / rho) ** 12 - (self.sigma / rho) ** 6)
        return -a * r

    def potential(self, delta, a):
        r = -np.asarray(delta, dtype=np.float64)
        if self.name == "fput":
            return a * (r**2 / 2.0 + self.alpha * r**3 / 3.0 + self.beta * r**4 / 4.0)
        if self.name == "toda":
            return a / self.b * np.exp(-self.b * r) + a * r
        if self.name == "morse":
            return a * (1.0 - np.exp(-self.alpha * r)) ** 2
        if self.name == "lj":
            rho = self._rho(r)
            return 4.0 * a * ((self.sigma / rho) ** 12 - (self.sigma / rho) ** 6)
        return a * r**2 / 2.0

    def derivs(self, d0, a):
        """F', F'', F''' in delta: (-d/dr)^m of the force."""
        r = -np.asarray(d0, dtype=np.float64)
        a = np.asarray(a, dtype=np.float64)
        if self.name == "fput":
            first = a * (1.0 + 2.0 * self.alpha * r + 3.0 * self.beta * r**2)
            return first, -a * (2.0 * self.alpha + 6.0 * self.beta * r), 6.0 * a * self.beta + 0.0 * r
        if self.name == "toda":
            e = a * np.exp(-self.b * r)
            return self.b * e, self.b**2 * e, self.b**3 * e
        if self.name == "morse":
            e1, e2 = np.exp(-self.alpha * r), np.exp(-2.0 * self.alpha * r)
            return tuple(2.0 * a * self.alpha ** (m + 1) * (2.0**m * e2 - e1) for m in (1, 2, 3))
        if self.name == "lj":
            rho, s12, s6 = self._rho(r), self.sigma**12, self.sigma**6
            return (
                24.0 * a * (26.0 * s12 * rho**-14 - 7.0 * s6 * rho**-8),
                24.0 * a * (2.0 * 13 * 14 * s12 * rho**-15 - 7.0 * 8 * s6 * rho**-9),
                24.0 * a * (2.0 * 13 * 14 * 15 * s12 * rho**-16 - 7.0 * 8 * 9 * s6 * rho**-10),
            )
        return a + 0.0 * r, 0.0 * r, 0.0 * r

    def overlap(self, F, a_c):
        """delta >= 0 with force(delta) = F >= 0, by bisection up to where the force first exceeds F."""
        F = np.asarray(F, dtype=np.float64) + 0.0 * np.asarray(a_c, dtype=np.float64)
        a_c = np.broadcast_to(np.asarray(a_c, dtype=np.float64), F.shape)
        contact = 2.0 ** (1.0 / 6.0) * self.sigma  # lj: the grains touch there
        lo, hi = np.zeros(F.shape), np.full(F.shape, 1e-3)
        for _ in range(100):
            short = self.force(hi, a_c) < F
            hi = np.where(short, 0.5 * (hi + contact) if self.name == "lj" else 2.0 * hi, hi)
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            below = self.force(mid, a_c) < F
            lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        return np.where(F > 0, hi, 0.0)


def _lattice(scene):
    """The scene's lattice law, or None for the power law."""
    chain = scene["chain"]
    return _Lattice(chain) if chain.get("potential", "hertz") != "hertz" else None


# --------------------------------------------------------------------------
# scene -> per-grain / per-contact parameters
# --------------------------------------------------------------------------


# program units of the paper (docs/model.md): SI per unit
LENGTH_M, MASS_KG, TIME_S = 1e-5, 2.36e-5, 1.0102e-3


def _material_grains(scene):
    """Per-grain (E [Pa], nu, rho [kg/m^3]) of ``chain.material`` (names repeated along the chain), read from the
    scene's own ``materials`` table (the reference knows no shipped table), or None without materials."""
    names = scene["chain"].get("material")
    if names is None:
        return None
    names = [names] if isinstance(names, str) else list(names)
    table = scene.get("materials") or {}
    N = int(scene["chain"]["grains"])
    return [table[names[i % len(names)]] for i in range(N)]


def _hertz_constant_si(p, q, reduced_radius_m):
    """a [J/m^(5/2)] of V = a delta^(5/2) between materials p and q (dicts E, nu) at reduced radius R* [m]:
    F = (4/3) E* sqrt(R*) delta^(3/2), 1/E* = (1 - nu_p^2)/E_p + (1 - nu_q^2)/E_q."""
    e_star = 1.0 / ((1.0 - p["nu"] ** 2) / p["E"] + (1.0 - q["nu"] ** 2) / q["E"])
    return 0.4 * (4.0 / 3.0) * e_star * np.sqrt(reduced_radius_m)


def _material_constants(scene):
    """(masses (N,), a_surface_wall, a_inner (N-1,), a_bottom_wall) in program units for a chain of materials:
    computed in SI, then converted (mass / MASS_KG; a · LENGTH_M^(5/2) / (MASS_KG LENGTH_M^2 / TIME_S^2))."""
    grains = _material_grains(scene)
    ratio = _radius_ratio(scene)
    radius_m = 0.5 * float(scene["chain"]["diameter"]) * LENGTH_M * (1.0 if ratio is None else ratio)
    radius_m = np.broadcast_to(radius_m, (len(grains),)).astype(np.float64)
    mass = np.array([g["rho"] for g in grains]) * (4.0 / 3.0) * np.pi * radius_m**3 / MASS_KG
    to_program = LENGTH_M**2.5 / (MASS_KG * LENGTH_M**2 / TIME_S**2)
    inner = np.array(
        [
            _hertz_constant_si(
                grains[i], grains[i + 1], radius_m[i] * radius_m[i + 1] / (radius_m[i] + radius_m[i + 1])
            )
            for i in range(len(grains) - 1)
        ]
    )
    wall_name = scene["boundary"].get("wall_material")
    walls = []
    for i in (0, len(grains) - 1):  # a flat wall: R* = R_i
        wall = grains[i] if wall_name is None else scene["materials"][wall_name]
        walls.append(_hertz_constant_si(grains[i], wall, radius_m[i]) * to_program)
    return mass, walls[0], inner * to_program, walls[1]


def _grain_params(scene):
    """Per-grain mass, self-constant a and 'own contact rule' flag."""
    ch = scene["chain"]
    N = int(ch["grains"])
    if N < 1:
        raise ValueError(f"chain.grains = {N}: need at least 1 grain")
    if _material_grains(scene) is not None:  # the contact constants come from _material_constants
        return _material_constants(scene)[0], np.full(N, np.nan), np.zeros(N, dtype=bool)
    m = np.full(N, float(ch["mass"]), dtype=np.float64)
    a = np.full(N, float(ch["a"]), dtype=np.float64)
    ratio = _radius_ratio(scene)
    if ratio is not None:  # Hertz spheres of radius R_i = ratio·R0 (docs/heterogeneous.md)
        m = m * ratio**3
        a = a * np.sqrt(ratio)
    own = np.zeros(N, dtype=bool)
    for blk in scene.get("impurities") or []:
        idx = np.asarray(list(blk["grains"]), dtype=np.int64)
        if idx.size and (idx.min() < 0 or idx.max() >= N):
            raise ValueError(f"impurities.grains = {list(blk['grains'])}: indices must lie in 0..{N - 1}")
        m[idx] = float(blk["mass"])
        a[idx] = float(blk["a"])
        rule = blk.get("contact", "harmonic")
        if rule not in ("harmonic", "own"):
            raise ValueError(f"impurities.contact = {rule!r}: allowed harmonic | own")
        own[idx] = rule == "own"
    return m, a, own


def _radius_ratio(scene):
    """R_i / R0 per grain from ``chain.radii`` given as a list of N radii [length] (R0 = diameter / 2),
    or None for equal grains. Only the explicit list is read: callers compute any other form themselves."""
    ch = scene["chain"]
    radii = ch.get("radii")
    if radii is None:
        return None
    if not isinstance(radii, (list, tuple, np.ndarray)) or len(radii) != int(ch["grains"]):
        raise ValueError(f"chain.radii: the reference reads only a list of {ch['grains']} radii")
    return np.asarray(radii, dtype=np.float64) / (0.5 * float(ch["diameter"]))


def _boundaries(scene):
    surface = scene["boundary"]["surface"]
    bottom = scene["boundary"]["bottom"]
    if surface not in SURFACES:
        raise ValueError(f"boundary.surface = {surface!r}: allowed {' | '.join(SURFACES)}")
    if bottom not in BOTTOMS:
        raise ValueError(f"boundary.bottom = {bottom!r}: allowed {' | '.join(BOTTOMS)}")
    return surface, bottom


def _F0(scene):
    ch = scene["chain"]
    if ch.get("load") is not None:
        return float(ch["load"])
    n = float(ch["exponent"])
    l0 = float(ch.get("l0") or 0.0)
    if _lattice(scene) is not None:
        return float(_lattice(scene).force(l0, float(ch["a"]))) if l0 > 0.0 else 0.0
    return n * float(ch["a"]) * l0 ** (n - 1.0) if l0 > 0.0 else 0.0


def contact_constants(scene):
    """Contact constants ``(a_surface_wall, a_inner (N-1,), a_bottom_wall)``.

    Inner contact (i, i+1): harmonic mean ``2 a_i a_j / (a_i + a_j)``, except a
    grain of an impurity block with ``contact = "own"`` imposes its own ``a``
    (both "own": harmonic mean of the two).  Walls use the touching grain's ``a``.
    Wall constants are returned even if the boundary has no wall. With per-grain radii
    (``chain.radii``, a list) the self-constant of grain i is ``a sqrt(R_i/R0)`` (walls) and an inner
    contact ``a sqrt(2 R_i R_j / (R0 (R_i + R_j)))``; its mass is ``m (R_i/R0)^3``.
    """
    if _material_grains(scene) is not None:
        _, a_sw, a_in, a_bw = _material_constants(scene)
        return float(a_sw), a_in, float(a_bw)
    _, a, own = _grain_params(scene)
    ai, aj = a[:-1], a[1:]
    oi, oj = own[:-1], own[1:]
    harm = 2.0 * ai * aj / (ai + aj)
    a_in = np.where(oi & ~oj, ai, np.where(oj & ~oi, aj, harm))
    ratio = _radius_ratio(scene)
    if ratio is not None:
        if scene.get("impurities"):
            raise ValueError("the reference does not combine chain.radii with impurities")
        ri, rj = ratio[:-1], ratio[1:]  # Hertz: a_ij = a sqrt(2 R_eff / R0), R_eff = R_i R_j / (R_i + R_j)
        a_in = float(scene["chain"]["a"]) * np.sqrt(2.0 * ri * rj / (ri + rj))
    return float(a[0]), a_in.astype(np.float64), float(a[-1])


def _overlap_from_force(F, a_c, n):
    F = np.asarray(F, dtype=np.float64)
    out = np.zeros(np.broadcast(F, a_c).shape, dtype=np.float64)
    pos = np.broadcast_to(F > 0.0, out.shape)
    ratio = np.broadcast_to(F / (n * np.asarray(a_c, dtype=np.float64)), out.shape)
    out[pos] = ratio[pos] ** (1.0 / (n - 1.0))
    return out


def static_overlaps(scene):
    """Static overlaps ``(surface_wall, inner (N-1,), bottom_wall)``.

    A wall overlap is ``None`` when that boundary has no wall contact
    (surface load/free/driven; bottom fixed/free).
    """
    surface, bottom = _boundaries(scene)
    ch = scene["chain"]
    n = float(ch["exponent"])
    g = float(ch.get("gravity") or 0.0)
    F0 = _F0(scene)
    m, _, _ = _grain_params(scene)
    a_sw, a_in, a_bw = contact_constants(scene)
    carried_in = F0 + g * np.cumsum(m)[:-1]  # contact (k-1, k) carries F0 + g sum_{j<k} m_j
    lattice = _lattice(scene)
    overlap = lattice.overlap if lattice is not None else (lambda F, a_c: _overlap_from_force(F, a_c, n))
    d_in = overlap(carried_in, a_in)
    d_sw = float(overlap(F0, a_sw)) if surface == "wall" else None
    d_bw = float(overlap(F0 + g * m.sum(), a_bw)) if bottom == "wall" else None
    return d_sw, d_in, d_bw


def contact_overlaps(scene, u):
    """Overlaps of every padded contact ``(surface wall, inner (N-1,), bottom wall)`` at displacements ``u``
    (records, N), shape (records, N + 1): static overlap plus the change of the gap; NaN where a boundary has no
    wall contact."""
    d_sw, d_in, d_bw = static_overlaps(scene)
    u = np.atleast_2d(np.asarray(u, dtype=np.float64))
    nan = np.full(len(u), np.nan)
    top = nan if d_sw is None else d_sw - u[:, 0]
    bottom = nan if d_bw is None else d_bw + u[:, -1]
    return np.column_stack([top, d_in + u[:, :-1] - u[:, 1:], bottom])


def validity_limits(scene):
    """Each padded contact's validity overlap, 0.1 of the smaller grain's diameter (a wall contact: its grain's),
    shape (N + 1,) [length]."""
    ch = scene["chain"]
    r = _radius_ratio(scene)
    radius = 0.5 * float(ch["diameter"]) * (np.ones(int(ch["grains"])) if r is None else r)
    smaller = np.concatenate([radius[:1], np.minimum(radius[:-1], radius[1:]), radius[-1:]])
    return 0.1 * 2.0 * smaller


# --------------------------------------------------------------------------
# the model: forces and energy
# --------------------------------------------------------------------------


class _Chain:
    """Everything needed to evaluate accelerations and energy of one scene."""

    def __init__(self, scene):
        self.surface, self.bottom = _boundaries(scene)
        ch = scene["chain"]
        self.N = int(ch["grains"])
        self.n = float(ch["exponent"])
        self.g = float(ch.get("gravity") or 0.0)
        self.F0 = _F0(scene)
        self.m, _, _ = _grain_params(scene)
        self.a_sw, self.a_in, self.a_bw = contact_constants(scene)
        self.d_sw, self.d_in, self.d_bw = static_overlaps(scene)
        self.lattice = _lattice(scene)
        # a ring (periodic ends): grain N-1 and grain 0 touch through one more contact, like an inner one
        self.ring = self.surface == "periodic"
        if self.ring:
            _, a, _ = _grain_params(scene)
            self.a_ring = 2.0 * a[-1] * a[0] / (a[-1] + a[0]) if a[-1] != a[0] else a[0]
            self.d_ring = float(
                self.lattice.overlap(self.F0, self.a_ring)
                if self.lattice
                else _overlap_from_force(self.F0, self.a_ring, self.n)
            )
        ex = scene.get("excitation") or {}
        self.impact = float(ex.get("impact") or 0.0)
        self.A = float(ex.get("drive_amplitude") or 0.0)
        self.tau = float(ex.get("drive_period") or 0.0)
        self.driven = self.surface == "driven"
        self.fixed = self.bottom == "fixed"
        if self.driven:
            if self.tau <= 0.0:
                raise ValueError(f"excitation.drive_period = {self.tau}: must be > 0 for a driven surface")
            if self.impact != 0.0:
                raise ValueError(f"excitation.impact = {self.impact}: cannot be combined with surface = 'driven'")
        self.w = 2.0 * np.pi / self.tau if self.driven else 0.0

    # prescribed drive
    def drive_u(self, t):
        return self.A * np.sin(self.w * t)

    def drive_v(self, t):
        return self.A * self.w * np.cos(self.w * t)

    def drive_a(self, t):
        return -self.A * self.w * self.w * np.sin(self.w * t)

    def enforce(self, u, t):
        """Impose the prescribed positions (driven grain 0, fixed bottom grain)."""
        if self.driven:
            u[0] = self.drive_u(t)
        if self.fixed:
            u[-1] = 0.0

    def force(self, delta, a):
        """The contact law's force at overlap delta."""
        if self.lattice is not None:
            return self.lattice.force(delta, a)
        return contact_force(delta, a, self.n)

    def potential(self, delta, a):
        """The contact law's energy at overlap delta."""
        if self.lattice is not None:
            return self.lattice.potential(delta, a)
        return potential(delta, a, self.n)

    def inner_force(self, u):
        return self.force(self.d_in + u[:-1] - u[1:], self.a_in)

    def accel(self, u, t):
        """Acceleration of every grain at positions u (constraints already imposed)."""
        f = self.m * self.g  # gravity, +m g (u grows downward)
        F = self.inner_force(u)  # F[i]: contact (i, i+1)
        f = f.copy()
        f[1:] += F  # contact above pushes down (+)
        f[:-1] -= F  # contact below pushes up (-)
        if self.surface == "wall":
            f[0] += self.force(self.d_sw - u[0], self.a_sw)
        elif self.surface == "load":
            f[0] += self.F0
        if self.bottom == "wall":
            f[-1] -= self.force(self.d_bw + u[-1], self.a_bw)
        if self.ring:
            closing = self.force(self.d_ring + u[-1] - u[0], self.a_ring)
            f[0] += closing
            f[-1] -= closing
        acc = f / self.m
        if self.driven:
            acc[0] = self.drive_a(t)
        if self.fixed:
            acc[-1] = 0.0
        return acc

    def energy(self, u, v):
        """docs/model.md §5 total energy (driven: grain 0's KE and gravity term excluded)."""
        ke = 0.5 * self.m * v * v
        grav = self.g * self.m * u
        if self.driven:
            ke = ke[1:]
            grav = grav[1:]
        E = ke.sum() - grav.sum()
        E += self.potential(self.d_in + u[:-1] - u[1:], self.a_in).sum()
        if self.surface == "wall":
            E += float(self.potential(self.d_sw - u[0], self.a_sw))
        elif self.surface == "load":
            E -= self.F0 * u[0]
        if self.bottom == "wall":
            E += float(self.potential(self.d_bw + u[-1], self.a_bw))
        if self.ring:
            E += float(self.potential(self.d_ring + u[-1] - u[0], self.a_ring))
        return float(E)

    def drive_power(self, u, t):
        """F_01 * v_0: power delivered by the driven grain 0 to the rest of the chain."""
        if not self.driven or self.N < 2:
            return 0.0
        F01 = float(self.force(self.d_in[0] + u[0] - u[1], self.a_in[0]))
        return F01 * self.drive_v(t)


# --------------------------------------------------------------------------
# exact Taylor start for the Nordsieck vector
# --------------------------------------------------------------------------


def _force_derivs(d0, a_c, n):
    """F', F'', F''' of F(delta) = n a_c delta^(n-1) at the static overlap d0.

    A contact with d0 = 0 (unloaded) is not differentiable at t = 0 (delta^(n-1)
    with n-1 = 3/2 has no finite second derivative at 0, and the contact may open
    at once): its F', F'', F''' are taken as 0 there.
    """
    d0 = np.asarray(d0, dtype=np.float64)
    a_c = np.asarray(a_c, dtype=np.float64)
    pos = d0 > 0.0
    d = np.where(pos, d0, 1.0)  # dummy 1.0 where unloaded
    F1 = np.where(pos, n * (n - 1.0) * a_c * d ** (n - 2.0), 0.0)
    F2 = np.where(pos, n * (n - 1.0) * (n - 2.0) * a_c * d ** (n - 3.0), 0.0)
    F3 = np.where(pos, n * (n - 1.0) * (n - 2.0) * (n - 3.0) * a_c * d ** (n - 4.0), 0.0)
    return F1, F2, F3


def _taylor_derivatives(ch, u, v, acc):
    """Exact time derivatives ``[u, u', u'', u''', u'''', u''''']`` at t = 0.

    Explicit chain rule (Faa di Bruno) about the static state; the constant
    gravity / load terms drop out of every derivative beyond the acceleration:

    * ``a'   = M^-1 sum_c +-F'(d0_c) d1_c``
    * ``a''  = M^-1 sum_c +-[F''(d0_c) d1_c^2 + F'(d0_c) d2_c]``
    * ``a''' = M^-1 sum_c +-[F'''(d0_c) d1_c^3 + 3 F''(d0_c) d1_c d2_c + F'(d0_c) d3_c]``

    with ``dk_c`` the k-th time derivative of contact c's overlap (inner contact
    (i, i+1): ``u_i^(k) - u_{i+1}^(k)``; surface wall: ``-u_0^(k)``; bottom wall:
    ``+u_{N-1}^(k)``) and ``u'' = a``, ``u''' = a'``.  A driven grain 0 follows
    ``A sin(w t)`` exactly; a fixed grain has every derivative 0.
    """
    n = ch.n
    sw = ch.surface == "wall"
    bw = ch.bottom == "wall"
    derivs = ch.lattice.derivs if ch.lattice is not None else (lambda d0, a_c: _force_derivs(d0, a_c, n))
    F1_in, F2_in, F3_in = derivs(ch.d_in, ch.a_in)
    F1_sw, F2_sw, F3_sw = derivs(ch.d_ring, ch.a_ring) if ch.ring else derivs(ch.d_sw if sw else 0.0, ch.a_sw)
    F1_bw, F2_bw, F3_bw = derivs(ch.d_bw if bw else 0.0, ch.a_bw)

    def ddelta(U):
        """k-th derivatives of the (inner, surface-wall, bottom-wall) overlaps from u^(k); a ring's closing contact
        takes the surface-wall slot."""
        return U[:-1] - U[1:], (U[-1] - U[0]) if ch.ring else -U[0], U[-1]

    def net(t_in, t_sw, t_bw):
        """M^-1 times the signed sum of per-contact force derivatives."""
        f = np.zeros(ch.N)
        f[1:] += t_in  # contact above pushes down (+)
        f[:-1] -= t_in  # contact below pushes up (-)
        if sw:
            f[0] += t_sw
        if ch.ring:
            f[0] += t_sw
            f[-1] -= t_sw
        if bw:
            f[-1] -= t_bw
        return f / ch.m

    def constrain(x, k):
        """Impose the prescribed k-th derivative on driven / fixed grains."""
        if ch.driven:
            # d^k/dt^k [A sin(w t)] at t = 0 is A w^k sin(k pi / 2)
            x[0] = ch.A * ch.w**k * (0.0, 1.0, 0.0, -1.0)[k % 4]
        if ch.fixed:
            x[-1] = 0.0
        return x

    d1_in, d1_sw, d1_bw = ddelta(v)
    a1 = constrain(net(F1_in * d1_in, F1_sw * d1_sw, F1_bw * d1_bw), 3)
    d2_in, d2_sw, d2_bw = ddelta(acc)
    a2 = constrain(
        net(F2_in * d1_in**2 + F1_in * d2_in, F2_sw * d1_sw**2 + F1_sw * d2_sw, F2_bw * d1_bw**2 + F1_bw * d2_bw), 4
    )
    d3_in, d3_sw, d3_bw = ddelta(a1)
    a3 = constrain(
        net(
            F3_in * d1_in**3 + 3.0 * F2_in * d1_in * d2_in + F1_in * d3_in,
            F3_sw * d1_sw**3 + 3.0 * F2_sw * d1_sw * d2_sw + F1_sw * d3_sw,
            F3_bw * d1_bw**3 + 3.0 * F2_bw * d1_bw * d2_bw + F1_bw * d3_bw,
        ),
        5,
    )
    return [u.copy(), v.copy(), acc.copy(), a1, a2, a3]


def total_energy(scene, u, v):
    """docs/model.md §5 energy of state (u, v) for this scene."""
    return _Chain(scene).energy(np.asarray(u, np.float64), np.asarray(v, np.float64))


# --------------------------------------------------------------------------
# stepping schedule
# --------------------------------------------------------------------------


def _schedule(scene):
    integ = scene["integrator"]
    rec = scene.get("record") or {}
    dt = float(integ["dt"])
    duration = float(integ["duration"])
    if not dt > 0.0:
        raise ValueError(f"integrator.dt = {dt}: must be > 0")
    if not duration > 0.0:
        raise ValueError(f"integrator.duration = {duration}: must be > 0")
    every = rec.get("every")
    every = duration if every is None else float(every)
    k = max(1, int(round(every / dt)))  # steps per record
    n_int = max(1, int(round(duration / every)))  # record intervals
    total = n_int * k
    te = rec.get("trace_every")
    s = 1 if te is None else max(1, int(round(float(te) / dt)))
    return dt, k, n_int, total, s


# --------------------------------------------------------------------------
# main entry point
# --------------------------------------------------------------------------


def reference_run(scene: dict, exact_start: bool = True) -> dict:
    """Integrate one scene; return snapshots, energy, drive work and traces (float64).

    ``exact_start`` (default): Gear's Nordsieck vector starts from the exact Taylor
    derivatives at t = 0, ``x_k = dt^k / k! * u^(k)(0)`` for every k < Q; gear4 (Q = 4)
    in the form its corrector keeps in steady state, ``x_1 += dt^4/24 * u^(4)(0)`` and
    ``x_3 -= dt^4/12 * u^(4)(0)`` (the corrector applied to u = t^4/24 in exact arithmetic
    settles there).
    ``exact_start=False``: the old start (``x_2 = dt^2/2 a(0)``, higher terms 0),
    which discards the initial jerk of an impact into a loaded chain and drops
    every Gear method to order 2.  Verlet needs only a(0) and is unaffected.
    """
    ch = _Chain(scene)
    method = scene["integrator"]["method"]
    if method not in GEAR_COEFFS and method not in ("verlet", *YOSHIDA):
        raise ValueError(
            f"integrator.method = {method!r}: allowed gear4 | gear5 | gear6 | verlet | yoshida4 | yoshida6"
        )
    if method in YOSHIDA and ch.driven:
        raise ValueError(f"integrator.method = {method!r}: no driven surface")
    dt, k, n_int, total, s = _schedule(scene)
    N = ch.N
    rec = scene.get("record") or {}
    traces = np.asarray(list(rec.get("traces") or []), dtype=np.int64)
    if traces.size and (traces.min() < 0 or traces.max() >= N):
        raise ValueError(f"record.traces = {traces.tolist()}: indices must lie in 0..{N - 1}")

    R = n_int + 1
    S = total // s + 1
    out_t = np.arange(R, dtype=np.float64) * (k * dt)
    out_u = np.zeros((R, N))
    out_v = np.zeros((R, N))
    out_E = np.zeros(R)
    out_W = np.zeros(R)
    tr_t = np.arange(S, dtype=np.float64) * (s * dt)
    tr_u = np.zeros((S, traces.size))
    tr_v = np.zeros((S, traces.size))

    # initial state
    u = np.zeros(N)
    v = np.zeros(N)
    v[0] = ch.impact
    if ch.driven:
        u[0] = ch.drive_u(0.0)
        v[0] = ch.drive_v(0.0)
    if ch.fixed:
        u[-1] = 0.0
        v[-1] = 0.0
    acc = ch.accel(u, 0.0)

    work = 0.0
    power = ch.drive_power(u, 0.0)

    def record(step, u, v):
        if step % k == 0:
            r = step // k
            out_u[r] = u
            out_v[r] = v
            out_E[r] = ch.energy(u, v)
            out_W[r] = work
        if step % s == 0:
            j = step // s
            tr_u[j] = u[traces]
            tr_v[j] = v[traces]

    record(0, u, v)

    if method in YOSHIDA:
        # Yoshida (1990) / Forest–Ruth: velocity Verlet (kick–drift–kick) over w·dt for each weight, in (u, v)
        for step in range(1, total + 1):
            t1 = step * dt
            for w in YOSHIDA[method]:
                h = w * dt
                u = u + h * v + (0.5 * h * h) * acc
                ch.enforce(u, t1)
                acc_new = ch.accel(u, t1)
                v = v + (0.5 * h) * (acc + acc_new)
                acc = acc_new
                if ch.fixed:
                    v[-1] = 0.0
            record(step, u, v)
    elif method == "verlet":
        for step in range(1, total + 1):
            t1 = step * dt
            u = u + dt * v + (0.5 * dt * dt) * acc
            ch.enforce(u, t1)
            acc_new = ch.accel(u, t1)
            v = v + (0.5 * dt) * (acc + acc_new)
            acc = acc_new
            if ch.driven:
                v[0] = ch.drive_v(t1)
            if ch.fixed:
                v[-1] = 0.0
            if ch.driven:
                p = ch.drive_power(u, t1)
                work += 0.5 * dt * (power + p)
                power = p
            record(step, u, v)
    else:
        C = np.asarray(GEAR_COEFFS[method], dtype=np.float64)
        q = C.size  # number of Nordsieck values
        # Nordsieck vector x_j = dt^j / j! * d^j u / dt^j
        X = np.zeros((q, N))
        if exact_start:
            derivs = _taylor_derivatives(ch, u, v, acc)
            fact = 1.0
            for j in range(q):
                fact *= max(j, 1)  # j!
                X[j] = dt**j / fact * derivs[j]
            if q == 4:
                quartic = dt**4 / 24.0 * derivs[4]
                if ch.driven:
                    quartic[0] = 0.0  # the driven grain keeps its exact derivatives, as after every step
                X[1] += quartic
                X[3] -= 2.0 * quartic
        else:
            X[0] = u
            X[1] = dt * v
            X[2] = 0.5 * dt * dt * acc
        # Pascal-triangle predictor: x_j <- sum_{l>=j} binom(l, j) x_l
        P = np.array([[comb(l, j) if l >= j else 0 for l in range(q)] for j in range(q)], dtype=np.float64)
        half_dt2 = 0.5 * dt * dt
        for step in range(1, total + 1):
            t1 = step * dt
            Xp = P @ X
            ch.enforce(Xp[0], t1)  # driven grain 0 exact, fixed grain 0
            a_p = ch.accel(Xp[0], t1)
            delta = half_dt2 * a_p - Xp[2]
            X = Xp + C[:, None] * delta[None, :]
            if ch.driven:
                X[:, 0] = 0.0
                X[0, 0] = ch.drive_u(t1)
                X[1, 0] = dt * ch.drive_v(t1)
                X[2, 0] = half_dt2 * ch.drive_a(t1)
            if ch.fixed:
                X[:, -1] = 0.0
            u = X[0]
            v = X[1] / dt
            if ch.driven:
                p = ch.drive_power(u, t1)
                work += 0.5 * dt * (power + p)
                power = p
            record(step, u, v)

    return {
        "t": out_t,
        "u": out_u,
        "v": out_v,
        "energy": out_E,
        "work": out_W,
        "trace_t": tr_t,
        "trace_u": tr_u,
        "trace_v": tr_v,
    }


def default_scene(**overrides) -> dict:
    """A fully filled scene dict (docs/model.md §8 defaults); ``overrides`` are
    ``section=dict`` updates, e.g. ``default_scene(chain={"grains": 20})``."""
    scene = {
        "chain": {
            "grains": 1000,
            "mass": 1.0,
            "a": 5657.0,
            "exponent": 2.5,
            "diameter": 100.0,
            "l0": 0.0,
            "load": None,
            "gravity": 0.0,
        },
        "boundary": {"surface": "wall", "bottom": "wall"},
        "impurities": [],
        "excitation": {"impact": 0.0, "drive_amplitude": 0.0, "drive_period": 10.0},
        "integrator": {"method": "gear4", "dt": 1.25e-5, "duration": 1.0, "precision": "float64"},
        "record": {"every": None, "fields": ["u", "v"], "traces": [], "trace_every": None, "energy": True},
    }
    for key, val in overrides.items():
        if isinstance(val, dict):
            scene[key].update(val)
        else:
            scene[key] = val
    return scene
