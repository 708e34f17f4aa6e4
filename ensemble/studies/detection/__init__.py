"""Soliton spectroscopy: locate and identify a buried impurity from the surface grain's velocity.

The measurement is the velocity ``v(t)`` of grain 0 after an impact at t = 0, sampled uniformly.
The host chain without impurities (BASE) is known. The unknowns are the class (``none``, ``light``,
``heavy``), the depth ``d`` (index of the impurity grain; of the first grain of a block of ``block``
grains) and the mass ratio ``μ = m_impurity / m_host`` (self-constant a as the host's; with ``fit_a``
also ``a / a_host``, fitted at the depth found and its neighbours: :func:`fit_contact`).

**Forward model.** BASE plus one impurity block at depth d with mass μ·m, impact at grain 0, grain 0's
velocity traced at exactly the signal's sample times: the step is the largest ``dt' ≤ dt_BASE`` that
divides the sample spacing (no interpolation). A whole library of candidate chains (depth × mass
ratio, coarse) is one ensemble run (:func:`hertzian.core.runner.run_ensemble`), cached per BASE under
``$HERTZIAN_DETECT_CACHE`` (default ``~/.cache/hertzian/detect/``).

With BASE's step unset (``dt_given = False``) the step is the largest spacing/k (k = 1, 2, 4, …) whose clean
trace moves by at most σ/10 when the step is halved (:mod:`hertzian.studies.detection.step`).

**Window.** The samples up to the return of the pulse reflected by the bottom, ``t ≤ 2 t_front(N − 1)``,
are analysed (``window`` to change it), where ``t_front(d)`` is the time the pulse front (``v_d > 1e-4
v_imp``) reaches grain d in the BASE chain's own clean run. After that time the surface signal is
dominated by the bottom reflection, whose timing depends so strongly on the impurity that the
likelihood becomes rugged in μ. Depths whose echo cannot start inside the window are not searched.

**Fine scan.** If the refined best fit still leaves σ above FINE_SCAN_MISFIT times the noise (σ before the
earliest echo, or ``noise``), its minimum may be a needle narrower than the library's and Gauss–Newton's steps
(a light grain next to the impact, whose collision sequence changes with μ): ln μ is then scanned every
FINE_SCAN_SPACING over the class's range at that depth (one ensemble run) and refined by Gauss–Newton from the
best point; the lower RSS is kept (``Detection.fine_scan`` says what ran). If the fit is still poor, both classes
are scanned more coarsely (WIDE_SCAN_SPACING) at the depths within WIDE_SCAN_DEPTHS grains, and the best (class,
depth) of that scan is scanned finely in turn (``fine_scan["wide"]``).

**Noise model.** i.i.d. Gaussian noise of standard deviation σ: ``--noise σ``, or estimated twice. First
as the rms of ``v − v_clean`` over the samples before the earliest possible echo, ``t < 2 t_front(d_min)``
(``d_min`` the shallowest depth searched; an echo cannot return faster than the pulse that causes it
travels out), or, when fewer than NOISE_MIN_SAMPLES samples precede it, from the best library
candidate's residual; this σ picks the depths to refine. Then from every sample, ``RSS_best / (S − 2)``
of the best candidate after refinement; the posterior uses this one.

**Posterior.** Likelihood ∝ exp(−‖v − v_model‖² / 2σ²); priors: the three classes equally likely,
depth uniform over the searched depths, ``x = ln μ`` uniform over ``[ln μ_min, 0)`` (light) or
``(0, ln μ_max]`` (heavy); ``none`` is the clean chain. For each depth and class the residual sum of
squares is modelled as a quadratic in x (Gauss–Newton: ``RSS(x) ≈ RSS(x0) − 2 J·r (x − x0) + J·J (x − x0)²``
with ``J = ∂v/∂x``), integrated in closed form over the class's range (a truncated Gaussian). From the
library, x0 is the best of the traces interpolated in x (local cubic through the library's ratios and
the clean chain at x = 0) and J the interpolant's derivative; the best ``refine`` depths of each class are
then refined by Gauss–Newton with J by central differences, each iteration one more ensemble run of
three chains per candidate (x0 − h, x0, x0 + h). Class probabilities are the normalised class evidences;
the depth is the posterior mode, with the central 95 % interval of the depth posterior; the mass
ratio is exp(x) at the mode's Gauss–Newton optimum, with the central 95 % interval of the class's
posterior over x (a mixture over depths of truncated Gaussians).

Units: program units (time 1.0102e-3 s, length 1e-5 m), as the scenes.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from hertzian.core.scene import Scene, SceneError
from hertzian.core.solvers.prepare import prepare_kernels
from hertzian.studies.detection.forward import (
    FRONT_THRESHOLD,
    LIBRARY_BATCH,
    bare_base,
    check_base,
    default_batch_size,
    detect_needs,
    forward_scene,
    front_times,
    impurity_scene,
    run_candidates,
)
from hertzian.studies.detection.library import (
    CACHED_ARRAYS,
    FIRST_ECHO_GRAINS,
    LIBRARY_VERSION,
    Grid,
    Library,
    assemble_library,
    build_library,
    cache_dir,
    cached_fronts,
    default_depths,
    first_echo_ends,
    library_key,
    load_library,
    make_grid,
    save_library,
)
from hertzian.studies.detection.refine import (
    ContactFit,
    fine_scan,
    fit_contact,
    fit_contact_near,
    gauss_newton,
    scan_if_poor,
    wide_scan,
)
from hertzian.studies.detection.scoring import (
    CLASSES,
    INTERPOLATION_POINTS,
    NOISE_MIN_SAMPLES,
    Quadratic,
    _candidate_rss,
    _class_bounds,
    _echo_projections,
    _first_echo_scores,
    _library_quadratics,
    bisect_increasing,
    class_posterior,
    depth_log_evidence,
    estimate_noise,
    interpolated_rss,
    lagrange_weights,
    log_normal_cdf,
    log_normal_mass,
    logsumexp,
    posterior_estimate,
    quadratic_at,
    rss_from_projections,
)
from hertzian.studies.detection.signal import Signal, read_signal, signal_from_arrays, write_signal_csv
from hertzian.studies.detection.step import StepChoice, noise_step

CREDIBLE = 0.95
"""Probability inside the reported intervals."""


@dataclass
class Detection:
    """What the surface signal says about an impurity (program units)."""

    kind: str
    """none | light | heavy."""
    class_probability: dict
    """Posterior probability of each class (equal prior odds)."""
    log_evidence: dict
    """ln of each class's evidence p(signal | class) (Gaussian noise model, σ below)."""
    depth: int | None
    """Posterior mode of the depth (first grain of the block) for the class found; None for none."""
    depth_interval: tuple[int, int] | None
    mass_ratio: float | None
    """m_impurity / m_host at the mode; 1 for none."""
    mass_ratio_interval: tuple[float, float] | None
    noise: float
    """σ used [length/time]."""
    noise_source: str
    """'given' or how it was estimated."""
    noise_before_echo: float | None
    """σ estimated from the samples before the earliest possible echo (None with --noise)."""
    depths_searched: tuple[int, int]
    window: float
    """Samples with t ≤ window were analysed [time]."""
    block: int
    best_fit: np.ndarray
    """Model surface velocity of the best candidate (the clean chain for none), shape (S,)."""
    depth_posterior: dict
    """Per class (light, heavy): p(depth | class), shape (D,)."""
    seconds: dict = field(default_factory=dict)
    """Wall seconds: library (0 if cached), refinement, total."""
    library_from_cache: bool = False
    dt: float = 0.0
    """Step of the forward model [time]."""
    refined_depths: dict = field(default_factory=dict)
    fine_scan: dict | None = None
    """When the refined best fit left σ > FINE_SCAN_MISFIT × the noise (a needle-shaped minimum in μ): the scan of
    ln μ at its depth (depth, class, points, spacing, RSS before and after; None if no scan ran)."""
    fit_a: dict | None = None
    """With --fit-a: a_ratio = a_impurity / a_host and its 95 % interval, the RSS of the joint fit and of the
    best fit with a = a_host, σ of the joint fit (None without --fit-a, or for class none)."""
    step_choice: StepChoice | None = None
    """The step the noise asks for and the one used (None when σ was neither given nor estimable)."""

    @property
    def misfit_ratio(self) -> float | None:
        """σ of the best fit over σ before the earliest echo: ≫ 1 means the best model misses the signal."""
        return None if not self.noise_before_echo else self.noise / self.noise_before_echo

    def to_dict(self) -> dict:
        return {
            "class": self.kind,
            "depth": self.depth,
            "depth_interval": list(self.depth_interval) if self.depth_interval else None,
            "mass_ratio": self.mass_ratio,
            "mass_ratio_interval": list(self.mass_ratio_interval) if self.mass_ratio_interval else None,
            "log_evidence": self.log_evidence,
            "class_probability": self.class_probability,
            "noise": self.noise,
            "noise_source": self.noise_source,
            "noise_before_echo": self.noise_before_echo,
            "misfit_ratio": self.misfit_ratio,
            "depths_searched": list(self.depths_searched),
            "window": self.window,
            "block": self.block,
            "credible": CREDIBLE,
            "dt": self.dt,
            "seconds": self.seconds,
            "library_from_cache": self.library_from_cache,
            "refined_depths": self.refined_depths,
            "fine_scan": self.fine_scan,
            "step_choice": self.step_choice.to_dict() if self.step_choice else None,
            **(self.fit_a if self.fit_a is not None else {}),
        }


