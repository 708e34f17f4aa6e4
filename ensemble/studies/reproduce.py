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

import contextlib
import json
import math
import platform
import time
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable

import numpy as np
from hertzian.studies import analysis as an
from hertzian.sweeping.pipeline import prepare_sweep, run_sweep

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
    "fig1": Group("paper_fig1.toml", ("fig1",), {"chain.grains": 200, "integrator.duration": 12.0}),
    "fig1d": Group(
        "paper_fig1d.toml", ("fig1d",), {"chain.grains": 200, "integrator.duration": 8.0, "record.every": 0.25}
    ),
    "fig2": Group("paper_fig2.toml", ("fig2",), {"chain.grains": 200, "integrator.duration": 12.0}),
    "fig3": Group("paper_fig3.toml", ("fig3",), {"chain.grains": 200, "integrator.duration": 12.0}),
    "fig3_load": Group("paper_fig3_load.toml", ("fig3",), {"chain.grains": 200, "integrator.duration": 12.0}),
    "fig4": Group("paper_fig4.toml", ("fig4",), {"chain.grains": 300, "integrator.duration": 13.0}),
    "fig5": Group(
        "paper_fig5.toml",
        ("fig5",),
        {
            "chain.grains": 150,
            "impurities.0.grains": [73, 74, 75, 76, 77],
            "record.traces": [0, 15, 35, 60],
            "integrator.duration": 12.0,
        },
    ),
    "fig5_single": Group(
        "paper_fig5_single.toml",
        ("fig5",),
        {
            "chain.grains": 150,
            "impurities.0.grains": [75],
            "record.traces": [0, 15, 35, 60],
            "integrator.duration": 12.0,
        },
    ),
    "fig5_modes": Group(
        "paper_fig5_modes.toml",
        ("modes",),
        {
            "chain.grains": 150,
            "impurities.0.grains": [75],
            "record.traces": [74, 75, 76, 95],
            "integrator.duration": 16.0,
        },
    ),
    "fig6": Group("paper_fig6.toml", ("fig6",), {"chain.grains": 200, "integrator.duration": 2.5}),
    "depth": Group("paper_fig6_depth.toml", ("depth",), {"chain.grains": 300, "integrator.duration": 5.0}),
    "fig7_8": Group(
        "paper_fig7_8.toml",
        ("fig7_8",),
        {
            "chain.grains": 200,
            "impurities.0.grains": _IMPURITY_5,
            "record.traces": [0, 20, 50],
            "integrator.duration": 5.0,
        },
    ),
    "fig7_8_single": Group(
        "paper_fig7_8_single.toml",
        ("fig7_8",),
        {"chain.grains": 200, "impurities.0.grains": [100], "record.traces": [0, 20, 50], "integrator.duration": 5.0},
    ),
    "fig7_8_slow": Group(
        "paper_fig7_8_slow.toml",
        ("fig7_8",),
        {
            "chain.grains": 200,
            "impurities.0.grains": _IMPURITY_5,
            "record.traces": [0, 20, 50],
            "integrator.duration": 6.0,
        },
    ),
    "finite_g": Group(
        "paper_finite_g.toml",
        (),
        {
            "chain.grains": 300,
            "impurities.0.grains": [148, 149, 150, 151, 152],
            "record.traces": [0, 30, 75],
            "integrator.duration": 24.0,
        },
    ),
    "fig9_10": Group("paper_fig9_10.toml", ("fig9", "fig10"), {"chain.grains": 300}),
    "sec6_lag": Group("paper_fig9_10.toml", ("sec6_lag",), {"chain.grains": 300}),
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


def run_sweep_group(
    path: Path, overrides: dict[str, Any], out: Path, device: str, kernel: str | None = "auto"
) -> dict[str, Any]:
    """Run one sweep file into a store at ``out`` through the sweep pipeline (as ``hertzian sweep --kernel KERNEL
    --overwrite`` does, serially); returns its log entry, with ``seconds``: setup (load, plan, kernel loads),
    integrate (the batches, calibration and the store's creation included), finalize. ``kernel=None``:
    ``group_kernel``'s choice for the sweep's scene on ``device``."""
    options = dict(device=device, overwrite=True, overrides=overrides, notify=lambda line: None)
    prepared = prepare_sweep(path, out, kernel="auto" if kernel is None else kernel, **options)
    scene = prepared.points.scene(0)
    if kernel is None:
        kernel = group_kernel(scene.integrator.events, prepared.device)
        prepared.kernel = kernel
    done = run_sweep(prepared)
    t = done["seconds"]
    setup = sum(t.get(k, 0.0) for k in ("load", "expand", "plan", "jobs", "warm_kernels"))
    return {
        "points": done["points"],
        "grains": scene.chain.grains,
        "steps": scene.step_count,
        "dt": scene.integrator.dt,
        "method": scene.integrator.method,
        "events": scene.integrator.events,
        "device": done["device"],
        "wall_seconds": t["batches"],
        "grain_steps": done["grain_steps"],
        "grain_steps_per_second": done["grain_steps_per_second"],
        "energy_error_max": done["energy_error_max"],
        "status_counts": done["status_counts"],
        "kernel_choice": kernel,
        "kernel": done["kernel"],
        "seconds": {"setup": setup, "integrate": t["batches"], "finalize": t["finalize"]},
    }


def group_kernel(events: str, device: str) -> str:
    """The solver choice of a figure group whose scene takes ``integrator.events = events``: on a GPU "fused" for
    plain Gear steps (the fused kernels, in the shape ``hertzian tune`` chose, else the shipped rule's), else "auto"
    (event-aware steps cost the fused kernels 1.7–11× on a GPU where contacts keep opening, docs/stability.md
    §6c). On a GPU the two choose alike; "fused" also keeps the CPU's chain kernel for the short groups."""
    import warp as wp

    return "fused" if events == "off" and not wp.get_device(device).is_cpu else "auto"


# ---- Figs. 9-10: windows of the driven column --------------------------------------------------


def drive_scenes(path: Path, grains: int, duration: float, dt: float, events: str | None = None):
    """The driven columns (τ = 10 and τ = 1) of sweeps/paper_fig9_10.toml at the given size."""
    from hertzian.sweeping.spec import load_sweep, sweep_scenes

    sweep = load_sweep(
        path,
        {
            "chain.grains": grains,
            "integrator.duration": duration,
            "integrator.dt": dt,
            "record.every": duration,
            **({"integrator.events": events} if events else {}),
        },
    )
    return sweep, sweep_scenes(sweep)


def read_marks(centres: np.ndarray, dt: float, coarse_every: float) -> tuple[dict[int, set], list[int]]:
    """The steps at which ``run_driven`` reads the state, each with what it reads there: ("sample", w) every
    SAMPLE_EVERY inside window w (WINDOW wide, centred at ``centres[w]``), ("centre", w) at its centre, and
    ("coarse", k) every ``coarse_every`` from t = 0 to the last window's end; and the coarse steps."""
    steps_per_sample = max(1, round(SAMPLE_EVERY / dt))
    half = round(0.5 * WINDOW / dt)
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
    return marks, coarse_steps


