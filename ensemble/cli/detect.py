"""``hertzian detect`` (locate and identify a buried impurity from the surface signal) and
``hertzian detect-study`` (its accuracy study). See ensemble/studies/detection/ and docs/detection.md."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Annotated, Optional

import typer
from hertzian.cli.app import (
    DeviceOption,
    SetOption,
    app,
    check_output_file,
    command_line,
    fail,
    load_scene_or_fail,
    one_line_errors,
    overrides_of,
    resolve_device,
)
from hertzian.core.scene import SceneError
from hertzian.core.shipped import shipped_file

MISFIT_WARNING = 3.0
"""Warn when the best fit's σ exceeds the σ before the earliest echo by more than this factor."""


def _pair(key: str, text: str, sep: str, kind):
    parts = text.split(sep)
    try:
        if len(parts) != 2:
            raise ValueError
        return kind(parts[0]), kind(parts[1])
    except ValueError:
        fail(f"{key} = {text!r}: must be written A{sep}B with two {'integers' if kind is int else 'numbers'}")


SignalArgument = Annotated[
    Path,
    typer.Argument(
        help="CSV with the header line t,v (grain 0's velocity sampled uniformly from the impact at t = 0, program units), or a hertzian store with a trace of grain 0."
    ),
]

SceneOption = Annotated[
    Optional[Path],
    typer.Option(
        "--scene",
        help="BASE scene TOML: the host chain without impurities (grains, l0, gravity, boundaries, impact, integrator); its duration and record are replaced.",
    ),
]

BlockOption = Annotated[int, typer.Option("--block", help="Impurity block length in grains (depth = its first grain).")]

NoiseOption = Annotated[
    Optional[float],
    typer.Option(
        "--noise",
        help="σ of the i.i.d. Gaussian noise (program velocity); default: estimated (see docs/detection.md).",
    ),
]

DepthsOption = Annotated[
    Optional[str],
    typer.Option(
        "--depths",
        help="Depths searched, A:B (default: ⌈N/20⌉ to the deepest whose echo can start within the signal).",
    ),
]

MassRangeOption = Annotated[
    str, typer.Option("--mass-range", help="Prior range of the mass ratio μ_min,μ_max (μ_min < 1 < μ_max).")
]

MassStepsOption = Annotated[
    int, typer.Option("--mass-steps", help="Library mass ratios on each side of 1 (log-spaced).")
]

RefineOption = Annotated[
    int,
    typer.Option("--refine", help="Depths per class refined by Gauss–Newton in ln μ (0: the library grid only)."),
]

IterationsOption = Annotated[int, typer.Option("--iterations", help="Gauss–Newton iterations (one ensemble run each).")]

WindowOption = Annotated[
    Optional[float],
    typer.Option(
        "--window",
        help="Analyse the samples with t ≤ this, in program time (default: until the pulse reflected by the bottom returns to the surface).",
    ),
]

FitAOption = Annotated[
    bool,
    typer.Option(
        "--fit-a",
        help="Also fit the impurity's self-constant a (as a/a_host; contacts by the scene's impurity rule, the harmonic mean) at the depth found; reports a_ratio with a 95 % interval.",
    ),
]

ARangeOption = Annotated[
    Optional[str],
    typer.Option(
        "--a-range", help="With --fit-a: prior range of a/a_host, a_min,a_max (a_min < 1 < a_max; default 0.25,4)."
    ),
]

AsJsonOption = Annotated[bool, typer.Option("--json", help="Print the result as a JSON object.")]

PlotOption = Annotated[
    Optional[Path],
    typer.Option("--plot", help="Draw signal, best fit, residual and the posterior over depth into this PNG."),
]

NoCacheOption = Annotated[bool, typer.Option("--no-cache", help="Neither read nor write the library cache.")]

BatchSizeOption = Annotated[
    Optional[int],
    typer.Option(
        "--batch-size", help="Chains per ensemble run of the library (default 4096 on the CPU, 16384 on a GPU)."
    ),
]


