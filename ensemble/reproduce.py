"""Reproduce Sen, Manciu & Wright (1998): run every figure group's sweep, write its store, draw its figures.

``reproduce(out_dir, groups=…, quick=False)`` is what ``hertzian reproduce`` runs. Each group of
:data:`GROUPS` is one sweep file of ``sweeps/`` (run through the same planner and store writer as
``hertzian sweep``) and the figures ``hertzian plot --figure`` draws from its store; Figs. 9–10 are
the exception (:func:`run_driven`): the 10 000-grain driven column is integrated once and only the
velocity samples inside the averaging windows at the paper's times are kept.

``quick=True`` shrinks every group to a short chain and a short time (``Group.quick``: a few
hundred grains, impurities and traced grains moved to the same relative depths, durations scaled
by the pulse travel time), so the whole paper runs on a CPU in minutes. Quick figures show the
same kind of picture at a smaller size; they are a smoke test of the pipeline, not the paper's
numbers (docs/reproduction.md reports the full-size runs).

Every run is logged (``log.json`` in ``out_dir``): device, wall seconds, grain-steps per second,
the largest energy error and the status counts, and the PNGs written.
"""

from __future__ import annotations

import json
import math
import platform
import time
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable

import numpy as np

from . import analysis as an

WINDOW = an.PAPER_WINDOW
"""Averaging window of Figs. 9–10 [time units] (Fig. 9's caption)."""
LAGS = an.PERSISTENCE_LAGS
"""Each paper time's window and the seven consecutive windows after it [time units]."""
SAMPLE_EVERY = 0.01
"""Spacing of the velocity samples inside a window [time units]: a pulse moves ~1 grain in between."""
COARSE_EVERY = 2.0
"""Spacing of the coarse velocity snapshots of the driven column [time units]."""
DRIVE_DT = 1.25e-4
"""The paper's own step for Figs. 9–10 (1.265e-7 s)."""
DRIVE_CHECK_DT = 1.25e-5
"""The step of the full-size check run of Figs. 9–10 (to the first window)."""


@dataclass(frozen=True)
class Group:
    """One figure group: its sweep file, the figures drawn from its store and its ``--quick`` overrides."""

    sweep: str
    figures: tuple[str, ...]
    quick: dict[str, Any] = field(default_factory=dict)
    """Scene keys set for ``--quick`` (a short chain and time)."""


_IMPURITY_5 = [98, 99, 100, 101, 102]
GROUPS: dict[str, Group] = {
    "fig1": Group("paper_fig1.toml", ("fig1",),
                  {"chain.grains": 200, "integrator.duration": 12.0}),
    "fig1d": Group("paper_fig1d.toml", ("fig1d",),
                   {"chain.grains": 200, "integrator.duration": 8.0, "record.every": 0.25}),
    "fig2": Group("paper_fig2.toml", ("fig2",),
                  {"chain.grains": 200, "integrator.duration": 12.0}),
    "fig3": Group("paper_fig3.toml", ("fig3",),
                  {"chain.grains": 200, "integrator.duration": 12.0}),
    "fig4": Group("paper_fig4.toml", ("fig4",),
                  {"chain.grains": 300, "integrator.duration": 13.0}),
    "fig5": Group("paper_fig5.toml", ("fig5",),
                  {"chain.grains": 150, "impurities.0.grains": [73, 74, 75, 76, 77], "record.traces": [0, 15, 35, 60],
                   "integrator.duration": 12.0}),
    "fig5_single": Group("paper_fig5_single.toml", ("fig5",),
                         {"chain.grains": 150, "impurities.0.grains": [75], "record.traces": [0, 15, 35, 60],
                          "integrator.duration": 12.0}),
    "fig6": Group("paper_fig6.toml", ("fig6",),
                  {"chain.grains": 200, "integrator.duration": 2.5}),
    "depth": Group("paper_fig6_depth.toml", ("depth",),
                   {"chain.grains": 300, "integrator.duration": 5.0}),
    "fig7_8": Group("paper_fig7_8.toml", ("fig7_8",),
                    {"chain.grains": 200, "impurities.0.grains": _IMPURITY_5, "record.traces": [0, 20, 50],
                     "integrator.duration": 5.0}),
    "fig7_8_single": Group("paper_fig7_8_single.toml", ("fig7_8",),
                           {"chain.grains": 200, "impurities.0.grains": [100], "record.traces": [0, 20, 50],
                            "integrator.duration": 5.0}),
    "fig9_10": Group("paper_fig9_10.toml", ("fig9", "fig10"), {"chain.grains": 300}),
}
"""Figure group → its sweep and figures, in the paper's order."""

