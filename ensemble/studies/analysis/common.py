"""Fits and the paper's sign convention, shared by every subject."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class LineFit:
    """Least-squares line ``y = slope·x + intercept`` with standard errors (from the residuals)."""

    slope: float
    slope_error: float
    intercept: float
    intercept_error: float
    r_squared: float
    points: int


def fit_line(x, y) -> LineFit:
    """Ordinary least squares of ``y`` on ``x`` (NaNs dropped); errors are 1σ standard errors."""
    x, y = np.asarray(x, dtype=float).ravel(), np.asarray(y, dtype=float).ravel()
    keep = np.isfinite(x) & np.isfinite(y)
    x, y = x[keep], y[keep]
    n = x.size
    if n < 2 or np.ptp(x) == 0:
        return LineFit(math.nan, math.nan, math.nan, math.nan, math.nan, n)
    xm, ym = x.mean(), y.mean()
    sxx = np.sum((x - xm) ** 2)
    slope = float(np.sum((x - xm) * (y - ym)) / sxx)
    intercept = float(ym - slope * xm)
    residual = y - (slope * x + intercept)
    ss_res, ss_tot = float(np.sum(residual**2)), float(np.sum((y - ym) ** 2))
    if n > 2:
        sigma2 = ss_res / (n - 2)
        slope_error = math.sqrt(sigma2 / sxx)
        intercept_error = math.sqrt(sigma2 * (1.0 / n + xm**2 / sxx))
    else:
        slope_error = intercept_error = math.nan
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else 1.0
    return LineFit(slope, slope_error, intercept, intercept_error, r2, n)


@dataclass(frozen=True)
class PowerLawFit:
    """``y = prefactor · x^exponent``, fitted as a line in (ln x, ln y); errors are 1σ."""

    exponent: float
    exponent_error: float
    prefactor: float
    prefactor_relative_error: float
    r_squared: float
    points: int

    def __call__(self, x):
        return self.prefactor * np.asarray(x, dtype=float) ** self.exponent


def fit_power_law(x, y) -> PowerLawFit:
    """Fit ``y = C x^β`` by least squares on logarithms (points with x ≤ 0 or y ≤ 0 are dropped)."""
    x, y = np.asarray(x, dtype=float).ravel(), np.asarray(y, dtype=float).ravel()
    keep = (x > 0) & (y > 0) & np.isfinite(x) & np.isfinite(y)
    line = fit_line(np.log(x[keep]), np.log(y[keep]))
    return PowerLawFit(
        line.slope,
        line.slope_error,
        math.exp(line.intercept) if math.isfinite(line.intercept) else math.nan,
        line.intercept_error,
        line.r_squared,
        line.points,
    )


def paper_displacement(u):
    """The paper's displacement (change of grain *position*, its y axes): ``−u`` [length]."""
    return -np.asarray(u)


def paper_label(grain, grain_count: int):
    """The paper's grain label in Figs. 1, 2 and 4 (surface grain = N, last grain = 1): ``N − i``."""
    return grain_count - np.asarray(grain)


def energy_drift(energy, work=None) -> tuple[np.ndarray, str]:
    """Energy conservation over a run: (E(t) − E(0) [− W(t)]) / scale and a label for the scale.

    ``energy`` (and the driver's ``work``) at the records, shape (..., record). The scale is docs/model.md §5's:
    max|W| for a driven chain, else the injected energy, which is E(0) for an impact (the energy is
    relative to the static state, where the chain starts), else 1 (absolute).
    """
    energy = np.asarray(energy, dtype=float)
    change = energy - energy[..., :1]
    if work is not None:
        work = np.asarray(work, dtype=float)
        change = change - work
        scale, label = np.max(np.abs(work), axis=-1, keepdims=True), "max |W|"
    else:
        scale, label = energy[..., :1], "E_inj"
    if not np.all(scale > 0):
        return change, "absolute"
    return change / scale, label