@app.command()
def detect(
    signal: SignalArgument,
    scene: SceneOption = None,
    block: BlockOption = 1,
    noise: NoiseOption = None,
    depths: DepthsOption = None,
    mass_range: MassRangeOption = "0.25,4",
    mass_steps: MassStepsOption = 7,
    refine: RefineOption = 3,
    iterations: IterationsOption = 2,
    window: WindowOption = None,
    fit_a: FitAOption = False,
    a_range: ARangeOption = None,
    as_json: AsJsonOption = False,
    plot: PlotOption = None,
    no_cache: NoCacheOption = False,
    batch_size: BatchSizeOption = None,
    device: DeviceOption = None,
    set_: SetOption = None,
):
    """Locate and identify a buried impurity (class none | light | heavy, depth, mass ratio) from the
    surface grain's velocity after an impact.

    A library of candidate chains (BASE + one impurity block at every depth × log-spaced mass ratios) is simulated as one ensemble with surface traces at the signal's sample times and cached per BASE ($HERTZIAN_DETECT_CACHE, default ~/.cache/hertzian/detect); the best depths are refined by Gauss–Newton in ln μ; with --fit-a, ln μ and ln(a/a_host) are then fitted jointly at the depth found and its neighbours (grid, then Gauss–Newton). Noise: i.i.d. Gaussian; posterior with equal class odds, uniform depth and uniform ln μ priors; intervals are central 95 %. Program units (time 1.0102e-3 s, length 1e-5 m).
    """
    # the detection modules load Warp and Zarr (≈ 0.7 s): imported here, not at the top, so that the other
    # commands, which import this module to register, do not pay for them
    from hertzian.plotting.detection import plot_detection
    from hertzian.studies.detection import check_base, read_signal
    from hertzian.studies.detection import detect as run_detection

    base, mass_ratio_range, depth_range, a_ratio_range = _checked_options(
        scene, set_, mass_range, depths, fit_a, a_range, plot, batch_size, iterations
    )
    try:
        check_base(base)
        measured = read_signal(signal)
    except SceneError as err:
        fail(str(err))
    dev = resolve_device(device)
    note = candidate_events_note(base, dev)
    if note:
        typer.echo(f"note: {note}", err=True)
    try:
        result, library = run_detection(
            measured,
            base,
            block=block,
            noise=noise,
            device=dev,
            depth_range=depth_range,
            mass_ratio_range=mass_ratio_range,
            mass_steps=mass_steps,
            refine=refine,
            iterations=iterations,
            window=window,
            use_cache=not no_cache,
            batch_size=batch_size,
            fit_a=fit_a,
            a_ratio_range=a_ratio_range,
            dt_given=dt_given(scene, set_),
            say=lambda line: typer.echo(line, err=True),
        )
    except SceneError as err:
        fail(str(err))
    if result.step_choice is not None and result.step_choice.warning():
        typer.echo(f"warning: {result.step_choice.warning()}", err=True)
    if plot is not None:
        plot_detection(measured, result, library, plot)
    if as_json:
        typer.echo(json.dumps(result.to_dict(), indent=1))
    else:
        _print_detection(result, mass_ratio_range, dev)
    _warn_if_misfit(result)
    if plot is not None:
        typer.echo(f"wrote {plot}", err=True)


def _checked_options(scene, set_, mass_range, depths, fit_a, a_range, plot, batch_size, iterations):
    """``detect``'s options checked (one line and exit 2 on bad input): the BASE scene, the mass ratio range, the
    depth range (or None), the a/a_host range."""
    if scene is None:
        fail("--scene: required: the BASE scene TOML (the host chain without impurities)")
    base = load_scene_or_fail(scene, set_, None)
    mass_ratio_range = _pair("--mass-range", mass_range, ",", float)
    depth_range = _pair("--depths", depths, ":", int) if depths is not None else None
    if a_range is not None and not fit_a:
        fail(f"--a-range = {a_range!r}: only used with --fit-a")
    a_ratio_range = _pair("--a-range", a_range, ",", float) if a_range is not None else (0.25, 4.0)
    check_output_file("--plot", plot)
    if batch_size is not None and batch_size < 1:
        fail(f"--batch-size = {batch_size}: must be an integer ≥ 1")
    if iterations < 1:
        fail(f"--iterations = {iterations}: must be an integer ≥ 1")
    return base, mass_ratio_range, depth_range, a_ratio_range


def dt_given(scene: Path, set_: list[str] | None) -> bool:
    """Whether BASE's file or a --set gives integrator.dt (a loaded scene always has one: the default)."""
    with one_line_errors():
        raw = tomllib.loads(shipped_file(scene).read_text())
    return "integrator.dt" in overrides_of(set_, None) or "dt" in raw.get("integrator", {})