def detect(
    signal: Signal,
    base: Scene,
    *,
    block: int = 1,
    noise: float | None = None,
    device: str = "cpu",
    depth_range: tuple[int, int] | None = None,
    mass_ratio_range=(0.25, 4.0),
    mass_steps: int = 7,
    refine: int = 3,
    iterations: int = 2,
    step: float = 0.02,
    window: float | None = None,
    use_cache: bool = True,
    batch_size: int | None = None,
    fit_a: bool = False,
    a_ratio_range: tuple[float, float] = (0.25, 4.0),
    dt_given: bool = True,
    say: Callable[[str], None] | None = None,
) -> tuple[Detection, Library]:
    """Class, depth and mass ratio of an impurity in BASE from a surface signal (see the module docstring).

    ``refine``: depths per class refined by Gauss–Newton (0: the library alone); ``iterations``: ensemble
    runs of refinement; ``step``: finite-difference step in ln μ; ``window``: the samples with t ≤ window
    are analysed [time] (default: until the pulse reflected by the bottom returns, 2 t_front(N − 1)); ``fit_a``:
    at the depth found, fit ln μ and ln(a/a_host) jointly (:func:`fit_contact`, a/a_host in ``a_ratio_range``)
    and report a_ratio with its interval; the mass ratio and its interval then come from the joint fit.
    ``noise``: σ [length/time], else estimated. ``dt_given``: whether BASE sets its step; when it does not, the
    forward model's step comes from the noise (:func:`hertzian.studies.detection.step.noise_step`), and when it
    does, ``Detection.step_choice`` says whether that step is needlessly small. ``say``, if given, gets one line
    before each long phase (the library, the refinement). Returns the detection and the library it used.
    """
    started = time.perf_counter()
    _check_options(base, block, noise, refine, iterations, window, fit_a, a_ratio_range)
    # every kernel variant the runs below launch, compiled side by side (on a GPU) before the first of them
    prepare_kernels(detect_needs(base), device)
    signal, fronts, depths, choice, forward = _forward_model(
        signal, base, noise, device, window, use_cache, dt_given, (block, depth_range)
    )
    grid = make_grid(depths, mass_ratio_range, mass_steps, block)
    if say is not None:
        say(_library_line(grid, forward))
    library = build_library(
        forward,
        grid,
        device,
        fronts=fronts,
        use_cache=use_cache,
        batch_size=batch_size,
        save_in_background=True,
    )
    grid, s = library.grid, signal.v
    depths = grid.depths
    residual = s - library.clean
    rss_clean = float(residual @ residual)
    projections, first_echo = _echo_projections(residual, library)
    floor = 1e-12 * float(np.max(np.abs(library.clean)))
    if noise is None:
        window_sigma, window_text, sigma = _first_noise(signal, library, rss_clean, projections, floor)
    else:
        sigma = float(noise)

    refine_start = time.perf_counter()
    bounds = _class_bounds(grid)
    quads = {kind: _library_quadratics(rss_clean, projections, library, kind) for kind in ("light", "heavy")}
    refined: dict[str, list[int]] = {"light": [], "heavy": []}
    if refine > 0:
        todo = _refinement_starts(quads, first_echo, library, bounds, sigma, refine, step)
        if say is not None:
            say(f"refining {len(todo)} candidates by Gauss–Newton ({iterations} ensemble runs)")
        final = gauss_newton(
            todo, s, forward, grid.block, depths, bounds, iterations, step, device, batch_size=batch_size
        )
        for (kind, k), q in final.items():
            quads[kind][k] = q  # the simulated quadratic replaces the library's estimate
            refined[kind].append(int(depths[k]))
    refine_seconds = time.perf_counter() - refine_start

    # σ before the echo is 0 for a noise-free signal that is the clean chain's own trace there: the floor, as for σ
    reference = noise if noise is not None else None if window_sigma is None else max(window_sigma, floor)
    fine = None
    if refine > 0:
        fine = scan_if_poor(
            s, quads, rss_clean, reference, forward, grid.block, depths, bounds, device, batch_size=batch_size
        )
    if noise is None:
        sigma, noise_source = _second_noise(signal, quads, rss_clean, floor, window_sigma, window_text)
    else:
        noise_source = "given (--noise)"
    log_z, probability, posterior = class_posterior(quads, bounds, sigma, rss_clean, signal.sample_count)
    kind = max(CLASSES, key=lambda c: log_z[c])
    depth = depth_interval = None
    mass_ratio, mass_interval, best_fit = 1.0, None, library.clean
    if kind != "none":
        depth, depth_interval, mass_ratio, mass_interval = posterior_estimate(
            posterior[kind], quads[kind], bounds[kind], depths, sigma, CREDIBLE
        )
        best_fit = run_candidates(forward, [(depth, mass_ratio)], grid.block, device)[0][0]
    fit_a_result = None
    if fit_a and kind != "none":
        depth, mass_ratio, mass_interval, best_fit, fit_a_result = fit_contact_near(
            s,
            forward,
            grid.block,
            depth,
            depths,
            bounds[kind],
            a_ratio_range,
            device,
            noise=noise,
            step=step,
            batch_size=batch_size,
            best_fit=best_fit,
            mass_ratio=mass_ratio,
            mass_interval=mass_interval,
        )
    library.finish_saving()  # the cache is complete when detect returns (a second signal may read it)
    seconds = {
        "library": library.build_seconds,
        "refinement": refine_seconds,
        **({"fine_scan": fine["seconds"]} if fine else {}),
        "total": time.perf_counter() - started,
    }
    return Detection(
        kind=kind,
        class_probability=probability,
        log_evidence=log_z,
        depth=depth,
        depth_interval=depth_interval,
        mass_ratio=mass_ratio,
        mass_ratio_interval=mass_interval,
        noise=sigma,
        noise_source=noise_source,
        noise_before_echo=window_sigma if noise is None else None,
        depths_searched=(int(depths[0]), int(depths[-1])),
        window=float(signal.t[-1]),
        block=grid.block,
        best_fit=best_fit,
        depth_posterior=posterior,
        seconds=seconds,
        library_from_cache=library.from_cache,
        dt=forward.integrator.dt,
        refined_depths=refined,
        fine_scan=fine,
        fit_a=fit_a_result,
        step_choice=choice,
    ), library