QUICK_DRIVE_TIMES = (2.0, 4.0)
"""``--quick`` Figs. 9–10: window times of the 300-grain column [time units]."""


def group_of(name: str) -> str:
    """The group drawing figure or group ``name`` (e.g. 'fig9' → 'fig9_10'); ValueError if none."""
    if name in GROUPS:
        return name
    for group, spec in GROUPS.items():
        if name in spec.figures:
            return group
    names = sorted(set(GROUPS) | {f for g in GROUPS.values() for f in g.figures})
    raise ValueError(f"allowed: {', '.join(names)}")


def default_sweeps_dir() -> Path:
    """The repository's ``sweeps/`` folder, installed as package data (``hertzian.sweeps``)."""
    from importlib import resources

    return Path(str(resources.files("hertzian.sweeps")))


# ---- a sweep group ---------------------------------------------------------------------------


def run_sweep_group(path: Path, overrides: dict[str, Any], out: Path, device: str) -> dict[str, Any]:
    """Run one sweep file into a store at ``out`` (as ``hertzian sweep`` does, serially); returns its log entry."""
    import zarr

    from .distributed import jobs_for, run_serial, warm_kernels
    from .planner import plan_sweep
    from .sweep import expand, load_sweep
    from .sweep_store import create_sweep_store, finalize

    definition = load_sweep(path, overrides)
    points = expand(definition)
    plan = plan_sweep(definition, points, device)
    create_sweep_store(out, definition, points.templates[0], plan, device=device, overwrite=True)
    jobs = jobs_for(out.resolve(), plan, points, plan.batches)
    warm_kernels([g.features for g in plan.groups], device)
    start = time.perf_counter()
    run_serial(jobs, device)
    session = time.perf_counter() - start
    grain_steps = sum(j.grain_steps for j in jobs)
    prov = finalize(out, session_seconds=session, session_grain_steps=grain_steps)
    status = np.asarray(zarr.open_array(store=str(out), path="status", mode="r")[...]).ravel()
    codes, counts = np.unique(status, return_counts=True)
    scene = points.scene(0)
    return {
        "points": points.point_count, "grains": scene.chain.grains, "steps": scene.step_count, "dt": scene.integrator.dt,
        "method": scene.integrator.method, "device": prov["device"], "wall_seconds": session,
        "grain_steps": grain_steps, "grain_steps_per_second": grain_steps / max(session, 1e-12),
        "energy_error_max": prov["energy_error_max"],
        "status_counts": {str(int(c)): int(k) for c, k in zip(codes, counts)},
    }


# ---- Figs. 9-10: windows of the driven column --------------------------------------------------


def drive_scenes(path: Path, grains: int, duration: float, dt: float):
    """The driven columns (τ = 10 and τ = 1) of sweeps/paper_fig9_10.toml at the given size."""
    from .sweep import load_sweep, sweep_scenes

    sweep = load_sweep(path, {"chain.grains": grains, "integrator.duration": duration, "integrator.dt": dt,
                              "record.every": duration})
    return sweep, sweep_scenes(sweep)