def _print_detection(result, mass_ratio_range: tuple[float, float], dev: str) -> None:
    """The detection as aligned lines: class, depth, mass ratio (and a/a_host), noise, what was searched, seconds."""
    p = result.class_probability
    typer.echo(f"class        {result.kind}  (p: none {p['none']:.3g}, light {p['light']:.3g}, heavy {p['heavy']:.3g})")
    if result.kind != "none":
        lo, hi = result.depth_interval
        mlo, mhi = result.mass_ratio_interval
        typer.echo(f"depth        {result.depth}  (95 %: {lo} … {hi}; block of {result.block})")
        typer.echo(f"mass ratio   {result.mass_ratio:.4g}  (95 %: {mlo:.4g} … {mhi:.4g})")
        if result.fit_a is not None:
            fa = result.fit_a
            interval = (
                f"95 %: {fa['a_ratio_interval'][0]:.4g} … {fa['a_ratio_interval'][1]:.4g}"
                if fa["a_ratio_interval"]
                else "no better than a = a_host"
            )
            typer.echo(
                f"a / a_host   {fa['a_ratio']:.4g}  ({interval}; RSS {fa['rss']:.4g}, with a = a_host "
                f"{fa['rss_a_host']:.4g})"
            )
    typer.echo(f"noise σ      {result.noise:.4g}  ({result.noise_source})")
    a, b = result.depths_searched
    low, high = mass_ratio_range
    s = result.seconds
    library_text = "cached" if result.library_from_cache else f"{s['library']:.2f} s"
    typer.echo(
        f"searched     depths {a} … {b}, mass ratio {low:g} … {high:g}, t ≤ {result.window:g}; forward dt "
        f"{result.dt:g} on {dev}; library {library_text}, refinement {s['refinement']:.2f} s, total {s['total']:.2f} s"
    )


def _warn_if_misfit(result) -> None:
    """A warning on stderr when the best fit's σ exceeds the σ before the earliest echo by MISFIT_WARNING."""
    if result.misfit_ratio is not None and result.misfit_ratio > MISFIT_WARNING:
        typer.echo(
            f"warning: the best fit leaves σ = {result.noise:.3g}, {result.misfit_ratio:.1f}× the noise before "
            "the earliest echo: the model misses part of the signal (a local minimum, an impurity outside "
            "the search, or model error); the intervals are not to be trusted",
            err=True,
        )


def candidate_events_note(base, dev: str) -> str | None:
    """One line when the candidate chains would run with event-aware steps on a GPU (BASE's
    ``integrator.events = "auto"`` where a contact can open), which cost a GPU several times plain steps (measured:
    docs/detection.md); None on a CPU or without event steps."""
    if dev.startswith("cpu"):
        return None
    # heavy (Warp): imported on use, as in the command above
    from hertzian.core.model import build_model
    from hertzian.core.solvers.calibrate import event_cost_note

    cost = event_cost_note(build_model([base], dev).features, is_cpu=False)
    return None if cost is None else f"candidate runs: {cost} in BASE"


@app.command("detect-study")
def detect_study(
    study: Annotated[Path, typer.Argument(help="Study TOML (e.g. sweeps/detect_study.toml).")],
    out: Annotated[Path, typer.Option("--out", help="JSON file to write (records and summary).")] = Path(
        "detect-study.json"
    ),
    overwrite: Annotated[bool, typer.Option("--overwrite", help="Replace an existing --out.")] = False,
    device: DeviceOption = None,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress lines on stderr.")] = False,
):
    """Accuracy study of detect: planted impurities (independent runs at half the step), seeded noise at
    given SNRs (relative to the echo peak), detection; class accuracy, depth error, interval coverage,
    confusion matrices and seconds per detection, written as JSON."""
    # heavy (Warp, Zarr): imported on use, as in ``detect``
    from hertzian.studies.detection.study import load_study, run_study, write_study

    if out.is_dir():
        fail(f"--out = {str(out)!r}: is a folder; --out names the JSON file to write")
    check_output_file("--out", out)  # a user's file: refused, --overwrite or not
    if out.exists() and not overwrite:
        fail(f"--out = {str(out)!r}: exists; choose another path or pass --overwrite")
    study = shipped_file(study)
    try:
        load_study(study)
    except SceneError as err:
        fail(str(err))
    dev = resolve_device(device)

    def progress(record: dict) -> None:
        if not quiet:
            typer.echo(
                f"{record['host']} snr {record['snr_db']:g} true {record['true_class']} d={record['true_depth']} "
                f"μ={record['true_mass_ratio']:g} → {record['class']} d={record['depth']} "
                f"μ={record['mass_ratio']:.3g} ({record['seconds']['total']:.2f} s)",
                err=True,
            )

    try:
        result = run_study(study, dev, progress=progress)
    except SceneError as err:
        fail(str(err))
    write_study({"command": command_line(), **result}, out)
    for host, per_snr in result["summary"].items():
        for snr, row in per_snr.items():
            typer.echo(
                f"{host} SNR {float(snr):g} dB: class {row['class_accuracy']:.3f}, depth ±1 "
                f"{row['depth_within_1'] if row['depth_within_1'] is None else round(row['depth_within_1'], 3)}, "
                f"μ coverage {row['mass_ratio_interval_coverage']}, "
                f"{row['seconds_per_detection_median']:.2f} s/detection"
            )
    typer.echo(f"wrote {out} ({result['meta']['wall_seconds']:.0f} s)")
