"""Work–precision studies: the error of a run against its cost, per method, step and precision.

**Reference.** The error of a run is measured against the same scene integrated with ``gear6`` in
float64 at a step ``reference_factor`` (default 4) times smaller than the finest step studied.
gear6 is the highest-order method here (order 6 in the positions, tests/core/test_order_of_accuracy.py): at that
step its truncation error is ``4^6 ≈ 4000`` times below its own error at the finest studied step,
and orders of magnitude below gear4/verlet there. That argument needs the asymptotic regime, so
it is checked, not assumed: the reference is also run at 2× and 4× its step and a Richardson
estimate of its error is formed from the three,

    p_obs = log2(‖u_4h − u_2h‖ / ‖u_2h − u_h‖),   err_ref ≈ ‖u_2h − u_h‖ / (2^p − 1),

with ``p`` the observed order clamped to [1, 6] (a non-smooth problem — contacts opening at
l0 = 0 — shows a lower order and gets a larger, more honest estimate; at round-off the
differences stop shrinking and ``p`` falls to 1, so the estimate becomes the difference itself).
Records whose error is within a factor 10 of ``err_ref`` are marked ``reference_limited``: their
error is not resolved by this reference. A reference that is not finite is refused. The reference
takes event-aware steps (kernels/events.py) unless only ``events = ["off"]`` is studied; with
``events = ["auto", "off"]`` every run is made both ways (before/after curves, docs/stability.md §6b).

**Error.** ``max over records and grains |u − u_ref| / max|u_ref|``: positions compared at the same
times, so every step (and the reference's) must divide the record interval. The study chooses
``record.every`` as a common multiple of all steps (about ``records`` snapshots over the duration),
keeping the scene's own interval when it already is one. The energy error is the run's own
(docs/model.md §5, at every record). Time is the run's wall seconds without kernel compilation; every run
of a study uses the same kernel (:func:`study_kernel`), so times compare.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from fractions import Fraction
from pathlib import Path

import numpy as np
import warp as wp
from hertzian.core.check import check_scene
from hertzian.core.devices import default_device, init_warp
from hertzian.core.model import build_model
from hertzian.core.outputs import PNG_METADATA, provenance, write_part
from hertzian.core.runner import Runner
from hertzian.core.scene import EVENT_MODES, METHODS, PRECISIONS, Scene, SceneError
from hertzian.core.solvers import KERNELS
from hertzian.core.status import Status

REFERENCE_METHOD = "gear6"
REFERENCE_ORDER = 6
RESOLVED_FACTOR = 10.0
"""An error at least this many times the reference's estimated error is resolved by the reference."""


@dataclass(frozen=True)
class ReferenceRun:
    """The gear6 float64 reference of a study and its Richardson error estimate."""

    dt: float
    """Reference step [time]."""
    u: np.ndarray
    """Snapshots u, shape (records, grains) [length]."""
    error_estimate: float
    """Estimated max |u_ref − u_exact| / max|u_ref| (Richardson, from steps h, 2h, 4h)."""
    observed_order: float
    """log2 of the ratio of successive differences (nan when undefined)."""
    seconds: float
    """Wall seconds of the three reference runs."""


@dataclass(frozen=True)
class AccuracyRecord:
    """One run of a work–precision study (docs/model.md §7 ``accuracy`` record)."""

    method: str
    dt: float
    """Step [time]."""
    precision: str
    error: float
    """max over records and grains |u − u_ref| / max|u_ref| (inf if the run blew up)."""
    energy_error: float
    """max_t |E(t) − E(0)| / E_inj over the records (docs/model.md §5)."""
    seconds: float
    """Wall seconds of the run (kernel compilation excluded)."""
    grain_steps_per_second: float
    steps: int
    steps_per_contact_time: float
    """T/dt with T from ``hertzian check`` (ensemble/core/check.py)."""
    status: int
    status_name: str
    reference_limited: bool
    """True when ``error`` is within a factor 10 of the reference's own estimated error."""
    events: str = "auto"
    """integrator.events of the run: auto (event-aware Gear steps, kernels/events.py) or off."""
    kernel: str = "step"
    """Which kernel ran (ensemble/core/solvers/calibrate.py): the same for every run of a study."""

    def to_dict(self) -> dict:
        return asdict(self)