def run_driven(scenes, device: str, centres: np.ndarray, *, coarse_every: float) -> dict[str, Any]:
    """Integrate the driven columns, sampling velocities inside the windows centred at ``centres``."""
    import warp as wp

    from .model import build_model
    from .runner import Runner, energy_errors

    model = build_model(list(scenes), device)
    runner = Runner(model)
    recorder = runner.recorder
    dt = model.dt
    chains, grains = model.chain_count, model.grain_count
    steps_per_sample = max(1, round(SAMPLE_EVERY / dt))
    half = round(0.5 * WINDOW / dt)
    # every step at which something is read: window samples, window centres, coarse snapshots
    marks: dict[int, set] = {}
    for w, centre in enumerate(centres):
        middle = round(centre / dt)
        for s in range(middle - half, middle + half + 1, steps_per_sample):
            marks.setdefault(s, set()).add(("sample", w))
        marks.setdefault(middle, set()).add(("centre", w))
    end = max(marks)
    coarse_steps = list(range(0, end + 1, max(1, round(coarse_every / dt))))
    for c, s in enumerate(coarse_steps):
        marks.setdefault(s, set()).add(("coarse", c))

    ke_sum = np.zeros((chains, len(centres), grains))
    v_sum = np.zeros((chains, len(centres), grains))
    samples = np.zeros(len(centres), dtype=int)
    v_centre = np.zeros((chains, len(centres), grains))
    v_coarse = np.zeros((chains, len(coarse_steps), grains), dtype=np.float32)
    energy, work, times = [], [], []
    mass = np.ones(grains)

    recorder.load()
    wp.synchronize_device(model.device)
    start = time.perf_counter()
    step = 0
    for mark in sorted(marks):
        if mark > step:
            runner.advance(mark - step)
            step = mark
        recorder.check(runner.current, step)
        velocity = runner.current.x[1].numpy() / dt
        energy.append(recorder.energy_now.numpy().copy())
        work.append(recorder.work_now.numpy().copy())
        times.append(step * dt)
        for kind, index in marks[mark]:
            if kind == "sample":
                ke_sum[:, index] += an.kinetic_energy(velocity, mass)
                v_sum[:, index] += velocity
                samples[index] += 1
            elif kind == "centre":
                v_centre[:, index] = velocity
            else:
                v_coarse[:, index] = velocity
    wp.synchronize_device(model.device)
    wall = time.perf_counter() - start
    samples = np.maximum(samples, 1)
    energy_arr, work_arr = np.array(energy).T, np.array(work).T
    return {
        "ke_window": ke_sum / samples[None, :, None],
        "v_window": v_sum / samples[None, :, None],
        "v_centre": v_centre,
        "v_coarse": v_coarse,
        "coarse_t": np.array(coarse_steps) * dt,
        "energy_t": np.array(times),
        "energy": energy_arr,
        "work": work_arr,
        "energy_error": energy_errors(energy_arr, work_arr, model.injected_energy),
        "status": runner.current.status.numpy().copy(),
        "wall_seconds": wall,
        "steps": step,
        "device": str(model.device),
        "kernel": runner.solver.describe(),
        "grain_steps_per_second": chains * grains * step / max(wall, 1e-12),
    }


def write_driven(path: Path, sweep, scenes, centres: np.ndarray, result: dict, block: np.ndarray,
                 lag: np.ndarray) -> None:
    """A Zarr store readable by xarray.open_zarr and ``hertzian plot --figure fig9|fig10``."""
    import xarray as xr

    taus = np.array([s.excitation.drive_period for s in scenes])
    grains = np.arange(scenes[0].chain.grains, dtype=np.int32)
    ds = xr.Dataset(
        {
            "ke_window": (("tau", "window", "grain"), result["ke_window"],
                          {"long_name": f"kinetic energy per grain averaged over {WINDOW} time units"}),
            "v_window": (("tau", "window", "grain"), result["v_window"],
                         {"long_name": f"velocity averaged over {WINDOW} time units, + toward the bottom"}),
            "v_centre": (("tau", "window", "grain"), result["v_centre"],
                         {"long_name": "velocity at the window centre, + toward the bottom"}),
            "v": (("tau", "record", "grain"), result["v_coarse"],
                  {"long_name": "velocity snapshots (float32), + toward the bottom"}),
            "energy": (("tau", "sample"), result["energy"]),
            "work": (("tau", "sample"), result["work"]),
            "energy_error": (("tau",), result["energy_error"]),
            "status": (("tau",), result["status"].astype(np.int32)),
        },
        coords={"tau": taus, "window_t": ("window", centres), "window_block": ("window", block),
                "window_lag": ("window", lag), "t": ("record", result["coarse_t"]),
                "energy_t": ("sample", result["energy_t"]), "grain": grains},
        attrs={"scene": json.dumps(scenes[0].to_dict()), "sweep": json.dumps(sweep.to_dict()),
               "provenance": json.dumps({k: result[k] for k in ("device", "wall_seconds", "steps",
                                                                "grain_steps_per_second")}),
               "window": WINDOW, "sample_every": SAMPLE_EVERY},
    )
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", category=UserWarning)   # zarr 3: consolidated metadata has no spec yet
        ds.to_zarr(path, mode="w", consolidated=True)


