"""The contact laws on the host (docs/lattices.md): forces, potentials, derivatives and static overlaps, in numpy.

Every law is written in the compression δ of a contact (δ = δ0 + u_i − u_{i+1}, docs/model.md §1) with the chain's
``a`` (per contact a_c: impurities, radii and materials as for Hertz) as its strength. The kernels' forms are
kernels/physics.py's ``contact_functions``; this module is what the static state, the Taylor start and the step
checks use.

* hertz: V = a·max(δ, 0)^n, no tension;
* harmonic: V = a δ²/2;
* fput: V = a (δ²/2 − α δ³/3 + β δ⁴/4), the Fermi–Pasta–Ulam–Tsingou V(r) = r²/2 + α r³/3 + β r⁴/4 at r = −δ;
* toda: V = (a/b)(e^{bδ} − 1 − bδ), Toda's (a/b) e^{−br} + a r at r = −δ less its value at rest;
* morse: V = a (1 − e^{αδ})², Morse's D (1 − e^{−αr})² with D = a;
* lj: V = 4a ((σ/ρ)^12 − (σ/ρ)^6) + a at the distance ρ = 2^(1/6) σ − δ, Lennard-Jones with ε = a, at rest at its
  minimum.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from hertzian.kernels.features import LATTICE_LAWS, POTENTIALS

LJ_MINIMUM = 2.0 ** (1.0 / 6.0)
"""ρ_e/σ of the Lennard-Jones law (kernels/physics.py's LJ_MINIMUM)."""


@dataclass(frozen=True)
class Law:
    """A contact law and its per-chain shape parameters (``p0``, ``p1``: see :func:`law_of`)."""

    name: str
    p0: float = 0.0
    p1: float = 0.0
    n: float = 2.5
    """The exponent of the power law (hertz only)."""

    @property
    def lattice(self) -> bool:
        """A law with tension (not the power law)."""
        return self.name != "hertz"

    def force(self, delta, a):
        """F(δ) = dV/dδ, the force that pushes the two grains apart."""
        delta = np.asarray(delta, dtype=np.float64)
        if self.name == "hertz":
            return np.where(delta > 0, self.n * a * np.maximum(delta, 0.0) ** (self.n - 1.0), 0.0)
        if self.name == "harmonic":
            return a * delta
        if self.name == "fput":
            return a * (delta - self.p0 * delta**2 + self.p1 * delta**3)
        if self.name == "toda":
            return a * np.expm1(self.p0 * delta)
        if self.name == "morse":
            t = np.exp(self.p0 * delta)
            return 2.0 * a * self.p0 * t * (t - 1.0)
        s6 = (self.p0 / (LJ_MINIMUM * self.p0 - delta)) ** 6
        return 24.0 * a / (LJ_MINIMUM * self.p0 - delta) * (2.0 * s6 * s6 - s6)

    def potential(self, delta, a):
        """V(δ), zero at δ = 0."""
        delta = np.asarray(delta, dtype=np.float64)
        if self.name == "hertz":
            return a * np.maximum(delta, 0.0) ** self.n
        if self.name == "harmonic":
            return a * delta**2 / 2.0
        if self.name == "fput":
            return a * (delta**2 / 2.0 - self.p0 * delta**3 / 3.0 + self.p1 * delta**4 / 4.0)
        if self.name == "toda":
            return a / self.p0 * (np.expm1(self.p0 * delta) - self.p0 * delta)
        if self.name == "morse":
            return a * np.expm1(self.p0 * delta) ** 2
        s6 = (self.p0 / (LJ_MINIMUM * self.p0 - delta)) ** 6
        return 4.0 * a * (s6 * s6 - s6) + a

    def derivatives(self, delta, a, count: int) -> np.ndarray:
        """F^(m)(δ) for m = 0 … count − 1, shape (count, *δ.shape) (lattice laws; smooth everywhere they are
        defined)."""
        delta = np.asarray(delta, dtype=np.float64)
        out = np.zeros((count, *delta.shape))
        out[0] = self.force(delta, a)
        for m in range(1, count):
            if self.name == "harmonic":
                out[m] = a if m == 1 else 0.0
            elif self.name == "fput":
                fput = (1.0 - 2.0 * self.p0 * delta + 3.0 * self.p1 * delta**2, -2.0 * self.p0 + 6.0 * self.p1 * delta)
                out[m] = a * (fput[m - 1] if m <= 2 else 6.0 * self.p1 if m == 3 else 0.0)
            elif self.name == "toda":
                out[m] = a * self.p0**m * np.exp(self.p0 * delta)
            elif self.name == "morse":
                t = np.exp(self.p0 * delta)
                out[m] = 2.0 * a * self.p0 * ((2.0 * self.p0) ** m * t * t - self.p0**m * t)
            else:  # d/dδ = −d/dρ; d^m/dρ^m ρ^{−p} = (−1)^m (p)_m ρ^{−p−m}
                rho = LJ_MINIMUM * self.p0 - delta
                s = self.p0
                repulsion = 2.0 * s**12 * _rising(13, m) * rho ** (-13 - m)
                out[m] = 24.0 * a * (repulsion - s**6 * _rising(7, m) * rho ** (-7 - m))
        return out

    def stiffness(self, delta, a):
        """F'(δ): the linear spring constant of a contact at overlap δ (its small-oscillation stiffness)."""
        if self.name == "hertz":
            delta = np.asarray(delta, dtype=np.float64)
            return np.where(delta > 0, self.n * (self.n - 1.0) * a * np.maximum(delta, 0.0) ** (self.n - 2.0), 0.0)
        return self.derivatives(delta, a, 2)[1]

    def static_overlap(self, force, a) -> np.ndarray:
        """δ0 with F(δ0) = ``force`` ≥ 0 on every contact (0 where the force is 0), by bisection on the rising branch
        of F from δ = 0; NaN where F never reaches the force there (fput with α > 0 peaks at a finite δ)."""
        force = np.asarray(force, dtype=np.float64)
        if not np.any(force > 0):
            return np.zeros(force.shape)  # no contact carries a force (no load, no gravity): every δ0 is 0
        a = np.broadcast_to(np.asarray(a, dtype=np.float64), force.shape)
        top = np.full(force.shape, self.rising_limit())
        lo, hi = np.zeros(force.shape), np.where(np.isfinite(top), top, 1.0)
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            grow = ~np.isfinite(top)
            for _ in range(200):  # an upper bracket where the branch is unbounded
                short = grow & (self.force(hi, a) < force)
                if not np.any(short):
                    break
                hi = np.where(short, 2.0 * hi, hi)
            for _ in range(200):
                mid = 0.5 * (lo + hi)
                if np.all((mid == lo) | (mid == hi) | (force <= 0)):
                    break  # every bracket that counts is two neighbouring floats: more halvings change nothing
                below = self.force(mid, a) < force
                lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
            reached = self.force(hi, a) >= force * (1.0 - 1e-12)
        return np.where(force > 0, np.where(reached, hi, np.nan), 0.0)

    def rising_limit(self) -> float:
        """The δ where the force stops rising (∞ where it rises for ever): fput's first maximum of
        δ − αδ² + βδ³, lj's contact distance 2^(1/6)σ."""
        if self.name == "fput":  # the first positive root of F'/a = 1 − 2αδ + 3βδ²
            alpha, beta = self.p0, self.p1
            if beta == 0.0:
                return 1.0 / (2.0 * alpha) if alpha > 0 else math.inf
            disc = alpha * alpha - 3.0 * beta
            root = (alpha - math.sqrt(disc)) / (3.0 * beta) if disc >= 0 else -1.0
            return root if root > 0 else math.inf
        if self.name == "lj":
            return LJ_MINIMUM * self.p0
        return math.inf


def _rising(p: int, m: int) -> float:
    """The rising factorial p (p + 1) … (p + m − 1)."""
    return float(math.prod(range(p, p + m)))


def law_of(chain) -> Law:
    """The Law of a ChainSpec: its ``potential`` and the shape keys that law reads (fput: alpha, beta; toda: b;
    morse: alpha; lj: sigma)."""
    name = chain.potential
    if name == "fput":
        return Law(name, chain.alpha, chain.beta)
    if name == "toda":
        return Law(name, chain.b)
    if name == "morse":
        return Law(name, chain.alpha)
    if name == "lj":
        return Law(name, chain.sigma)
    if name == "harmonic":
        return Law(name)
    return Law("hertz", n=chain.exponent)


__all__ = ["LATTICE_LAWS", "LJ_MINIMUM", "POTENTIALS", "Law", "law_of"]