def run_driven(scenes, device: str, centres: np.ndarray, *, coarse_every: float) -> dict[str, Any]:
    """Integrate the driven columns, sampling velocities inside the windows centred at ``centres``.

    Everything read along the way stays on the device until the end (kernels/windows.py): per window the
    sums of ½ m v² and v over its samples, the velocities at the window centres and at the coarse
    snapshots, and energy and work at every step where something is read. The host only launches, so the
    GPU never waits for it."""
    import warp as wp
    from hertzian.core.model import build_model
    from hertzian.core.runner import Runner, energy_errors
    from hertzian.kernels.windows import keep_chain_values, window_kernels

    model = build_model(list(scenes), device)
    runner = Runner(model)
    recorder = runner.recorder
    dt = model.dt
    chains, grains = model.chain_count, model.grain_count
    marks, coarse_steps = read_marks(centres, dt, coarse_every)
    order = sorted(marks)

    dev = model.device
    add_sample, snapshot64, snapshot32 = window_kernels(model.features.precision)
    ke_sum = wp.zeros((chains, len(centres), grains), dtype=wp.float64, device=dev)
    v_sum = wp.zeros((chains, len(centres), grains), dtype=wp.float64, device=dev)
    v_centre = wp.zeros((chains, len(centres), grains), dtype=wp.float64, device=dev)
    v_coarse = wp.zeros((chains, len(coarse_steps), grains), dtype=wp.float32, device=dev)
    energy = wp.zeros((len(order), chains), dtype=wp.float64, device=dev)
    work = wp.zeros((len(order), chains), dtype=wp.float64, device=dev)
    samples = np.zeros(len(centres), dtype=int)
    hetero = int(model.features.heterogeneous)
    wp_dt = wp.float64(dt)
    for kernel in (add_sample, snapshot64, snapshot32, keep_chain_values):
        wp.load_module(kernel.module, device=dev)

    recorder.load()
    wp.synchronize_device(dev)
    start = time.perf_counter()
    step = 0
    for row, mark in enumerate(order):
        if mark > step:
            runner.advance(mark - step)
            step = mark
        # t = 0 as it is, not in gear4's steady-state form (the energy every later one is compared with)
        with model.exact_start(runner.current) if step == 0 else contextlib.nullcontext():
            x = runner.current.x
            recorder.check(runner.current, step)
            wp.launch(keep_chain_values, dim=chains, inputs=[recorder.energy_now, row], outputs=[energy], device=dev)
            wp.launch(keep_chain_values, dim=chains, inputs=[recorder.work_now, row], outputs=[work], device=dev)
            for kind, index in sorted(marks[mark]):
                if kind == "sample":
                    wp.launch(
                        add_sample,
                        dim=(chains, grains),
                        inputs=[x, model.inverse_mass, hetero, wp_dt, index],
                        outputs=[ke_sum, v_sum],
                        device=dev,
                    )
                    samples[index] += 1
                elif kind == "centre":
                    wp.launch(
                        snapshot64, dim=(chains, grains), inputs=[x, wp_dt, index], outputs=[v_centre], device=dev
                    )
                else:
                    wp.launch(
                        snapshot32, dim=(chains, grains), inputs=[x, wp_dt, index], outputs=[v_coarse], device=dev
                    )
    wp.synchronize_device(dev)
    wall = time.perf_counter() - start
    samples = np.maximum(samples, 1)
    energy_arr, work_arr = energy.numpy().T, work.numpy().T
    return {
        "ke_window": ke_sum.numpy() / samples[None, :, None],
        "v_window": v_sum.numpy() / samples[None, :, None],
        "v_centre": v_centre.numpy(),
        "v_coarse": v_coarse.numpy(),
        "coarse_t": np.array(coarse_steps) * dt,
        "energy_t": np.array(order) * dt,
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


def write_dataset(ds, path: Path) -> None:
    """Write an xarray Dataset as a Zarr store at ``path`` (replacing one there) with consolidated metadata."""
    from hertzian.sweeping.store_format import consolidate

    ds.to_zarr(path, mode="w", consolidated=False)
    consolidate(path)


def driven_entry(name: str, scenes, result: dict[str, Any], *, grains: int, dt: float, duration: float, **extra):
    """The log entry of one run of the driven columns (``run_driven``'s ``result``): size, steps, device, kernel,
    wall seconds, energy error and status per chain, then ``extra``."""
    return {
        "name": name,
        "points": len(scenes),
        "grains": grains,
        "dt": dt,
        "duration": duration,
        "steps": result["steps"],
        "taus": [s.excitation.drive_period for s in scenes],
        "device": result["device"],
        "kernel": result["kernel"],
        "wall_seconds": result["wall_seconds"],
        "grain_steps_per_second": result["grain_steps_per_second"],
        "energy_error": result["energy_error"].tolist(),
        "energy_error_max": float(np.max(result["energy_error"])),
        "status": result["status"].tolist(),
        **extra,
    }


def write_driven(
    path: Path, sweep, scenes, centres: np.ndarray, result: dict, block: np.ndarray, lag: np.ndarray
) -> None:
    """A Zarr store readable by xarray.open_zarr and ``hertzian plot --figure fig9|fig10``."""
    import xarray as xr

    taus = np.array([s.excitation.drive_period for s in scenes])
    grains = np.arange(scenes[0].chain.grains, dtype=np.int32)
    ds = xr.Dataset(
        {
            "ke_window": (
                ("tau", "window", "grain"),
                result["ke_window"],
                {"long_name": f"kinetic energy per grain averaged over {WINDOW} time units"},
            ),
            "v_window": (
                ("tau", "window", "grain"),
                result["v_window"],
                {"long_name": f"velocity averaged over {WINDOW} time units, + toward the bottom"},
            ),
            "v_centre": (
                ("tau", "window", "grain"),
                result["v_centre"],
                {"long_name": "velocity at the window centre, + toward the bottom"},
            ),
            "v": (
                ("tau", "record", "grain"),
                result["v_coarse"],
                {"long_name": "velocity snapshots (float32), + toward the bottom"},
            ),
            "energy": (("tau", "sample"), result["energy"]),
            "work": (("tau", "sample"), result["work"]),
            "energy_error": (("tau",), result["energy_error"]),
            "status": (("tau",), result["status"].astype(np.int32)),
        },
        coords={
            "tau": taus,
            "window_t": ("window", centres),
            "window_block": ("window", block),
            "window_lag": ("window", lag),
            "t": ("record", result["coarse_t"]),
            "energy_t": ("sample", result["energy_t"]),
            "grain": grains,
        },
        attrs={
            "scene": json.dumps(scenes[0].to_dict()),
            "sweep": json.dumps(sweep.to_dict()),
            "provenance": json.dumps(
                {k: result[k] for k in ("device", "wall_seconds", "steps", "grain_steps_per_second")}
            ),
            "window": WINDOW,
            "sample_every": SAMPLE_EVERY,
        },
    )
    write_dataset(ds, path)


def standing_wave_numbers(ke_window: np.ndarray, paper_times: np.ndarray, block: np.ndarray) -> list[list[dict]]:
    """Per chain and paper time: shape correlation and node shift of the next windows against the first;
    last entry: correlations and nodes of the block averages (long-time stability)."""
    out = []
    for chain in range(ke_window.shape[0]):
        rows = []
        for k, t0 in enumerate(paper_times):
            sw = an.standing_wave_measure(ke_window[chain, block == k])
            rows.append(
                {
                    "t": float(t0),
                    "lags": LAGS.tolist(),
                    "correlation": sw.correlation.tolist(),
                    "node_count": [int(n.size) for n in sw.nodes],
                    "node_spacing": sw.node_spacing,
                    "node_shift": sw.node_shift.tolist(),
                }
            )
        # long-time stability: each paper time's block of windows averaged (12 time units, more than one
        # drive period for both τ), smoothed over 25 grains, correlated with every other block
        blocks = np.array([ke_window[chain, block == k].mean(axis=0) for k in range(len(paper_times))])
        smoothed = np.array([np.convolve(b, np.ones(25) / 25, mode="same") for b in blocks])
        rows.append(
            {
                "block_average_correlation": np.corrcoef(smoothed).tolist(),
                "block_average_nodes": [an.profile_nodes(b, smooth=25).tolist() for b in blocks],
            }
        )
        out.append(rows)
    return out


@dataclass(frozen=True)
class DriveJob:
    """What a driven-column group (``run_drive_group``, ``run_lag_group``) runs: its sweep file, output folder,
    device, size (``grains``: None = 10 000, or the group's ``--quick`` size), integrator.events, progress lines."""

    path: Path
    out_dir: Path
    device: str
    quick: bool = False
    grains: int | None = None
    events: str | None = None
    say: Callable[[str], None] = print

    def size(self, group: str) -> int:
        """The column's grains for ``group``."""
        return self.grains or (GROUPS[group].quick["chain.grains"] if self.quick else 10000)


def run_drive_group(job: DriveJob) -> list[dict[str, Any]]:
    """Figs. 9–10: the windowed run (store ``fig9_10.zarr``) and, at full size, the dt check
    (``fig9_10_dt_check.zarr``: dt = 1.25e-5 to the first window, compared window by window)."""
    grains = job.size("fig9_10")
    if job.quick and grains == GROUPS["fig9_10"].quick["chain.grains"]:
        paper_times = np.array(QUICK_DRIVE_TIMES)
    else:
        paper_times = np.round(an.drive_times(grains), 3)
    block = np.repeat(np.arange(len(paper_times)), len(LAGS))
    lag = np.tile(LAGS, len(paper_times))
    centres = paper_times[block] + lag
    duration = float(centres[-1] + WINDOW)
    clock = time.perf_counter()
    sweep, scenes = drive_scenes(job.path, grains, duration, DRIVE_DT, job.events)
    result = run_driven(scenes, job.device, centres, coarse_every=0.5 if job.quick else COARSE_EVERY)
    store = job.out_dir / "fig9_10.zarr"
    write = time.perf_counter()
    write_driven(store, sweep, scenes, centres, result, block, lag)
    seconds = {
        "integrate": result["wall_seconds"],
        "setup": write - clock - result["wall_seconds"],
        "store": time.perf_counter() - write,
    }
    runs = [
        driven_entry(
            "fig9_10",
            scenes,
            result,
            grains=grains,
            dt=DRIVE_DT,
            duration=duration,
            store=store.name,
            standing_wave=standing_wave_numbers(result["ke_window"], paper_times, block),
            seconds=seconds,
        )
    ]
    job.say(f"fig9_10: {result['wall_seconds']:.1f} s, energy error {np.max(result['energy_error']):.2e}")
    if job.quick:
        return runs
    first = centres[centres <= paper_times[0]]
    clock = time.perf_counter()
    _, fine_scenes = drive_scenes(job.path, grains, float(first[-1] + WINDOW), DRIVE_CHECK_DT, job.events)
    fine = run_driven(fine_scenes, job.device, first, coarse_every=float(first[-1] + WINDOW))
    write = time.perf_counter()
    write_driven(
        job.out_dir / "fig9_10_dt_check.zarr", sweep, fine_scenes, first, fine, block[: len(first)], lag[: len(first)]
    )
    fine_seconds = {
        "integrate": fine["wall_seconds"],
        "setup": write - clock - fine["wall_seconds"],
        "store": time.perf_counter() - write,
    }
    coarse_ke = result["ke_window"][:, : len(first)]
    difference = np.linalg.norm(fine["ke_window"] - coarse_ke, axis=-1) / np.linalg.norm(fine["ke_window"], axis=-1)
    runs.append(
        driven_entry(
            "fig9_10_dt_check",
            fine_scenes,
            fine,
            grains=grains,
            dt=DRIVE_CHECK_DT,
            duration=float(first[-1] + WINDOW),
            store="fig9_10_dt_check.zarr",
            window_t=first.tolist(),
            **{"relative_l2_difference_of_window_ke(dt=1.25e-4 vs 1.25e-5)": difference.tolist()},
            seconds=fine_seconds,
        )
    )
    job.say(f"fig9_10 dt check: {fine['wall_seconds']:.1f} s, relative KE-profile difference {difference.tolist()}")
    return runs


LAG_TIMES = slice(3, None)
"""Paper times whose patterns the lag study follows: t = 276 and 492 (panels (d), (e), the "standing-wave-like
patterns"), scaled by the column's travel time."""


def lag_correlations(result: dict[str, Any], t0s: np.ndarray, lags: np.ndarray) -> dict[str, Any]:
    """Shape correlation (:func:`analysis.profile_correlation`, 5-grain smoothing, the driven grain left out)
    of each profile at t0 + lag with the one at t0, per chain and t0: instantaneous (the velocity at that
    instant, and ½ m v² with m = 1) and averaged over WINDOW (the paper's window, centred there)."""
    kinds = {
        ("instantaneous", "ke"): an.kinetic_energy(result["v_centre"]),
        ("instantaneous", "v"): result["v_centre"],
        ("averaged", "ke"): result["ke_window"],
        ("averaged", "v"): result["v_window"],
    }
    out: dict[str, Any] = {}
    for (kind, quantity), profiles in kinds.items():
        blocks = profiles[:, :, 1:].reshape(profiles.shape[0], len(t0s), len(lags), -1)
        out[f"{kind}_{quantity}"] = [[an.profile_correlation(b).tolist() for b in chain] for chain in blocks]
    return out


def run_lag_group(job: DriveJob) -> list[dict[str, Any]]:
    """Sec. VI at the paper's own timescale: the driven columns of Figs. 9–10, profiles every SAMPLE_EVERY
    (80 steps) from t0 to t0 + WINDOW (12 000 steps) at the late paper times, instantaneous and WINDOW-averaged,
    each correlated with the one at t0 (:func:`lag_correlations`); at DRIVE_DT and DRIVE_DT/2 (the chaotic-drive
    rule: what differs between the two is a statistic, not a pattern). Writes no store: the numbers are the
    log's, ``hertzian plot LOG.json --figure sec6_lag`` draws them."""
    grains = job.size("sec6_lag")
    t0s = np.round(an.drive_times(grains)[LAG_TIMES], 2)
    lags = np.round(np.arange(0.0, WINDOW + 1e-9, SAMPLE_EVERY), 6)
    centres = (t0s[:, None] + lags[None, :]).ravel()
    duration = float(centres[-1] + WINDOW)
    runs = []
    for dt in (DRIVE_DT, 0.5 * DRIVE_DT):
        sweep, scenes = drive_scenes(job.path, grains, duration, dt, job.events)
        result = run_driven(scenes, job.device, centres, coarse_every=duration)
        runs.append(
            driven_entry(
                "sec6_lag" if dt == DRIVE_DT else "sec6_lag_dt_check",
                scenes,
                result,
                grains=grains,
                dt=dt,
                duration=duration,
                store=None,
                amplitude=scenes[0].excitation.drive_amplitude,
                t0=t0s.tolist(),
                lag=lags.tolist(),
                lag_steps_at_paper_dt=np.rint(lags / DRIVE_DT).astype(int).tolist(),
                correlation=lag_correlations(result, t0s, lags),
            )
        )
        job.say(
            f"sec6_lag dt = {dt:g}: {result['wall_seconds']:.1f} s, energy error {np.max(result['energy_error']):.2e}"
        )
    runs[0]["store"] = "sec6_lag.zarr"
    write_lag_store(job.out_dir / "sec6_lag.zarr", runs)
    return runs


def write_lag_store(path: Path, runs: list[dict[str, Any]]) -> None:
    """The lag correlations of ``run_lag_group`` as a Zarr store (dims dt, tau, t0, lag; one variable per
    profile kind) for ``hertzian plot --figure sec6_lag``."""
    import xarray as xr

    first = runs[0]
    dims = ("dt", "tau", "t0", "lag")
    ds = xr.Dataset(
        {name: (dims, np.array([run["correlation"][name] for run in runs])) for name in first["correlation"]},
        coords={"dt": [run["dt"] for run in runs], "tau": first["taus"], "t0": first["t0"], "lag": first["lag"]},
        attrs={"grains": first["grains"], "window": WINDOW, "amplitude": first["amplitude"]},
    )
    ds["energy_error"] = (("dt", "tau"), np.array([run["energy_error"] for run in runs]))
    write_dataset(ds, path)


DRIVEN_GROUPS: dict[str, Callable[[DriveJob], list[dict[str, Any]]]] = {
    "fig9_10": run_drive_group,
    "sec6_lag": run_lag_group,
}
"""The groups that integrate the driven columns themselves (``run_driven``) instead of through a sweep."""

# ---- measurements behind docs/reproduction.md ------------------------------------------------------

ECHO_FRACTIONS = (0.05, 0.1, 0.2, 0.3, 0.4, 0.5)
"""Thresholds (fraction of the largest |echo|) at which the echo's leading sign is read."""
TAIL_TIMES = an.PAPER_TAIL_TIMES
"""Fig. 3: times [time units] of the tail fits per l0."""


def _first_lobes(ds, grain: int, after: float, until: float, reference=None) -> dict[str, Any]:
    """Sign and relative height of each echo's first lobe at a traced grain (light/heavy × contact)."""
    light, heavy, clean = an.impurity_points(ds)
    column = int(np.flatnonzero(ds.traced_grain.values == grain)[0])
    if reference is None:
        reference = ds.trace_v.isel(impurity_mass=clean, contact=0).values[:, column]
    out = {}
    for name, index in (("light", light), ("heavy", heavy)):
        for rule in [str(c) for c in ds.contact.values]:
            out[f"{name}/{rule}"] = list(
                an.first_lobe(
                    ds.trace_t.values,
                    ds.trace_v.isel(impurity_mass=index).sel(contact=rule).values[:, column],
                    reference,
                    after=after,
                    until=until,
                )
            )
    return out


def _echo_measurements(ds) -> dict[str, Any]:
    """Per traced grain: the echo table at every threshold, and the light/heavy contrast."""
    out: dict[str, Any] = {}
    for grain in ds.traced_grain.values:
        grain = int(grain)
        tables = {f: an.echo_table(ds, traced=grain, fraction=f) for f in ECHO_FRACTIONS}
        after, until = an.echo_window(ds, grain)
        out[f"grain {grain}"] = {
            "window": [after, until],
            "leading_sign_by_threshold": {
                key: {str(f): tables[f][key].leading_sign for f in ECHO_FRACTIONS} for key in tables[0.2]
            },
            "arrival_by_threshold": {
                key: {str(f): tables[f][key].arrival_time for f in ECHO_FRACTIONS} for key in tables[0.2]
            },
            "amplitude": {key: b.amplitude for key, b in tables[0.2].items()},
            "peak_sign": {key: b.peak_sign for key, b in tables[0.2].items()},
            "peak_time": {key: b.peak_time for key, b in tables[0.2].items()},
            "light_heavy_contrast": an.contrast_table(ds, traced=grain),
            "first_lobe (sign, height / largest)": _first_lobes(ds, grain, after, until),
        }
    return out


def _profile_measurements(ds) -> dict[str, Any]:
    """Fig. 5's caption, per contact rule: reflected profiles (light vs heavy), the block's compressions,
    and whether the reflected tail is exponential."""
    light, heavy, clean = an.impurity_points(ds)
    t = ds.t.values
    block = an.impurity_grains(ds)
    depth = float(np.mean(block))
    l0 = float(json.loads(ds.attrs["scene"])["chain"].get("l0", 0.0))
    clean_v = ds.v.isel(impurity_mass=clean, contact=0).values
    speed = an.pulse_speed(t, an.head_positions(clean_v), first_grain=20, last_grain=depth - 20).slope
    t_hit = depth / speed
    record = int(np.argmin(np.abs(t - 1.8 * t_hit)))
    out: dict[str, Any] = {"t_reflected": float(t[record]), "speed": speed}
    contacts = slice(min(block) - 1, max(block) + 1)  # contacts (i, i+1) touching the block
    clean_u = ds.u.isel(impurity_mass=clean, contact=0).values
    clean_max = float(np.max(an.overlaps(clean_u, l0)[:, contacts] - l0))
    for rule in [str(c) for c in ds.contact.values]:
        u_light = ds.u.isel(impurity_mass=light).sel(contact=rule).values
        u_heavy = ds.u.isel(impurity_mass=heavy).sel(contact=rule).values
        front = slice(0, int(depth) - 10)
        pl, ph = -u_light[record, front], -u_heavy[record, front]
        # best shift of the heavy profile onto the light one (the arrival difference), then what is left
        shifts = range(-30, 31)
        left = [np.linalg.norm(pl[40:-40] - np.roll(ph, s)[40:-40]) for s in shifts]
        best = int(np.argmin(left))
        entry = {
            "profile_difference": float(np.linalg.norm(pl - ph) / np.linalg.norm(ph)),
            "profile_difference_after_shift": (
                float(left[best] / np.linalg.norm(ph[40:-40])) if ph[40:-40].any() else math.nan
            ),  # NaN: chain too short for the shifts
            "shift_grains": int(list(shifts)[best]),
            "block_dynamic_overlap_max": {
                "light": float(np.max(an.overlaps(u_light, l0)[:, contacts] - l0)),
                "heavy": float(np.max(an.overlaps(u_heavy, l0)[:, contacts] - l0)),
                "clean": clean_max,
            },
        }
        tails = {}
        for name, u in (("light", u_light), ("heavy", u_heavy)):
            reflected = -u[record, front]  # the reflected pulse moves toward the surface
            head = float(np.argmax(reflected))
            fit = an.tail_decay(reflected[::-1], reflected.size - 1 - head)  # "behind" = deeper
            tails[name] = {
                "head": head,
                "decay_length": fit.decay_length,
                "r_squared": fit.r_squared,
                "points": fit.points,
            }
        entry["reflected_tail"] = tails
        out[rule] = entry
    return out


def _mode_measurements(ds) -> dict[str, Any]:
    """Sec. IV: does a light impurity ring after the pulse has passed? The impurity site's velocity against
    the clean chain's same grain, and linear theory of the precompressed chain (normal modes)."""
    scene = json.loads(ds.attrs["scene"])
    a = float(scene["chain"].get("a", 5657.0))
    l0 = float(scene["chain"]["l0"])
    n = int(ds.sizes["grain"])
    site = an.impurity_grains(ds)[0]
    column = int(np.flatnonzero(ds.traced_grain.values == site)[0])
    tt = ds.trace_t.values
    masses, stiffnesses = ds.impurity_mass.values, ds.impurity_a.values
    clean = int(np.flatnonzero(masses == 1.0)[0])
    v_clean = ds.trace_v.isel(impurity_mass=clean).values[:, column]
    arrival = float(tt[np.flatnonzero(np.abs(v_clean) >= 0.5 * np.max(np.abs(v_clean)))[0]])
    peak = float(np.max(np.abs(v_clean)))
    load = 2.5 * a * l0**1.5
    out: dict[str, Any] = {"site": site, "arrival": arrival, "clean_peak_velocity": peak}
    windows = [(arrival + 5.0 + 10.0 * k, arrival + 15.0 + 10.0 * k) for k in range(4)]
    windows = [w for w in windows if w[1] <= tt[-1] + 1e-9]
    out["windows"] = windows
    band_edge = None
    for k, (mass, stiffness) in enumerate(zip(masses, stiffnesses)):
        v = ds.trace_v.isel(impurity_mass=k).values[:, column]
        rms = [float(np.sqrt(np.mean(v[(tt >= lo) & (tt < hi)] ** 2)) / peak) for lo, hi in windows]
        late = tt >= arrival + 5.0
        freq, power = an.power_spectrum(tt[late], v[late])
        m = np.ones(n)
        m[site] = mass
        ac = np.full(n + 1, a)
        ac[site] = ac[site + 1] = 2 * stiffness * a / (stiffness + a)
        omega, shapes = an.linear_chain_modes(m, an.hertz_stiffness(ac, load))
        ipr = np.sum(shapes**4, axis=0)
        if mass == 1.0:
            band_edge = float(omega[-1] / (2 * np.pi))
        out[f"m={mass:g}"] = {
            "rms_over_clean_peak": rms,
            "spectral_peak_frequency": float(freq[np.argmax(power[1:]) + 1]),
            "linear_band_edge_frequency": float(omega[-1] / (2 * np.pi)),
            "linear_largest_mode_localisation": float(np.max(ipr)),
            "linear_most_localised_mode_frequency": float(omega[np.argmax(ipr)] / (2 * np.pi)),
            "linear_site_weight_of_top_mode": float(shapes[site, -1] ** 2),
            "_spectrum": (freq, power),
        }
    for key in [k for k in out if k.startswith("m=")]:
        freq, power = out[key].pop("_spectrum")
        out[key]["power_fraction_above_band_edge"] = float(power[freq > band_edge].sum() / power.sum())
    return out


def _pulse_measurements(ds, name: str) -> dict[str, Any]:
    """Figs. 1–3: pulse speed, the overlap behind the front, and (Fig. 3) the tail fits."""
    scene = json.loads(ds.attrs["scene"])
    t = ds.t.values
    n = int(ds.sizes["grain"])
    out: dict[str, Any] = {}
    dim = "l0" if name.startswith("fig3") else "v_imp"
    for k in range(ds.sizes[dim]):
        point = ds.isel({dim: k})
        l0 = float(point.l0) if "l0" in point.variables and point.l0.size == 1 else float(scene["chain"]["l0"])
        v_imp = (
            float(point.v_imp)
            if "v_imp" in point.variables and point.v_imp.size == 1
            else float(scene["excitation"]["impact"])
        )
        u, v = point.u.values, point.v.values
        heads = an.head_positions(v)
        fit = an.pulse_speed(t, heads, first_grain=100, last_grain=800)
        entry: dict[str, Any] = {"l0": l0, "v_imp": v_imp, "speed": fit.slope, "speed_error": fit.slope_error}
        beyond = np.flatnonzero(heads > 0.9 * n)  # before the head first reaches 0.9 of the chain
        stop = beyond[0] if beyond.size else len(t)
        flight = np.flatnonzero(heads[:stop] > 0.1 * n)
        ratios = [an.overlap_behind_head(u[r], heads[r], l0=l0) for r in flight]
        entry["overlap_behind_head_over_head"] = {
            "max": float(np.nanmax(ratios)),
            "min": float(np.nanmin(ratios)),
            "t_range": [float(t[flight[0]]), float(t[flight[-1]])],
        }
        if name.startswith("fig3"):
            fits = []
            load = scene["boundary"].get("surface") == "load"
            for time in TAIL_TIMES.get(l0, ()):
                r = int(np.argmin(np.abs(t - time)))
                level = an.rear_level(u[r]) if load else 0.0  # a constant-force surface shifts the rear
                tail = an.tail_decay(u[r], heads[r], baseline=level)
                raw = an.tail_decay(u[r], heads[r])
                fits.append(
                    {
                        "t": float(t[r]),
                        "head": float(heads[r]),
                        "baseline": level,
                        "decay_length": tail.decay_length,
                        "r_squared": tail.r_squared,
                        "decay_over_ct": tail.decay_length / (fit.slope * t[r]),
                        "decay_length_without_baseline": raw.decay_length,
                        "r_squared_without_baseline": raw.r_squared,
                    }
                )
            growth = an.fit_power_law([f["t"] for f in fits], [f["decay_length"] for f in fits])
            entry["tail"] = fits
            entry["decay_length_exponent"] = [growth.exponent, growth.exponent_error]
        out[f"{dim}={float(point[dim]):g}"] = entry
    return out


def _speed_measurements(ds) -> dict[str, Any]:
    """Fig. 1(d): c per (l0, v_imp), α per l0 and lumped (all points; v_imp ≥ 1e-2 only)."""
    c, err = an.speeds_table(ds)
    v_imp, l0s = ds.v_imp.values, ds.l0.values
    out: dict[str, Any] = {
        "v_imp": v_imp.tolist(),
        "l0": l0s.tolist(),
        "speed": c.tolist(),
        "speed_error": err.tolist(),
        "alpha": {},
    }
    for i, l0 in enumerate(l0s):
        fit = an.speed_exponent(v_imp, c[i])
        out["alpha"][f"l0={l0:g}"] = [fit.exponent, fit.exponent_error]
    lumped = an.speed_exponent(np.tile(v_imp, len(l0s)), c.ravel())
    strong = v_imp >= 1e-2 - 1e-12
    lumped_strong = an.speed_exponent(np.tile(v_imp[strong], len(l0s)), c[:, strong].ravel())
    out["alpha_lumped"] = [lumped.exponent, lumped.exponent_error]
    out["alpha_lumped_v_imp_from_1e-2"] = [lumped_strong.exponent, lumped_strong.exponent_error]
    return out


def _width_measurements(ds) -> dict[str, Any]:
    """Fig. 1: W(t) (region displaced by ≥ half the largest displacement) while the head is short of
    0.9 of the chain: dW/dt and the exponent of W ∝ t^β."""
    t = ds.t.values
    n = int(ds.sizes["grain"])
    out = {}
    for k, v_imp in enumerate(ds.v_imp.values):
        heads = an.head_positions(ds.v.isel(v_imp=k).values)
        widths = an.shock_widths(ds.u.isel(v_imp=k).values)
        beyond = np.flatnonzero(heads > 0.9 * n)  # until the head first reaches 0.9 of the chain
        keep = (np.arange(t.size) < (beyond[0] if beyond.size else t.size)) & (t > 0) & np.isfinite(widths)
        line = an.fit_line(t[keep], widths[keep])
        power = an.fit_power_law(t[keep], widths[keep])
        out[f"v_imp={v_imp:g}"] = {
            "dW_dt": [line.slope, line.slope_error],
            "beta": [power.exponent, power.exponent_error],
        }
    return out


def _tilt_measurements(ds) -> dict[str, Any]:
    """Fig. 4: tilt of the top of the in-going pulse (u) and of the reflected one (−u) at the figure's times."""
    t = ds.t.values
    u, v = ds.u.values, ds.v.values
    n = u.shape[-1]
    heads = an.head_positions(v)
    arrive = np.flatnonzero(heads > 0.98 * n)
    t_wall = float(t[arrive[0]] if arrive.size else t[-1])
    before = [int(np.argmin(np.abs(t - f * t_wall))) for f in (0.25, 0.5, 0.75, 0.95)]
    after = [int(np.argmin(np.abs(t - tt))) for tt in np.linspace(t_wall, t[-1], 5)[1:]]
    return {
        "t_wall": t_wall,
        "in_going": {f"t={t[r]:g}": an.plateau_tilt(u[r], fraction=0.9) for r in before},
        "reflected": {f"t={t[r]:g}": an.plateau_tilt(-u[r], fraction=0.9) for r in after},
        "speed": an.pulse_speed(t, heads, first_grain=100, last_grain=0.9 * n).slope,
    }


def _column_measurements(ds, name: str) -> dict[str, Any]:
    """Fig. 6: bumps and largest displacement per g at the figure's time; depth law: β per v_imp and
    c / closed form."""
    t = ds.t.values
    n = int(ds.sizes["grain"])
    scene = json.loads(ds.attrs["scene"])
    if name == "fig6":
        heads = an.head_positions(ds.v.sel(g=ds.g.values.max()).values)
        inside = np.flatnonzero(heads <= 0.8 * n)
        r = int(inside[-1]) if inside.size else len(t) - 1
        out: dict[str, Any] = {"t": float(t[r])}
        for g in ds.g.values:
            v = ds.v.sel(g=g).values[r]
            head = an.pulse_head(v)
            out[f"g={g:g}"] = {
                "head": head,
                "bumps_10pc": an.count_bumps(v, head, fraction=0.1),
                "bumps_30pc": an.count_bumps(v, head, fraction=0.3),
                "largest_u_below_grain_2": float(np.max(np.abs(ds.u.sel(g=g).values[r][3:]))),
            }
        return out
    dim = [d for d in ds.v.dims if d not in ("record", "grain")]
    out = {}
    g = float(scene["chain"]["gravity"])
    a = float(scene["chain"].get("a", 5657.0))
    for k, value in enumerate(ds[dim[0]].values):
        heads = an.head_positions(ds.v.isel({dim[0]: k}).values)
        fit = an.depth_law(t, heads, first_grain=50, last_grain=0.9 * n)
        ranges = {
            str(first): an.depth_law(t, heads, first_grain=first, last_grain=0.9 * n).exponent
            for first in (20, 100, 200)
        }
        mid, speed = an.speed_against_depth(t, heads, last_grain=0.9 * n)
        keep = (mid >= 50) & np.isfinite(speed)
        ratio = speed[keep] / an.column_sound_speed(mid[keep], gravity=g, a=a)
        out[f"{dim[0]}={value:g}"] = {
            "beta": [fit.exponent, fit.exponent_error],
            "beta_by_first_grain": ranges,
            "c_over_closed_form": [float(np.mean(ratio)), float(np.min(ratio)), float(np.max(ratio))],
        }
    return out


def _finite_g_measurements(ds) -> dict[str, Any]:
    """Sec. VII's controlled pair: per g (everything else equal) the light/heavy contrast, leading signs (20 %
    threshold), amplitudes and first lobes of the echoes at every traced grain."""
    out: dict[str, Any] = {}
    for g in ds.gravity.values:
        out[f"g={float(g):g}"] = _echo_measurements(ds.sel(gravity=g))
    return out


def measure(name: str, ds) -> dict[str, Any]:
    """The numbers docs/reproduction.md quotes for group ``name``, from its store (empty if none)."""
    if name in ("fig1", "fig2", "fig3", "fig3_load"):
        out = _pulse_measurements(ds, name)
        if name == "fig1":
            out["width"] = _width_measurements(ds)
        return out
    if name == "fig1d":
        return _speed_measurements(ds)
    if name == "fig4":
        return _tilt_measurements(ds)
    if name in ("fig6", "depth"):
        return _column_measurements(ds, name)
    if name.startswith("fig5_modes"):
        return _mode_measurements(ds)
    if name == "finite_g":
        return _finite_g_measurements(ds)
    if name.startswith("fig5") or name.startswith("fig7_8"):
        out = {"echo": _echo_measurements(ds)} if "impurity_mass" in ds.dims and np.any(ds.impurity_mass == 1.0) else {}
        if name == "fig5":
            out["profiles"] = _profile_measurements(ds)
        return out
    return {}


def compare(out_dir: Path) -> dict[str, Any]:
    """Measurements across groups (stores ``out_dir/<group>/<group>.zarr`` or ``out_dir/<group>.zarr``)."""

    def store(group: str):
        for path in (out_dir / group / f"{group}.zarr", out_dir / f"{group}.zarr"):
            if path.exists():
                return read_store(path)
        return None

    out: dict[str, Any] = {}
    fig1, fig2 = store("fig1"), store("fig2")
    if fig1 is not None and fig2 is not None:
        rows = {}
        for k, v_imp in enumerate(fig1.v_imp.values):
            u1, u2 = fig1.u.isel(v_imp=k).values, fig2.u.sel(v_imp=v_imp).values
            heads = an.head_positions(fig1.v.isel(v_imp=k).values)
            r = int(np.flatnonzero(heads > 500)[0])
            change = np.abs(u2[r] - u1[r])
            rows[f"v_imp={v_imp:g}"] = {
                "t": float(fig1.t.values[r]),
                "relative_profile_change": float(np.linalg.norm(u2[r] - u1[r]) / np.linalg.norm(u1[r])),
                "largest_change_at_grain": int(np.argmax(change)),
                "largest_displacement_ratio": float(np.max(u2[r]) / np.max(u1[r])),
            }
        out["fig2_vs_fig1"] = rows
    contrast = {}
    for group in ("fig5", "fig5_single", "fig7_8", "fig7_8_single", "fig7_8_slow"):
        ds = store(group)
        if ds is not None and np.any(ds.impurity_mass == 1.0):
            contrast[group] = an.contrast_table(ds)
    for group, reference in (("fig5_single", "fig5"), ("fig7_8_single", "fig7_8")):
        ds, ref = store(group), store(reference)
        if ds is not None and ref is not None:  # single impurities: the clean chain is in the five-impurity store
            light, heavy, _ = an.impurity_points(ds)
            clean = int(np.flatnonzero(ref.impurity_mass.values == 1.0)[0])
            after, until = an.echo_window(ref, int(ds.traced_grain.values[0]))
            contrast[group] = {
                str(rule): an.echo_contrast(
                    ds.trace_t.values,
                    ds.trace_v.isel(impurity_mass=light).sel(contact=rule).values[:, 0],
                    ds.trace_v.isel(impurity_mass=heavy).sel(contact=rule).values[:, 0],
                    ref.trace_v.isel(impurity_mass=clean, contact=0).values[:, 0],
                    after=after,
                    until=until,
                )
                for rule in ds.contact.values
            }
            tables = {}
            for f in ECHO_FRACTIONS:
                for name, index in (("light", light), ("heavy", heavy)):
                    for rule in ds.contact.values:
                        b = an.backscatter(
                            ds.trace_t.values,
                            ds.trace_v.isel(impurity_mass=index).sel(contact=rule).values[:, 0],
                            ref.trace_v.isel(impurity_mass=clean, contact=0).values[:, 0],
                            after=after,
                            until=until,
                            fraction=f,
                        )
                        tables.setdefault(f"{name}/{rule}", {})[str(f)] = [
                            b.leading_sign,
                            b.arrival_time,
                            b.amplitude,
                            b.peak_sign,
                        ]
            out[f"{group}_echo_by_threshold (sign, arrival, amplitude, peak sign)"] = tables
            out[f"{group}_first_lobe (sign, height / largest)"] = _first_lobes(
                ds,
                int(ds.traced_grain.values[0]),
                after,
                until,
                reference=ref.trace_v.isel(impurity_mass=clean, contact=0).values[:, 0],
            )
    out["light_heavy_contrast_at_surface"] = contrast
    return out


FIGURE_FILES = {"depth": "fig6_depth.png"}
"""PNG names in docs/figures/ that differ from the group's name."""


def group_runs(root: Path) -> dict[str, tuple[dict[str, Any], dict[str, Any], Path]]:
    """The figure groups stored under ``root``, as ``hertzian reproduce --out-dir root`` writes them (one
    ``log.json`` and ``root/<group>.zarr``) or as ``--out-dir root/<group>`` does, one group at a time: for each
    group (Figs. 9-10 and Sec. VI aside) its reproduction log, its run entry there and its store."""
    found: dict[str, tuple[dict[str, Any], dict[str, Any], Path]] = {}
    for folder in (root, *(root / name for name in GROUPS)):
        if not (folder / "log.json").is_file():
            continue
        log = json.loads((folder / "log.json").read_text())
        for run in log.get("runs", []):
            name = run.get("name")
            if name in GROUPS and name not in DRIVEN_GROUPS and (folder / f"{name}.zarr").exists():
                found[name] = (log, run, folder / f"{name}.zarr")
    return {name: found[name] for name in GROUPS if name in found}


def measure_stores(root: Path, *, figures_dir: Path | None = None, command: str = "") -> dict[str, Any]:
    """Re-measure every figure-group store under ``root`` (:func:`group_runs`) with the current analysis, and
    optionally redraw each group's figures into ``figures_dir``. Returns a log: date, command, each group's run
    (from its log.json: device, date, command, wall seconds) and measurements, and :func:`compare` across
    groups."""
    import warp as wp
    from hertzian.plotting.figures import plot_figure

    log: dict[str, Any] = {
        "command": command,
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "platform": platform.platform(),
        "cpu_count": _cpu_count(),
        "warp_version": wp.config.version,
        "groups": {},
    }
    for name, (runs, run, store) in group_runs(root).items():
        entry = {
            "run": {k: runs[k] for k in ("command", "date", "device", "device_name", "cpu_count", "platform")},
            **{k: run[k] for k in ("points", "grains", "steps", "dt", "wall_seconds", "grain_steps_per_second")},
            **{k: run[k] for k in ("energy_error_max", "status_counts")},
        }
        with opened(store) as ds:
            entry["measurements"] = measure(name, ds)
            if figures_dir is not None:
                entry["figures"] = {}
                for figure in GROUPS[name].figures:
                    png = figures_dir / (
                        FIGURE_FILES.get(name, f"{name}.png") if len(GROUPS[name].figures) == 1 else f"{figure}.png"
                    )
                    plot_figure(ds, figure, png)
                    entry["figures"][figure] = f"hertzian plot {store} --figure {figure} --out {png}"
            else:
                entry["figures"] = {figure: str(store.parent / png) for figure, png in run.get("figures", {}).items()}
        log["groups"][name] = entry
    log["comparisons"] = compare(root)
    return finite(log)


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


def reproduce(
    out_dir: Path,
    *,
    groups: list[str] | None = None,
    quick: bool = False,
    device: str = "cpu",
    sweeps_dir: Path | None = None,
    drive_grains: int | None = None,
    events: str | None = None,
    kernel: str | None = None,
    background: bool | None = None,
    say: Callable[[str], None] = print,
) -> dict[str, Any]:
    """Run ``groups`` (default: all of GROUPS), write their stores and PNGs into ``out_dir`` and the log
    ``out_dir/log.json``; returns the log. A figure that cannot be drawn is logged with its error.
    ``events``: "auto" or "off" sets integrator.events for every group (default None: each sweep file's).
    ``drive_grains``: the driven column's length for Figs. 9–10 (default 10 000, or 300 with ``quick``;
    the paper's times are scaled by the travel time ∝ N^(5/6)). ``kernel``: the solver choice of the sweep
    groups (default: per group, ``group_kernel``: "fused" on a GPU where the group takes plain Gear steps, as
    every paper_*.toml does, whose short groups would otherwise take the per-step kernel; else "auto").
    Each run's ``seconds`` splits its wall time (setup, integrate, finalize or store, figures, measure).
    ``background`` (default: on a GPU): figures and measurements of a group are made in worker processes
    while the next groups integrate (same PNGs and numbers); the log's ``figure_wait_seconds`` is the time
    the end waited for them."""
    import warp as wp
    from hertzian.core.solvers.prepare import prepare_kernels

    sweeps_dir = sweeps_dir or default_sweeps_dir()
    out_dir.mkdir(parents=True, exist_ok=True)
    names = groups or list(GROUPS)
    log: dict[str, Any] = {
        "command": "hertzian reproduce"
        + (" --quick" if quick else "")
        + "".join(f" --figure {g}" for g in (groups or []))
        + (f" --drive-grains {drive_grains}" if drive_grains else "")
        + (f" --events {events}" if events else "")
        + (f" --kernel {kernel}" if kernel else "")
        + f" --device {device}",
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "device": device,
        "device_name": wp.get_device(device).name,
        "cpu_count": _cpu_count(),
        "platform": platform.platform(),
        "warp_version": wp.config.version,
        "quick": quick,
        "events": events or "as each sweep file says",
        "runs": [],
    }
    begin = time.perf_counter()
    failures = 0
    background = (not wp.get_device(device).is_cpu) if background is None else background
    pool = _figure_pool(len(names)) if background else None
    pending = []
    log["figures_in_background"] = pool is not None
    # with figures in the background the driven column (the longest run) goes first: its figures and the short
    # groups overlap, and the log keeps the groups' order
    order = sorted(names, key=lambda n: n != "fig9_10") if pool is not None else names
    prepare_kernels(paper_needs(device, quick=quick, events=events, kernel=kernel, groups=names), device)
    for name in order:
        group = GROUPS[name]
        path = sweeps_dir / group.sweep
        if name in DRIVEN_GROUPS:
            runs = DRIVEN_GROUPS[name](DriveJob(path, out_dir, device, quick, drive_grains, events, say))
        else:
            store = out_dir / f"{name}.zarr"
            overrides = {**(group.quick if quick else {}), **({"integrator.events": events} if events else {})}
            entry = run_sweep_group(path, overrides, store, device, kernel)
            runs = [{"name": name, "sweep": group.sweep, "store": store.name, **entry}]
            say(
                f"{name}: {entry['points']} points x {entry['grains']} grains, {entry['wall_seconds']:.1f} s, "
                f"{entry['grain_steps_per_second']:.3g} grain-steps/s, energy error {entry['energy_error_max']:.2e}"
            )
        if pool is not None:
            pending.append((runs, pool.submit(draw_and_measure, str(out_dir), name, runs[0]["store"])))
        else:
            failures += _merge_drawn(runs, draw_and_measure(str(out_dir), name, runs[0]["store"]), say)
        log["runs"].extend(runs)
    if pool is not None:
        clock = time.perf_counter()
        for runs, future in pending:
            failures += _merge_drawn(runs, future.result(), say)
        pool.shutdown()
        log["figure_wait_seconds"] = time.perf_counter() - clock
    log["runs"].sort(key=lambda run: names.index(group_of(run["name"].removesuffix("_dt_check"))))
    log["total_seconds"] = time.perf_counter() - begin
    log["figure_failures"] = failures
    (out_dir / "log.json").write_text(json.dumps(finite(log), indent=1))
    return log


IN_MEMORY_BYTES = 4 << 30
"""A store up to this size is read into memory once before its figures and measurements, which read its arrays
many times over (each read of a lazy Zarr array decompresses its chunks again)."""


def read_store(path: Path):
    """The store at ``path`` as an xarray Dataset: in memory up to IN_MEMORY_BYTES, else lazy."""
    import xarray as xr

    lazy = xr.open_zarr(path)
    return lazy.load() if lazy.nbytes <= IN_MEMORY_BYTES else lazy


@contextlib.contextmanager
def opened(path: Path):
    """:func:`read_store`, closed after use."""
    with read_store(path) as dataset:
        yield dataset


DRIVEN_STORES = {"fig9_10": ("fig9_10.zarr", "fig9_10_dt_check.zarr"), "sec6_lag": ("sec6_lag.zarr",)}
"""The stores each driven group may write (the others write ``<group>.zarr``)."""


def figure_file(name: str, figure: str) -> str:
    """The PNG of ``figure`` of group ``name``: the group's name when it draws one figure, else the figure's."""
    return f"{name}.png" if len(GROUPS[name].figures) == 1 else f"{figure}.png"


def outputs(names: list[str]) -> tuple[list[str], list[str]]:
    """(stores, files) that reproducing the groups ``names`` may write in its folder: what it replaces there."""
    stores = [store for name in names for store in DRIVEN_STORES.get(name, (f"{name}.zarr",))]
    files = ["log.json", *(figure_file(name, figure) for name in names for figure in GROUPS[name].figures)]
    return stores, files


def draw_and_measure(out_dir: str, name: str, store: str) -> dict[str, Any]:
    """Group ``name``'s figures (PNGs in ``out_dir``) and measurements from its store; a figure that cannot be
    drawn is reported, not raised. Runs in the reproducing process or in a worker process."""
    from hertzian.plotting.figures import plot_figure

    group = GROUPS[name]
    out = Path(out_dir)
    drawn: dict[str, Any] = {"figures": {}, "failures": [], "seconds": {}}
    clock = time.perf_counter()
    with opened(out / store) as dataset:
        for figure in group.figures:
            png = out / figure_file(name, figure)
            try:
                plot_figure(dataset, figure, png)
                drawn["figures"][figure] = png.name
            except Exception as err:  # noqa: BLE001  (logged; the other groups still run)
                drawn["figures"][figure] = f"failed: {type(err).__name__}: {err}"
                drawn["failures"].append(f"{name}: figure {figure} failed: {err}")
        drawn["seconds"]["figures"] = time.perf_counter() - clock
        if name not in DRIVEN_GROUPS:
            clock = time.perf_counter()
            drawn["measurements"] = measure(name, dataset)
            drawn["seconds"]["measure"] = time.perf_counter() - clock
    return drawn


def _merge_drawn(runs: list[dict[str, Any]], drawn: dict[str, Any], say: Callable[[str], None]) -> int:
    """Put ``draw_and_measure``'s result into the group's first run entry; returns the failed figure count."""
    for line in drawn["failures"]:
        say(line)
    runs[0]["figures"] = drawn["figures"]
    runs[0].setdefault("seconds", {}).update(drawn["seconds"])
    if "measurements" in drawn:
        runs[0]["measurements"] = drawn["measurements"]
    return len(drawn["failures"])


FIGURE_WORKERS = 8
"""The most worker processes drawing a reproduction's figures: the figures take far more CPU time than the GPU
takes for the runs, so with fewer workers a reproduction on a GPU host waits for its figures after its last run."""


def _figure_pool(groups: int):
    """Worker processes (spawned: the parent holds a CUDA context) for figures and measurements: up to
    FIGURE_WORKERS, one core left to the process that drives the GPU."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    workers = max(1, min(groups, FIGURE_WORKERS, _cpu_count() - 1))
    return ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"))


def _cpu_count() -> int:
    import os

    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def paper_needs(
    device: str,
    *,
    quick: bool = False,
    events: str | None = None,
    kernel: str | None = None,
    groups: list[str] | None = None,
) -> list:
    """Every launch group of ``hertzian reproduce`` (each figure group's sweep of ``groups``, default all; the driven
    column of Figs. 9-10 and its window kernels), with the kernel choice ``reproduce`` makes per group."""
    from hertzian.core.model import features_of
    from hertzian.core.solvers.prepare import Need
    from hertzian.kernels.windows import window_kernels
    from hertzian.sweeping.distributed import sweep_needs

    needs: list = []
    sweeps = default_sweeps_dir()
    for name in groups or list(GROUPS):
        group = GROUPS[name]
        overrides = {**(group.quick if quick else {}), **({"integrator.events": events} if events else {})}
        if name == "fig9_10":
            grains = group.quick["chain.grains"] if quick else 10000
            _, scenes = drive_scenes(sweeps / group.sweep, grains, 1.0, DRIVE_DT, events)
            needs.append(Need(features_of(list(scenes)), grains, len(scenes), None, "auto"))
            needs.extend(window_kernels(needs[-1].features.precision))
            continue
        from hertzian.sweeping.spec import expand, load_sweep

        choice = kernel
        if choice is None:
            choice = group_kernel(
                expand(load_sweep(sweeps / group.sweep, overrides)).scene(0).integrator.events, device
            )
        needs.extend(sweep_needs(sweeps / group.sweep, overrides, device, choice))
    return needs