def standing_wave_numbers(ke_window: np.ndarray, paper_times: np.ndarray, block: np.ndarray) -> list[list[dict]]:
    """Per chain and paper time: shape correlation and node shift of the next windows against the first;
    last entry: correlations and nodes of the block averages (long-time stability)."""
    out = []
    for chain in range(ke_window.shape[0]):
        rows = []
        for k, t0 in enumerate(paper_times):
            sw = an.standing_wave_measure(ke_window[chain, block == k])
            rows.append({"t": float(t0), "lags": LAGS.tolist(), "correlation": sw.correlation.tolist(),
                         "node_count": [int(n.size) for n in sw.nodes], "node_spacing": sw.node_spacing,
                         "node_shift": sw.node_shift.tolist()})
        # long-time stability: each paper time's block of windows averaged (12 time units, more than one
        # drive period for both τ), smoothed over 25 grains, correlated with every other block
        blocks = np.array([ke_window[chain, block == k].mean(axis=0) for k in range(len(paper_times))])
        smoothed = np.array([np.convolve(b, np.ones(25) / 25, mode="same") for b in blocks])
        rows.append({"block_average_correlation": np.corrcoef(smoothed).tolist(),
                     "block_average_nodes": [an.profile_nodes(b, smooth=25).tolist() for b in blocks]})
        out.append(rows)
    return out


def run_drive_group(path: Path, out_dir: Path, device: str, *, quick: bool, grains: int | None = None,
                    say: Callable[[str], None] = print) -> list[dict[str, Any]]:
    """Figs. 9–10: the windowed run (store ``fig9_10.zarr``) and, at full size, the dt check
    (``fig9_10_dt_check.zarr``: dt = 1.25e-5 to the first window, compared window by window)."""
    grains = grains or (GROUPS["fig9_10"].quick["chain.grains"] if quick else 10000)
    if quick and grains == GROUPS["fig9_10"].quick["chain.grains"]:
        paper_times = np.array(QUICK_DRIVE_TIMES)
    else:
        paper_times = np.round(an.drive_times(grains), 3)
    block = np.repeat(np.arange(len(paper_times)), len(LAGS))
    lag = np.tile(LAGS, len(paper_times))
    centres = paper_times[block] + lag
    duration = float(centres[-1] + WINDOW)
    sweep, scenes = drive_scenes(path, grains, duration, DRIVE_DT)
    result = run_driven(scenes, device, centres, coarse_every=0.5 if quick else COARSE_EVERY)
    store = out_dir / "fig9_10.zarr"
    write_driven(store, sweep, scenes, centres, result, block, lag)
    runs = [{
        "name": "fig9_10", "store": store.name, "points": len(scenes), "grains": grains, "dt": DRIVE_DT,
        "duration": duration, "steps": result["steps"], "taus": [s.excitation.drive_period for s in scenes],
        "device": result["device"], "kernel": result["kernel"], "wall_seconds": result["wall_seconds"],
        "grain_steps_per_second": result["grain_steps_per_second"],
        "energy_error": result["energy_error"].tolist(),
        "energy_error_max": float(np.max(result["energy_error"])),
        "status": result["status"].tolist(),
        "standing_wave": standing_wave_numbers(result["ke_window"], paper_times, block),
    }]
    say(f"fig9_10: {result['wall_seconds']:.1f} s, energy error {np.max(result['energy_error']):.2e}")
    if quick:
        return runs
    first = centres[centres <= paper_times[0]]
    _, fine_scenes = drive_scenes(path, grains, float(first[-1] + WINDOW), DRIVE_CHECK_DT)
    fine = run_driven(fine_scenes, device, first, coarse_every=float(first[-1] + WINDOW))
    write_driven(out_dir / "fig9_10_dt_check.zarr", sweep, fine_scenes, first, fine, block[:len(first)],
                 lag[:len(first)])
    coarse_ke = result["ke_window"][:, :len(first)]
    difference = np.linalg.norm(fine["ke_window"] - coarse_ke, axis=-1) / np.linalg.norm(fine["ke_window"], axis=-1)
    runs.append({
        "name": "fig9_10_dt_check", "store": "fig9_10_dt_check.zarr", "points": len(fine_scenes), "grains": grains,
        "dt": DRIVE_CHECK_DT, "duration": float(first[-1] + WINDOW), "steps": fine["steps"],
        "device": fine["device"], "kernel": fine["kernel"], "wall_seconds": fine["wall_seconds"],
        "grain_steps_per_second": fine["grain_steps_per_second"], "energy_error": fine["energy_error"].tolist(),
        "energy_error_max": float(np.max(fine["energy_error"])), "window_t": first.tolist(),
        "relative_l2_difference_of_window_ke(dt=1.25e-4 vs 1.25e-5)": difference.tolist(),
    })
    say(f"fig9_10 dt check: {fine['wall_seconds']:.1f} s, relative KE-profile difference {difference.tolist()}")
    return runs