def _exact(dt: float) -> Fraction:
    return Fraction(repr(float(dt)))


def common_record_interval(
    dts: list[float], duration: float, *, records: int = 40, preferred: float | None = None
) -> float:
    """A record interval [time] that every step in ``dts`` divides, near ``duration / records``.

    Keeps ``preferred`` when all steps divide it. Raises SceneError when the steps have no common
    multiple within the duration.
    """
    steps = [_exact(dt) for dt in dts]
    numerator, denominator = 0, 0
    for s in steps:
        numerator = s.numerator if numerator == 0 else math.lcm(numerator, s.numerator)
        denominator = s.denominator if denominator == 0 else math.gcd(denominator, s.denominator)
    multiple = Fraction(numerator, denominator)

    def divides_all(every: float) -> bool:
        return all(abs(every / dt - round(every / dt)) <= 1e-9 * (every / dt) for dt in dts)

    if preferred is not None and preferred <= duration * (1 + 1e-12) and divides_all(preferred):
        return preferred
    if multiple > _exact(duration) * (1 + Fraction(1, 10**12)):
        raise SceneError(
            "--dt",
            ",".join(f"{d:g}" for d in dts),
            f"the steps (and the reference's, min/4) have no common multiple within the "
            f"duration {duration:g} (least common multiple {float(multiple):.3g}); use steps "
            "like 2e-4, 1e-4, 5e-5",
        )
    # the multiple of the common step nearest duration/records, preferring one that divides the duration
    total = _exact(duration) / multiple
    target = max(1, math.floor(total / max(records, 1)))
    if total.denominator == 1:
        divisors = [m for m in range(max(1, target // 2), 2 * target + 1) if total.numerator % m == 0]
        if divisors:
            target = min(divisors, key=lambda m: (abs(m - target), m))
    return float(multiple * target)


def study_scene(
    scene: Scene, *, method: str, dt: float, precision: str, every: float, events: str | None = None
) -> Scene:
    """The scene as a study runs it: one method/step/precision, positions every ``every``, no traces."""
    return scene.with_overrides(
        {
            "integrator.method": method,
            "integrator.tolerance": None,
            "integrator.dt": dt,
            "integrator.precision": precision,
            "integrator.events": events or scene.integrator.events,
            "record.every": every,
            "record.fields": ["u"],
            "record.traces": [],
            "record.trace_every": None,
            "record.energy": True,
        }
    )


def relative_error(u: np.ndarray, u_ref: np.ndarray) -> float:
    """max |u − u_ref| / max |u_ref| over all entries (inf if u is not finite; absolute if u_ref ≡ 0)."""
    u = np.asarray(u, dtype=np.float64)
    u_ref = np.asarray(u_ref, dtype=np.float64)
    if u.shape != u_ref.shape:
        raise ValueError(f"snapshots of shape {u.shape} and {u_ref.shape} are not at the same times")
    if not np.all(np.isfinite(u)):
        return math.inf
    scale = float(np.max(np.abs(u_ref)))
    return float(np.max(np.abs(u - u_ref))) / (scale if scale > 0 else 1.0)


def richardson_estimate(
    u_h: np.ndarray, u_2h: np.ndarray, u_4h: np.ndarray, *, max_order: float = REFERENCE_ORDER
) -> tuple[float, float]:
    """(estimated relative error of u_h, observed order) from three runs at steps h, 2h, 4h."""
    runs = [np.asarray(u, dtype=np.float64) for u in (u_h, u_2h, u_4h)]
    if not all(np.all(np.isfinite(u)) for u in runs):
        return math.inf, math.nan
    scale = float(np.max(np.abs(runs[0]))) or 1.0
    fine = float(np.max(np.abs(runs[1] - runs[0]))) / scale
    coarse = float(np.max(np.abs(runs[2] - runs[1]))) / scale
    if fine == 0.0:
        return 0.0, math.nan
    observed = math.log2(coarse / fine) if coarse > 0 else math.nan
    order = min(max(observed, 1.0), max_order) if math.isfinite(observed) else 1.0
    return fine / (2.0**order - 1.0), observed


def study_kernel(scene: Scene, device: str | None) -> str:
    """The kernel every run of a study uses, so that their times compare (``auto`` would switch kernels with
    the run length): on a CPU the chain-per-thread kernel (it implements every feature); on a GPU ``auto``
    (ensemble/core/solvers/calibrate.py)."""
    return "auto" if not wp.get_device(device).is_cpu else "chain"


def _run(scene: Scene, device: str | None, kernel: str = "auto"):
    """(RunResult, name of the kernel that ran)."""
    init_warp()
    result = Runner(build_model([scene], device or default_device()), kernel=kernel).run()
    return result, result.kernel


def reference_run(
    scene: Scene, dt: float, every: float, device: str | None = None, *, kernel: str = "auto"
) -> ReferenceRun:
    """gear6 float64 at ``dt``, checked against 2·dt and 4·dt (Richardson); see the module docstring."""
    runs = [
        _run(study_scene(scene, method=REFERENCE_METHOD, dt=dt * f, precision="float64", every=every), device, kernel)[
            0
        ]
        for f in (1, 2, 4)
    ]
    u_h, u_2h, u_4h = (r.u[0] for r in runs)
    if not np.all(np.isfinite(u_h)):
        raise SceneError(
            "--dt",
            f"{dt * 4:g}",
            f"the reference ({REFERENCE_METHOD} at dt = {dt:g}) is not "
            "finite: the scene is unstable even there; use smaller steps",
        )
    estimate, observed = richardson_estimate(u_h, u_2h, u_4h)
    return ReferenceRun(
        dt=dt, u=u_h, error_estimate=estimate, observed_order=observed, seconds=sum(r.wall_seconds for r in runs)
    )


def parse_list(key: str, text: str, allowed: tuple[str, ...]) -> list[str]:
    """'gear4,verlet' → ['gear4', 'verlet'] (each checked against ``allowed``)."""
    items = [w.strip() for w in text.split(",") if w.strip()]
    if not items:
        raise SceneError(key, text, f"give a comma-separated list of {', '.join(allowed)}")
    for item in items:
        if item not in allowed:
            raise SceneError(key, item, f"allowed: {', '.join(allowed)}")
    return list(dict.fromkeys(items))


def _positive_numbers(texts: list[str], key: str, example: str) -> list[float]:
    """Comma-separated finite numbers > 0 from ``texts`` (no repeats), largest first; SceneError on ``key``."""
    values = []
    for text in texts:
        for word in (w.strip() for w in text.split(",")):
            if not word:
                continue
            try:
                value = float(word)
            except ValueError:
                raise SceneError(key, word, f"must be a number > 0, e.g. {example}") from None
            if not (value > 0 and math.isfinite(value)):
                raise SceneError(key, word, f"must be > 0 and finite, e.g. {example}")
            values.append(value)
    if texts and not values:
        raise SceneError(key, ",".join(texts), f"give at least one number > 0, e.g. {example}")
    return sorted(set(values), reverse=True)


def parse_steps(text: str) -> list[float]:
    """'1e-4,5e-5' → [1e-4, 5e-5] (positive, finite, no repeats), largest first."""
    return _positive_numbers([text], "--dt", "--dt 1e-4,5e-5")


def default_steps(scene: Scene) -> list[float]:
    """The steps a study takes when none are given: twice, once and half the scene's dt, so that the study is
    on the scene's own time scale (a Hertz pulse, a lattice's phonons alike). A scene run to a tolerance has no dt
    of its own: refused in one line."""
    if scene.integrator.tolerance is not None:
        raise SceneError("--dt", None, "required for a scene run to a tolerance (it has no dt): e.g. --dt 1e-4,5e-5")
    dt = scene.integrator.dt
    return [2 * dt, dt, dt / 2]


TARGET_MEASURES = ("energy", "error")
"""What ``--target`` bounds: the energy error (docs/model.md §5, the default) or the position error against the reference."""


@dataclass(frozen=True)
class TimeToTarget:
    """The cheapest way a study found to meet one accuracy target with one method and precision.

    ``dt`` is the largest step of the study meeting ``target`` on ``measure`` (steps are the study's own,
    not interpolated); ``seconds`` is that run's wall seconds. ``dt`` and ``seconds`` are None when no step
    of the study meets the target.
    """

    target: float
    measure: str
    """"energy": max_t |E(t) − E(0)| / E_inj; "error": max |u − u_ref| / max|u_ref|."""
    method: str
    precision: str
    events: str
    dt: float | None
    """Largest studied step meeting the target [time], or None."""
    seconds: float | None
    """Wall seconds of the run at ``dt`` (kernel compilation excluded), or None."""
    error: float | None
    energy_error: float | None
    reference_limited: bool = False
    """Measure "error" only: the run's error is within a factor 10 of the reference's estimated error."""

    def to_dict(self) -> dict:
        return asdict(self)


def parse_targets(texts: list[str]) -> list[float]:
    """['1e-6,1e-8', '1e-7'] → [1e-6, 1e-7, 1e-8] (each a finite number > 0, no repeats), largest first."""
    return _positive_numbers(texts, "--target", "--target 1e-6,1e-8")


@dataclass(frozen=True)
class StudyRequest:
    """What a work–precision study runs and reports, checked (the options of ``hertzian accuracy``)."""

    methods: list[str]
    dts: list[float]
    """Steps [time], largest first."""
    precisions: list[str]
    events: list[str]
    """integrator.events modes: each run is made once per mode."""
    targets: list[float]
    """Accuracy targets (dimensionless), largest first; empty: no time-to-target table."""
    measure: str
    """What the targets bound: one of TARGET_MEASURES."""
    reference_factor: int
    records: int
    kernel: str | None
    """A kernel name of KERNELS, or None for :func:`study_kernel`."""


def _modes(key: str, text: str | None, default: str, both: list[str]) -> list[str]:
    """``text`` as a list of modes: None → [default], "both" → ``both``, one of ``both`` → [text]."""
    if text is None:
        return [default]
    if text == "both":
        return list(both)
    if text in both:
        return [text]
    raise SceneError(key, text, f"allowed: {', '.join(both)}, both")


def study_request(
    scene: Scene,
    *,
    methods: str,
    dt: str | None,
    precision: str | None = None,
    events: str | None = None,
    targets: list[str] | None = None,
    measure: str = "energy",
    reference_factor: int = 4,
    records: int = 40,
    kernel: str | None = None,
) -> StudyRequest:
    """The study's options as given on the command line (comma-separated text), checked; SceneError on the first
    bad one (steps default to :func:`default_steps`, precision and events to the scene's; "both" studies both
    values)."""
    method_list, steps, target_list = (
        parse_list("--methods", methods, METHODS),
        parse_steps(dt) if dt is not None else default_steps(scene),
        parse_targets(targets or []),
    )
    if measure not in TARGET_MEASURES:
        raise SceneError("--measure", measure, f"allowed: {', '.join(TARGET_MEASURES)}")
    precisions = _modes("--precision", precision, scene.integrator.precision, ["float64", "float32"])
    event_modes = _modes("--events", events, scene.integrator.events, ["auto", "off"])
    if reference_factor < 1:
        raise SceneError("--reference-factor", reference_factor, "must be an integer ≥ 1")
    if records < 1:
        raise SceneError("--records", records, "must be ≥ 1")
    if kernel is not None and kernel not in KERNELS:
        raise SceneError("--kernel", kernel, f"allowed: {', '.join(KERNELS)}")
    return StudyRequest(
        methods=method_list,
        dts=steps,
        precisions=precisions,
        events=event_modes,
        targets=target_list,
        measure=measure,
        reference_factor=reference_factor,
        records=records,
        kernel=kernel,
    )


def _meets(record: AccuracyRecord, target: float, measure: str) -> bool:
    value = record.energy_error if measure == "energy" else record.error
    return record.status == 0 and math.isfinite(value) and value <= target


def time_to_target(records: list[AccuracyRecord], targets: list[float], measure: str = "energy") -> list[TimeToTarget]:
    """Per target and (method, precision, events) of a study's records, the largest step meeting the target.

    A step meets the target when its run ended OK and its ``measure`` is finite and ≤ target; every step
    of the study is tried (no interpolation, no assumption that smaller steps do better). Rows are ordered
    by target (largest first), then by wall seconds (cheapest first); rows where no step meets the target
    come last.
    """
    if measure not in TARGET_MEASURES:
        raise SceneError("--measure", measure, f"allowed: {', '.join(TARGET_MEASURES)}")
    groups: dict[tuple[str, str, str], list[AccuracyRecord]] = {}
    for r in records:
        groups.setdefault((r.method, r.precision, r.events), []).append(r)
    rows = []
    for target in sorted(set(targets), reverse=True):
        found = []
        for (method, precision, events), runs in groups.items():
            meeting = [r for r in runs if _meets(r, target, measure)]
            best = max(meeting, key=lambda r: r.dt) if meeting else None
            found.append(
                TimeToTarget(
                    target=target,
                    measure=measure,
                    method=method,
                    precision=precision,
                    events=events,
                    dt=best.dt if best else None,
                    seconds=best.seconds if best else None,
                    error=best.error if best else None,
                    energy_error=best.energy_error if best else None,
                    reference_limited=bool(best and measure == "error" and best.reference_limited),
                )
            )
        found.sort(
            key=lambda t: (
                t.seconds is None,
                t.seconds if t.seconds is not None else 0.0,
                METHODS.index(t.method) if t.method in METHODS else 0,
            )
        )
        rows.extend(found)
    return rows


def work_precision(
    scene: Scene,
    methods: list[str],
    dts: list[float],
    precisions: list[str],
    *,
    device: str | None = None,
    reference_factor: int = 4,
    records: int = 40,
    kernel: str | None = None,
    progress=None,
    events: list[str] | None = None,
) -> tuple[list[AccuracyRecord], ReferenceRun, float]:
    """Run every (events, precision, method, dt) of a study and measure it against a gear6 reference.

    Returns (records, reference, record interval). ``kernel`` (ensemble/core/solvers/calibrate.py KERNELS) is the
    same for every run; default :func:`study_kernel`. ``progress(text)`` is called before each run.
    ``events`` (integrator.events modes, default the scene's): with both, every run is made with and
    without event-aware steps (before/after curves); the reference uses them unless only "off" is asked.
    """
    for m in methods:
        if m not in METHODS:
            raise SceneError("--methods", m, f"allowed: {', '.join(METHODS)}")
    for p in precisions:
        if p not in PRECISIONS:
            raise SceneError("--precision", p, "allowed: float32, float64, both")
    if reference_factor < 1:
        raise SceneError("--reference-factor", reference_factor, "must be ≥ 1")
    events = events or [scene.integrator.events]
    for e in events:
        if e not in EVENT_MODES:
            raise SceneError("--events", e, "allowed: auto, off, both")
    scene = scene.with_overrides({"integrator.events": "auto" if "auto" in events else "off"})
    dts = sorted(set(dts), reverse=True)
    duration = scene.integrator.duration
    if dts[0] > duration:
        raise SceneError("--dt", dts[0], f"must not exceed integrator.duration = {duration:g}")
    reference_dt = float(_exact(dts[-1]) / reference_factor)
    every = common_record_interval(
        dts + [reference_dt, 2 * reference_dt, 4 * reference_dt],
        duration,
        records=records,
        preferred=scene.record.every,
    )
    # validate every study scene before running anything
    plan = [
        (e, p, m, dt, study_scene(scene, method=m, dt=dt, precision=p, every=every, events=e))
        for e in events
        for p in precisions
        for m in methods
        for dt in dts
    ]
    if progress:
        progress(f"reference: {REFERENCE_METHOD} float64 at dt = {reference_dt:g}, 2·dt and 4·dt")
    kernel = kernel or study_kernel(plan[0][4], device)
    reference = reference_run(scene, reference_dt, every, device, kernel=kernel)
    contact_time = check_scene(scene).contact_time
    out = []
    for e, p, m, dt, s in plan:
        if progress:
            progress(f"{m} {p} dt = {dt:g}" + (f" events {e}" if len(events) > 1 else ""))
        r, ran = _run(s, device, kernel)
        err = relative_error(r.u[0], reference.u)
        status = int(r.status[0])
        out.append(
            AccuracyRecord(
                method=m,
                dt=dt,
                precision=p,
                error=err,
                energy_error=float(r.energy_error[0]),
                seconds=float(r.wall_seconds),
                grain_steps_per_second=float(r.grain_steps_per_second),
                steps=int(r.steps),
                steps_per_contact_time=contact_time / dt,
                status=status,
                status_name=Status(status).name if status in Status._value2member_map_ else str(status),
                reference_limited=bool(err < RESOLVED_FACTOR * reference.error_estimate),
                kernel=ran,
                events=e,
            )
        )
    return out, reference, every


def plot_work_precision(
    records: list[AccuracyRecord], path, *, title: str = "", reference_error: float | None = None
) -> None:
    """Error and energy error against wall seconds, log–log, one line per (method, precision); writes ``path``.

    Open markers: errors within a factor 10 of the reference's own estimated error (drawn dotted).
    """
    # matplotlib is heavy and only needed for the figure
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.8), constrained_layout=True)
    colours = {"gear4": "C0", "gear5": "C1", "gear6": "C2", "verlet": "C3", "yoshida4": "C4", "yoshida6": "C5"}
    lines = sorted(
        {(r.method, r.precision, r.events) for r in records}, key=lambda k: (k[2], k[1], METHODS.index(k[0]))
    )
    several_events = len({k[2] for k in lines}) > 1
    methods = {m for m, _, _ in lines}
    labelled = {m for m in methods if m in ("verlet", "yoshida4", "yoshida6")} | {
        min((m for m in methods if m not in ("verlet", "yoshida4", "yoshida6")), default="")
    }
    for method, precision, events in lines:
        rows = sorted(
            (r for r in records if r.method == method and r.precision == precision and r.events == events),
            key=lambda r: r.seconds,
        )
        seconds = np.array([r.seconds for r in rows])
        colour = colours.get(method, "k")
        marker = "o" if precision == "float64" else "s"
        style = "-" if precision == "float64" else "--"
        label = f"{method} {precision}"
        if several_events:
            label += f" events {events}"
            if events == "off":
                style, marker = ":", "x"
        for ax, values in ((axes[0], [r.error for r in rows]), (axes[1], [r.energy_error for r in rows])):
            values = np.array(values, dtype=float)
            ok = np.isfinite(values) & (values > 0)
            ax.loglog(seconds[ok], values[ok], marker=marker, linestyle=style, color=colour, label=label, markersize=4)
        for r in rows:
            if r.reference_limited and np.isfinite(r.error) and r.error > 0:
                axes[0].plot([r.seconds], [r.error], marker=marker, markersize=7, markerfacecolor="white", color=colour)
            if method in labelled and precision == "float64" and np.isfinite(r.error) and r.error > 0:
                axes[0].annotate(
                    f"{r.dt:g}",
                    (r.seconds, r.error),
                    fontsize=6,
                    textcoords="offset points",
                    xytext=(3, 3),
                    color=colour,
                )
    if reference_error is not None and reference_error > 0 and np.isfinite(reference_error):
        axes[0].axhline(reference_error, color="0.4", linestyle=":", linewidth=1)
        axes[0].annotate(
            "reference's estimated error",
            (axes[0].get_xlim()[1], reference_error),
            fontsize=7,
            textcoords="offset points",
            xytext=(-4, -9),
            ha="right",
            color="0.3",
        )
    axes[0].set_ylabel("max |u − u_ref| / max |u_ref|")
    axes[1].set_ylabel("energy error max |E(t) − E(0)| / E_inj")
    for ax in axes:
        ax.set_xlabel("wall seconds")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8)
    if title:
        fig.suptitle(title, fontsize=9)
    fig.savefig(path, dpi=130, metadata=PNG_METADATA)
    plt.close(fig)


