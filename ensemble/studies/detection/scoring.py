"""Scoring candidates against a signal: Gaussian integrals, the Gauss–Newton quadratic of the residual sum of
squares in x = ln μ, the noise estimate, and the library's scores per depth and class from its echoes' projections
on the signal and their Gram matrices (program units)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from hertzian.studies.detection.library import Grid, Library
from hertzian.studies.detection.signal import Signal

NOISE_MIN_SAMPLES = 8
"""Fewest samples before the earliest possible echo from which σ is estimated."""
INTERPOLATION_POINTS = 8
"""Points per library interval in ln μ at which the cubic interpolant of the traces is evaluated."""


def bisect_increasing(f, target: float, lo: float, hi: float, steps: int = 80) -> float:
    """x in [lo, hi] where the non-decreasing ``f`` crosses ``target``, by ``steps`` halvings."""
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        if f(mid) < target:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def log_normal_cdf(z: float) -> float:
    """log Φ(z), accurate in the far left tail."""
    if z > -30.0:
        return math.log(0.5 * math.erfc(-z / math.sqrt(2.0)))
    # asymptotic series: Φ(z) ≈ φ(z)/|z| (1 − 1/z² + 3/z⁴)
    return -0.5 * z * z - math.log(-z) - 0.5 * math.log(2 * math.pi) + math.log1p(-1 / z**2 + 3 / z**4)


def log_normal_mass(lo: float, hi: float) -> float:
    """log(Φ(hi) − Φ(lo)) for lo < hi, stable in both tails."""
    if lo > 0:  # use symmetry so the difference is taken in the left tail
        lo, hi = -hi, -lo
    a, b = log_normal_cdf(lo), log_normal_cdf(hi)
    if b - a < 1e-300:
        return -math.inf
    return b + math.log(-math.expm1(a - b))


def logsumexp(values) -> float:
    values = np.asarray(values, dtype=float)
    if values.size == 0 or not np.any(np.isfinite(values)):
        return -math.inf
    top = np.max(values[np.isfinite(values)])
    return float(top + math.log(np.sum(np.exp(values[np.isfinite(values)] - top))))


@dataclass
class Quadratic:
    """RSS(x) ≈ rss0 − 2 g (x − x0) + H (x − x0)² near x0 (Gauss–Newton model of one depth and class)."""

    x0: float
    rss0: float
    g: float
    """J·r, r = signal − model(x0)."""
    H: float
    """J·J."""

    @property
    def optimum(self) -> float:
        return self.x0 + self.g / self.H if self.H > 0 else self.x0

    @property
    def rss_min(self) -> float:
        return max(self.rss0 - self.g * self.g / self.H, 0.0) if self.H > 0 else self.rss0

    def log_integral(self, lo: float, hi: float, sigma: float) -> float:
        """log ∫_lo^hi exp(−RSS(x)/2σ²) dx / (hi − lo) (the prior-averaged likelihood, without constants)."""
        width = hi - lo
        if self.H <= 0 or sigma / math.sqrt(self.H) > 1e6 * width:
            return -self.rss0 / (2 * sigma**2)
        s = sigma / math.sqrt(self.H)
        m = self.optimum
        return (
            -self.rss_min / (2 * sigma**2)
            + math.log(math.sqrt(2 * math.pi) * s)
            + log_normal_mass((lo - m) / s, (hi - m) / s)
            - math.log(width)
        )

    def cdf(self, x: float, lo: float, hi: float, sigma: float) -> float:
        """Posterior CDF of x on [lo, hi] under this quadratic (a truncated Gaussian)."""
        if self.H <= 0:
            return min(max((x - lo) / (hi - lo), 0.0), 1.0)
        s = sigma / math.sqrt(self.H)
        m = self.optimum
        total = log_normal_mass((lo - m) / s, (hi - m) / s)
        if x <= lo or total == -math.inf:
            return 0.0 if x <= lo else min(max((x - lo) / (hi - lo), 0.0), 1.0)
        if x >= hi:
            return 1.0
        return math.exp(log_normal_mass((lo - m) / s, (x - m) / s) - total)


def quadratic_at(signal: np.ndarray, x0: float, model: np.ndarray, jacobian: np.ndarray) -> Quadratic:
    r = signal - model
    return Quadratic(x0=float(x0), rss0=float(r @ r), g=float(jacobian @ r), H=float(jacobian @ jacobian))


def estimate_noise(signal: Signal, clean: np.ndarray, fronts: np.ndarray, first_depth: int) -> tuple[float | None, str]:
    """rms of (signal − clean model) before the earliest possible echo, t < 2 t_front(first_depth).

    None when fewer than NOISE_MIN_SAMPLES samples precede it.
    """
    end = 2 * fronts[first_depth]
    window = signal.t < end
    count = int(window.sum())
    if count < NOISE_MIN_SAMPLES:
        return None, f"only {count} samples before the earliest possible echo (t < {end:.4g})"
    residual = signal.v[window] - clean[window]
    sigma = float(np.sqrt(np.mean(residual**2)))
    return sigma, f"{count} samples before the earliest possible echo (t < {end:.4g})"


def _class_bounds(grid: Grid) -> dict:
    low, high = grid.mass_ratio_range
    return {"light": (math.log(low), 0.0), "heavy": (0.0, math.log(high))}


def lagrange_weights(nodes: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Local cubic Lagrange interpolation on increasing ``nodes``: values and x-derivatives at ``points``.

    Returns W, dW of shape (P, n) so that f(points) ≈ W @ f(nodes), f'(points) ≈ dW @ f(nodes); each
    point uses the 4 nodes around it (3 or 2 where fewer exist).
    """
    n = nodes.size
    width = min(4, n)
    W = np.zeros((points.size, n))
    dW = np.zeros((points.size, n))
    for p, x in enumerate(points):
        i = int(np.clip(np.searchsorted(nodes, x) - 1, 0, n - 1))
        first = int(np.clip(i - 1, 0, n - width))
        idx = range(first, first + width)
        for a in idx:
            others = [b for b in idx if b != a]
            denominator = np.prod([nodes[a] - nodes[b] for b in others])
            W[p, a] = np.prod([x - nodes[b] for b in others]) / denominator
            dW[p, a] = sum(np.prod([x - nodes[c] for c in others if c != b]) for b in others) / denominator
    return W, dW