def _check_options(base: Scene, block, noise, refine, iterations, window, fit_a, a_ratio_range) -> None:
    """:func:`detect`'s options, each refused with one line (SceneError) when out of range."""
    if block < 1 or block >= base.chain.grains:
        raise SceneError("--block", block, f"must be an integer 1 … {base.chain.grains - 1}")
    if noise is not None and not (noise > 0 and math.isfinite(noise)):
        raise SceneError("--noise", noise, "must be a number > 0 (σ of the noise, program velocity)")
    if refine < 0:
        raise SceneError("--refine", refine, "must be an integer ≥ 0")
    if iterations < 1:
        raise SceneError("--iterations", iterations, "must be an integer ≥ 1")
    if window is not None and not window > 0:
        raise SceneError("--window", window, "must be a time > 0")
    if fit_a:
        a_low, a_high = a_ratio_range
        if not (0 < a_low < 1 < a_high and math.isfinite(a_high)):
            raise SceneError(
                "--a-range",
                f"{a_low},{a_high}",
                "must be two numbers a_min < 1 < a_max, both > 0 (prior range of a_impurity / a_host)",
            )


def _analysed_signal(
    signal: Signal, base: Scene, device: str, window: float | None, use_cache: bool
) -> tuple[Signal, np.ndarray]:
    """The samples analysed (t ≤ ``window``, default 2 t_front(N − 1)) and the clean chain's pulse front times
    [time], shape (N,) (cached under a key of BASE and the sample times)."""
    fronts = cached_fronts(forward_scene(base, signal.spacing, signal.sample_count), device, use_cache)
    end = 2 * float(fronts[-1]) if window is None else float(window)
    count = min(signal.sample_count, int(np.searchsorted(signal.t, end * (1 + 1e-12), side="right")))
    if count < 3:
        raise SceneError("--window", f"{end:g}", "leaves fewer than 3 samples")
    return Signal(t=signal.t[:count], v=signal.v[:count], source=signal.source), fronts