def write_record(out: Path, part: str, scene: Scene, source: dict, request, device: str) -> dict:
    """Run the study ``request`` on ``scene`` and put it into the JSON record ``out`` under ``parts.<part>`` (other
    parts kept): ``source`` (the command, the scene file and overrides), the date, the device, the reference (its
    step, estimated error and observed order), every run's record and, for the request's targets, the largest
    step meeting each (:func:`time_to_target`)."""
    results, reference, every = work_precision(
        scene,
        request.methods,
        request.dts,
        request.precisions,
        device=device,
        events=request.events,
        reference_factor=request.reference_factor,
        records=request.records,
        kernel=request.kernel,
    )
    value = (
        provenance(device)
        | source
        | {
            "record_every": every,
            "reference": {
                "method": REFERENCE_METHOD,
                "dt": reference.dt,
                "error_estimate": reference.error_estimate,
                "observed_order": reference.observed_order,
                "seconds": reference.seconds,
            },
            "records": [r.to_dict() for r in results],
        }
    )
    if request.targets:
        value["targets"] = [t.to_dict() for t in time_to_target(results, request.targets, request.measure)]
    write_part(out, part, value)
    return value


def parse_across(text: str) -> tuple[str, list[float]]:
    """'excitation.impact=0.0099,0.01' → ('excitation.impact', [0.0099, 0.01]): a scene key and its values."""
    key, _, values = text.partition("=")
    try:
        numbers = [float(v) for v in values.split(",")]
    except ValueError:
        numbers = []
    if not key.strip() or not numbers or not all(math.isfinite(v) for v in numbers):
        raise SceneError("--across", text, "KEY=V1,V2,… (a scene key and numbers)")
    return key.strip(), numbers