@functools.lru_cache(maxsize=16)
def _fine_interpolation(nodes: tuple[float, ...], points: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The fine x grid over increasing ``nodes`` (``points`` per interval) and the local-cubic weights W and
    derivatives dW on it, read-only (kept: a detection asks four times for the same nodes, a study every time)."""
    xs = np.array(nodes)
    fine = np.linspace(xs[0], xs[-1], (xs.size - 1) * points + 1)
    W, dW = lagrange_weights(xs, fine)
    for array in (fine, W, dW):
        array.flags.writeable = False
    return fine, W, dW


def _class_interpolation(library: Library, kind: str):
    """The class's library columns, their order in x = ln μ (the clean chain appended at x = 0), the fine
    x grid (INTERPOLATION_POINTS per interval) and the local-cubic weights W and derivatives dW on it."""
    grid = library.grid
    columns = grid.light if kind == "light" else grid.heavy
    xs = np.concatenate([grid.log_mass_ratio[columns], [0.0]])
    order = np.argsort(xs)
    fine, W, dW = _fine_interpolation(tuple(xs[order].tolist()), INTERPOLATION_POINTS)
    return columns, order, fine, W, dW


def rss_from_projections(
    residual_norm2: float | np.ndarray, projections: np.ndarray, gram: np.ndarray, W: np.ndarray
) -> np.ndarray:
    """|e − W @ D|² per row of W, from e's projections on the rows of D and their Gram matrix alone.

    RSS = |e|² − 2 W (D e) + diag(W (D Dᵀ) Wᵀ). ``residual_norm2``: |e|² (a number, or one per leading index);
    ``projections``: D e, shape (..., n); ``gram``: D Dᵀ, shape (..., n, n); W: shape (P, n). Returns shape (..., P),
    clipped at 0 (rounding can leave a perfect fit slightly negative)."""
    quadratic = np.einsum("pi,...ip->...p", W, gram @ W.T)
    rss = np.asarray(residual_norm2)[..., None] - 2.0 * (projections @ W.T) + quadratic
    return np.maximum(rss, 0.0)


def interpolated_rss(signal: np.ndarray, models: np.ndarray, clean: np.ndarray, W: np.ndarray) -> np.ndarray:
    """|signal − W @ models|² per row of W, without forming the (rows × samples) interpolated traces.

    With e = signal − clean and D = models − clean (each row of W sums to 1, so W @ models − clean =
    W @ D): RSS = |e|² − 2 W (D e) + diag(W (D Dᵀ) Wᵀ) (:func:`rss_from_projections`). D Dᵀ is a small Gram
    matrix (nodes × nodes), so the cost is O(nodes² · samples) instead of O(rows · nodes · samples);
    subtracting the clean chain first keeps the cancellation to the size of the echoes, not of the whole
    signal."""
    e = signal - clean
    D = models - clean[None]
    return rss_from_projections(float(e @ e), D @ e, D @ D.T, W)


def _class_rss(
    residual_norm2: float | np.ndarray, projections: np.ndarray, gram: np.ndarray, library: Library, kind: str
):
    """Per depth, the RSS of the class's interpolated library against the signal, at every fine x.

    ``projections``: the echoes' projections on the clean chain's residual e = signal − clean, shape (D, M);
    ``gram``: the echoes' Gram matrices over the same samples, shape (D, M, M); ``residual_norm2``: |e|² over
    them (a number, or shape (D,)). Returns the fine x grid (P,), the weights W and derivatives dW (P, n), the
    class's nodes' projections (D, n) and Gram matrices (D, n, n) in x order (the clean chain a node of echo 0),
    and the RSS (D, P), inf at points whose interpolation weighs a candidate that did not run OK."""
    columns, order, fine, W, dW = _class_interpolation(library, kind)
    depths, n = projections.shape[0], columns.size + 1
    node_projections = np.zeros((depths, n))
    node_projections[:, :-1] = projections[:, columns]
    node_gram = np.zeros((depths, n, n))
    node_gram[:, :-1, :-1] = gram[:, columns[:, None], columns]
    ok = np.ones((depths, n), dtype=bool)
    ok[:, :-1] = library.ok[:, columns]
    node_projections, node_gram, ok = node_projections[:, order], node_gram[:, order][:, :, order], ok[:, order]
    unusable = ((np.abs(W) > 0)[None] & ~ok[:, None, :]).any(axis=-1)
    rss = np.where(unusable, np.inf, rss_from_projections(residual_norm2, node_projections, node_gram, W))
    return fine, W, dW, node_projections, node_gram, rss


def _echo_projections(residual: np.ndarray, library: Library) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """The library's echoes projected on the clean chain's residual e = signal − clean [(length/time)²]: over all
    samples, shape (D, M), and over each depth's first-echo window, (|e|² there, shape (D,); the projections,
    shape (D, M)). One pass over the echoes, depth by depth (the window and the rest of one depth's echoes while
    they are in cache: faster than a product with a masked copy of e per depth)."""
    projections = np.empty(library.ok.shape)
    first_norm2 = np.empty(library.ok.shape[0])
    first_projections = np.empty(library.ok.shape)
    for k, end in enumerate(library.first_echo_ends.tolist()):
        echoes, head = library.echoes[k], residual[:end]
        first_norm2[k] = head @ head
        first_projections[k] = echoes[:, :end] @ head
        projections[k] = first_projections[k] + echoes[:, end:] @ residual[end:]
    return projections, (first_norm2, first_projections)


def _candidate_rss(residual_norm2: float, projections: np.ndarray, library: Library) -> np.ndarray:
    """RSS of every library candidate against the signal, |e − echo|², shape (D, M); inf where it did not run OK."""
    rss = residual_norm2 - 2.0 * projections + np.einsum("dmm->dm", library.gram)
    return np.where(library.ok, np.maximum(rss, 0.0), np.inf)


def _library_quadratics(
    residual_norm2: float, projections: np.ndarray, library: Library, kind: str
) -> list[Quadratic | None]:
    """Per depth, the Gauss–Newton quadratic at the best point of the class's interpolated library.

    The traces are interpolated in x = ln μ (local cubic through the library's ratios and the clean
    chain at x = 0) at INTERPOLATION_POINTS points per interval; x0 is the point of least RSS, J the
    interpolant's derivative there. All from the residual e = signal − clean (|e|², and the echoes'
    projections on it, shape (D, M)) and the library's Gram matrices: with w, w' the weights and derivatives
    at x0 and G, b the class's nodes' Gram matrix and projections, J·r = w'·(b − G w), J·J = w'·G w'.
    """
    fine, W, dW, b, G, rss = _class_rss(residual_norm2, projections, library.gram, library, kind)
    rows = np.arange(rss.shape[0])
    j = np.argmin(rss, axis=1)
    w, dw = W[j], dW[j]
    g = np.einsum("di,di->d", dw, b - np.einsum("dij,dj->di", G, w))
    H = np.einsum("di,dij,dj->d", dw, G, dw)
    return [
        Quadratic(x0=x0, rss0=rss0, g=gk, H=Hk) if usable else None
        for x0, rss0, gk, Hk, usable in zip(
            fine[j].tolist(), rss[rows, j].tolist(), g.tolist(), H.tolist(), np.isfinite(rss).any(axis=1).tolist()
        )
    ]


def _first_echo_scores(
    first_echo: tuple[np.ndarray, np.ndarray], library: Library, kind: str
) -> tuple[np.ndarray, np.ndarray]:
    """Per depth: how much the class's interpolated library reduces the RSS of the clean chain over the
    samples before 2 t_front(d + FIRST_ECHO_GRAINS) (its first echo and little else), and the best x there
    (-inf and 0 for a window of fewer than 2 samples). ``first_echo``: |e|² and the echoes' projections over
    each depth's window (:func:`_echo_projections`)."""
    norm2, projections = first_echo
    fine, _, _, _, _, rss = _class_rss(norm2, projections, library.first_echo_gram, library, kind)
    j = np.argmin(rss, axis=1)
    windowed = library.first_echo_ends >= 2
    gain = np.where(windowed, norm2 - rss[np.arange(rss.shape[0]), j], -np.inf)
    return gain, np.where(windowed, fine[j], 0.0)