def _forward_model(
    signal: Signal, base: Scene, noise, device: str, window, use_cache: bool, dt_given: bool, searched: tuple
):
    """(the analysed signal, the pulse fronts, the depths searched, the step choice, the forward scene) of a
    detection: BASE without its own records (:func:`bare_base`), at its own step or, when it sets none, at the noise
    rule's. ``searched``: (block, depth range) of the impurities sought."""
    base = given_base = bare_base(base)
    if not dt_given:  # the pulse fronts from a step the ladder starts at, not BASE's default
        base = base.with_overrides({"integrator.dt": signal.spacing / 2})
    signal, fronts = _analysed_signal(signal, base, device, window, use_cache)
    depths = default_depths(fronts, float(signal.t[-1]), base.chain.grains, *searched)
    given = forward_scene(base, signal.spacing, signal.sample_count).integrator.dt if dt_given else None
    choice = noise_step(signal, base, fronts, int(depths[0]), noise, device, given=given)
    if not dt_given:  # with no σ to go by, BASE's step as it is
        base = given_base if choice is None else base.with_overrides({"integrator.dt": choice.dt})
    return signal, fronts, depths, choice, forward_scene(base, signal.spacing, signal.sample_count)


def _library_line(grid: Grid, forward: Scene) -> str:
    """What a detection says before its library: how many chains, how long, how much work."""
    chains = 1 + len(grid.depths) * len(grid.log_mass_ratio)
    work = chains * forward.chain.grains * forward.step_count
    return (
        f"library: {chains} chains of {forward.chain.grains} grains, {forward.step_count} steps each "
        f"({work:.3g} grain-steps; a cached library loads at once)"
    )