# ---- the whole paper -------------------------------------------------------------------------------


def finite(value):
    """NaN/inf → None and NumPy scalars → Python, so the log is standard JSON."""
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(v) for v in value]
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


def reproduce(out_dir: Path, *, groups: list[str] | None = None, quick: bool = False, device: str = "cpu",
              sweeps_dir: Path | None = None, drive_grains: int | None = None,
              say: Callable[[str], None] = print) -> dict[str, Any]:
    """Run ``groups`` (default: all of GROUPS), write their stores and PNGs into ``out_dir`` and the log
    ``out_dir/log.json``; returns the log. A figure that cannot be drawn is logged with its error.
    ``drive_grains``: the driven column's length for Figs. 9–10 (default 10 000, or 300 with ``quick``;
    the paper's times are scaled by the travel time ∝ N^(5/6))."""
    import warp as wp
    import xarray as xr

    from .plot import plot_figure

    sweeps_dir = sweeps_dir or default_sweeps_dir()
    out_dir.mkdir(parents=True, exist_ok=True)
    names = groups or list(GROUPS)
    log: dict[str, Any] = {
        "command": "hertzian reproduce" + (" --quick" if quick else "") + "".join(
            f" --figure {g}" for g in (groups or [])) + (f" --drive-grains {drive_grains}" if drive_grains else "")
        + f" --device {device}",
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"), "device": device,
        "device_name": wp.get_device(device).name, "cpu_count": _cpu_count(), "platform": platform.platform(),
        "warp_version": wp.config.version, "quick": quick, "runs": [],
    }
    begin = time.perf_counter()
    failures = 0
    for name in names:
        group = GROUPS[name]
        path = sweeps_dir / group.sweep
        if name == "fig9_10":
            runs = run_drive_group(path, out_dir, device, quick=quick, grains=drive_grains, say=say)
        else:
            store = out_dir / f"{name}.zarr"
            entry = run_sweep_group(path, group.quick if quick else {}, store, device)
            runs = [{"name": name, "sweep": group.sweep, "store": store.name, **entry}]
            say(f"{name}: {entry['points']} points x {entry['grains']} grains, {entry['wall_seconds']:.1f} s, "
                f"{entry['grain_steps_per_second']:.3g} grain-steps/s, energy error {entry['energy_error_max']:.2e}")
        figures = {}
        with xr.open_zarr(out_dir / runs[0]["store"]) as dataset:
            for figure in group.figures:
                png = out_dir / (f"{name}.png" if len(group.figures) == 1 else f"{figure}.png")
                try:
                    plot_figure(dataset, figure, png)
                    figures[figure] = png.name
                except Exception as err:  # noqa: BLE001  (logged; the other groups still run)
                    failures += 1
                    figures[figure] = f"failed: {type(err).__name__}: {err}"
                    say(f"{name}: figure {figure} failed: {err}")
        runs[0]["figures"] = figures
        log["runs"].extend(runs)
    log["total_seconds"] = time.perf_counter() - begin
    log["figure_failures"] = failures
    (out_dir / "log.json").write_text(json.dumps(finite(log), indent=1))
    return log


def _cpu_count() -> int:
    import os

    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