CLASSES = ("none", "light", "heavy")


def depth_log_evidence(quads: list[Quadratic | None], bounds: tuple[float, float], sigma: float) -> np.ndarray:
    """Per depth, ln of the likelihood averaged over the class's prior range of x = ln μ (without constants;
    -inf where the depth has no quadratic), shape (D,); ``sigma``: σ of the noise [length/time]."""
    lo, hi = bounds
    return np.array([q.log_integral(lo, hi, sigma) if q is not None else -math.inf for q in quads])


def class_posterior(
    quads: dict, bounds: dict, sigma: float, rss_clean: float, sample_count: int
) -> tuple[dict, dict, dict]:
    """Evidence of each class from the quadratics of each depth (``quads``, ``bounds``: per class light and heavy),
    the clean chain's RSS and σ [length/time], with equal class odds and a uniform depth prior. Returns (ln
    evidence per class, posterior probability per class, p(depth | class) per class light and heavy, shape (D,))."""
    norm = -0.5 * sample_count * math.log(2 * math.pi * sigma**2)
    log_prior_depth = -math.log(len(quads["light"]))
    per_depth = {kind: depth_log_evidence(quads[kind], bounds[kind], sigma) + log_prior_depth for kind in quads}
    log_z = {
        "none": norm - rss_clean / (2 * sigma**2),
        "light": norm + logsumexp(per_depth["light"]),
        "heavy": norm + logsumexp(per_depth["heavy"]),
    }
    total = logsumexp(list(log_z.values()))
    probability = {kind: math.exp(log_z[kind] - total) for kind in CLASSES}
    posterior = {kind: np.exp(per_depth[kind] - logsumexp(per_depth[kind])) for kind in ("light", "heavy")}
    return log_z, probability, posterior