def _first_noise(
    signal: Signal, library: Library, rss_clean: float, projections: np.ndarray, floor: float
) -> tuple[float | None, str, float]:
    """The first σ estimate [length/time] (it picks the depths to refine): before the earliest possible echo, else
    the best library candidate's residual; returns (σ before the echo or None, how it was estimated, σ ≥ floor)."""
    window_sigma, window_text = estimate_noise(signal, library.clean, library.fronts, int(library.grid.depths[0]))
    if window_sigma is not None:
        sigma = window_sigma
    else:
        best = min(float(np.min(_candidate_rss(rss_clean, projections, library))), rss_clean)
        sigma = math.sqrt(best / (signal.sample_count - 2))
    return window_sigma, window_text, max(sigma, floor)


def _second_noise(
    signal: Signal, quads: dict, rss_clean: float, floor: float, window_sigma: float | None, window_text: str
) -> tuple[float, str]:
    """σ from every sample [length/time]: the best candidate's residual after refinement (2 fitted parameters),
    RSS/(S − 2), at least ``floor``; and how it was estimated."""
    best_rss = min([rss_clean] + [q.rss0 for kind in quads for q in quads[kind] if q is not None])
    sigma = max(math.sqrt(best_rss / (signal.sample_count - 2)), floor)
    source = f"rms residual of the best candidate over all {signal.sample_count} samples, RSS/(S − 2); " + (
        f"rms of signal − clean chain before the earliest echo: {window_sigma:.4g} over {window_text}"
        if window_sigma is not None
        else window_text
    )
    return sigma, source