def energy_across(scene: Scene, key: str, values: list[float], request, device: str) -> list[dict]:
    """The energy error of ``scene`` at each of ``values`` of ``key``, per (events, precision, method, dt) of
    ``request``: one ensemble of len(values) chains per configuration (no reference, no position error). Only
    the energy is recorded, every record.every of the scene (which sets how often the energy is checked)."""
    kernel = request.kernel or study_kernel(scene, device)
    init_warp()
    rows = []
    for events in request.events:
        for precision in request.precisions:
            for method in request.methods:
                for dt in request.dts:
                    change = {"integrator.method": method, "integrator.dt": dt, "integrator.tolerance": None}
                    change |= {"integrator.precision": precision, "integrator.events": events}
                    change |= {"record.fields": [], "record.traces": [], "record.trace_every": None}
                    scenes = [scene.with_overrides(change | {key: value}) for value in values]
                    result = Runner(build_model(scenes, device), kernel=kernel).run()
                    rows.append(
                        {"method": method, "events": events, "precision": precision, "dt": dt}
                        | {"energy_errors": result.energy_error.tolist(), "status": result.status.tolist()}
                        | {"seconds": float(result.wall_seconds), "kernel": result.kernel}
                    )
    return rows


def main(argv: list[str] | None = None) -> None:
    """``python -m hertzian.studies.accuracy --out FILE --part NAME [SCENE] [--set k=v …] --methods … --dt …
    [--precision …] [--events …] [--target …] [--measure …] [--device …]``: a work–precision study (what
    ``hertzian accuracy`` prints with ``--json``) written into a JSON record with its command, date and device.
    With ``--across KEY=V1,V2,…``: instead, each configuration's energy error at every value of KEY
    (:func:`energy_across`)."""
    import argparse
    import shlex
    import sys

    argv = sys.argv[1:] if argv is None else argv
    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument("scene", nargs="?", default=None)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--part", required=True)
    parser.add_argument("--set", dest="overrides", action="append", default=[])
    parser.add_argument("--methods", default="gear4,gear5,gear6,verlet")
    parser.add_argument("--dt", default=None)
    parser.add_argument("--precision", default=None)
    parser.add_argument("--events", default=None)
    parser.add_argument("--target", action="append", default=[])
    parser.add_argument("--measure", default="energy")
    parser.add_argument("--across", default=None)
    parser.add_argument("--device", default="cpu")
    args = parser.parse_args(argv)
    from hertzian.core.outputs import why_not_writable
    from hertzian.core.scene import load_scene, parse_overrides
    from hertzian.core.shipped import example_path, shipped_file

    why = why_not_writable(args.out)
    if why:
        raise SceneError("--out", str(args.out), why)

    scene = load_scene(
        shipped_file(args.scene) if args.scene else example_path("impact"), parse_overrides(args.overrides)
    )
    request = study_request(
        scene,
        methods=args.methods,
        dt=args.dt,
        precision=args.precision,
        events=args.events,
        targets=args.target,
        measure=args.measure,
    )
    source = {
        "command": "python -m hertzian.studies.accuracy " + shlex.join(argv),
        "scene": args.scene or "built-in example",
        "overrides": args.overrides,
    }
    if args.across is not None:
        key, values = parse_across(args.across)
        rows = energy_across(scene, key, values, request, args.device)
        write_part(args.out, args.part, provenance(args.device) | source | {"key": key, "values": values, "rows": rows})
        print(f"wrote {args.out} → parts.{args.part} ({len(rows)} configurations × {len(values)} values)")
        return
    part = write_record(args.out, args.part, scene, source, request, args.device)
    print(f"wrote {args.out} → parts.{args.part} ({len(part['records'])} runs)")


if __name__ == "__main__":
    import sys

    try:
        main()
    except SceneError as err:
        print(f"error: {err}", file=sys.stderr)
        sys.exit(2)