def posterior_estimate(
    p: np.ndarray,
    quads: list[Quadratic | None],
    bounds: tuple[float, float],
    depths: np.ndarray,
    sigma: float,
    credible: float,
) -> tuple[int, tuple[int, int], float, tuple[float, float]]:
    """One class's answer from its posterior over depth ``p`` (shape (D,)) and each depth's quadratic: the mode's
    depth and the central ``credible`` interval of depth; μ = exp(x) at the mode's optimum (inside ``bounds``) and
    the central interval of the posterior over x, a mixture over depths of truncated Gaussians. Returns (depth,
    depth interval, mass ratio, mass ratio interval)."""
    k_best = int(np.argmax(p))
    cdf = np.cumsum(p)
    tail = (1 - credible) / 2
    depth_interval = (
        int(depths[int(np.searchsorted(cdf, tail))]),
        int(depths[min(int(np.searchsorted(cdf, 1 - tail)), len(depths) - 1)]),
    )
    lo, hi = bounds
    mass_ratio = math.exp(min(max(quads[k_best].optimum, lo), hi))
    weights = [(p[k], quads[k]) for k in range(len(depths)) if p[k] > 1e-12 and quads[k] is not None]
    wsum = sum(w for w, _ in weights)

    def mixture_cdf(x: float) -> float:
        return sum(w * q.cdf(x, lo, hi, sigma) for w, q in weights) / wsum

    mass_interval = (
        math.exp(bisect_increasing(mixture_cdf, tail, lo, hi)),
        math.exp(bisect_increasing(mixture_cdf, 1 - tail, lo, hi)),
    )
    return int(depths[k_best]), depth_interval, mass_ratio, mass_interval