def _refinement_starts(
    quads: dict, first_echo: tuple, library: Library, bounds: dict, sigma: float, refine: int, step: float
) -> list[tuple[str, int, float]]:
    """Where Gauss–Newton starts, (class, depth index, x = ln μ): per class the best ``refine`` depths by their
    library evidence over the window, and the best ``refine`` by how much of the first echo they explain (robust
    where later reverberations make the library's interpolation in μ poor), each from its own best x, kept
    ``step`` inside the class's range; a start within 2 steps of one already taken at that depth is dropped."""
    todo = []
    for kind in ("light", "heavy"):
        lo, hi = bounds[kind]
        logz = depth_log_evidence(quads[kind], bounds[kind], sigma)
        starts = [(int(k), quads[kind][k].optimum) for k in np.argsort(-logz)[:refine] if np.isfinite(logz[k])]
        gain, first_x = _first_echo_scores(first_echo, library, kind)
        starts += [(int(k), first_x[k]) for k in np.argsort(-gain)[:refine] if np.isfinite(gain[k])]
        for k, x in starts:
            x0 = min(max(x, lo + step), hi - step)
            if not any(kk == k and cc == kind and abs(xx - x0) < 2 * step for cc, kk, xx in todo):
                todo.append((kind, k, x0))
    return todo


__all__ = [
    "CACHED_ARRAYS",
    "CLASSES",
    "CREDIBLE",
    "FIRST_ECHO_GRAINS",
    "FRONT_THRESHOLD",
    "INTERPOLATION_POINTS",
    "LIBRARY_BATCH",
    "LIBRARY_VERSION",
    "NOISE_MIN_SAMPLES",
    "ContactFit",
    "Detection",
    "Grid",
    "Library",
    "Quadratic",
    "Signal",
    "assemble_library",
    "bisect_increasing",
    "build_library",
    "cache_dir",
    "check_base",
    "default_batch_size",
    "default_depths",
    "detect",
    "estimate_noise",
    "fine_scan",
    "first_echo_ends",
    "fit_contact",
    "forward_scene",
    "front_times",
    "impurity_scene",
    "interpolated_rss",
    "lagrange_weights",
    "library_key",
    "load_library",
    "log_normal_cdf",
    "log_normal_mass",
    "logsumexp",
    "make_grid",
    "quadratic_at",
    "read_signal",
    "rss_from_projections",
    "run_candidates",
    "save_library",
    "signal_from_arrays",
    "wide_scan",
    "write_signal_csv",
]
