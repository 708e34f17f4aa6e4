"""Numbers of docs/reproduction.md and docs/drive.md that no figure group measures: checks at a second time step,
reruns of a group with one setting changed, closed forms, and the reduction of the long driven-column runs.

``hertzian reproduce --measure NAME --json RECORD`` runs one item (or ``daggers``: every item but ``settle`` and
``drive_map``, which have records of their own)
and merges its values into RECORD under ``items.NAME`` with the device, date, command and wall seconds; stores go
to ``--out-dir``. The scenes are the paper sweeps of ``sweeps/`` (as ``hertzian reproduce`` runs them) with the
overrides written in each item; the measures are those of :mod:`hertzian.studies.analysis`.
"""

from __future__ import annotations

import json
import math
import platform
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable

import numpy as np
from hertzian.studies import analysis as an
from hertzian.studies import reproduce as rp
from hertzian.studies.analysis.drive import point_scene_value

NESTERENKO_IMPACTS = (1e-3, 1e-2, 1e-1)
NESTERENKO_GRAINS = (40, 80)
"""Traced grains of the Nesterenko chain (120 grains, l0 = 0): the speed is their distance over the passage times."""
RIPPLE_DEPTHS = (500.0, 750.0, 1000.0, 5000.0, 7500.0, 10000.0)
SETTLE_STORES = ("tau10", "tau1")
"""Stores of docs/drive.md's long runs in ``--out-dir``: NAME.zarr at dt, NAME_half.zarr at dt/2."""
POWER_SPANS = ((0.0, 1000.0), (1000.0, 2500.0), (2500.0, 5000.0))
CHANGE_PERCENTILES = (50.0, 90.0, 99.0)


def _sweep(group: str) -> Path:
    return rp.default_sweeps_dir() / rp.GROUPS[group].sweep


def _open(path: Path):
    import xarray as xr

    return xr.open_zarr(path)


def _summary(entry: dict[str, Any]) -> dict[str, Any]:
    keys = ("points", "grains", "steps", "dt", "wall_seconds", "grain_steps_per_second", "energy_error_max")
    return {k: entry[k] for k in keys} | {"status_counts": entry["status_counts"]}


def _run_summary(result) -> dict[str, Any]:
    return {
        "energy_error_max": float(np.max(result.energy_error)),
        "status": result.status.tolist(),
        "steps": result.steps,
        "run_wall_seconds": result.wall_seconds,
    }


# ---- closed forms and committed numbers (no run) ----------------------------------------------------


def local_slopes(v_imp, speeds) -> dict[str, Any]:
    """d ln c / d ln v_imp between neighbouring impact speeds, at their geometric midpoints."""
    v, c = np.asarray(v_imp, float), np.asarray(speeds, float)
    return {
        "v_imp_midpoints": np.sqrt(v[1:] * v[:-1]).tolist(),
        "slope": (np.diff(np.log(c)) / np.diff(np.log(v))).tolist(),
    }


def fig1d_local_slopes(work: Path, device: str, *, measurements: Path | None = None) -> dict[str, Any]:
    """Local slopes of Fig. 1(d) at each l0, from the committed measurements.json's speeds (no run)."""
    path = measurements or Path("docs/records/reproduction/measurements.json")
    m = json.loads(path.read_text())["groups"]["fig1d"]["measurements"]
    out: dict[str, Any] = {"source": f"{path} groups.fig1d.measurements.speed"}
    for l0, c in zip(m["l0"], m["speed"]):
        slopes = local_slopes(m["v_imp"], c)
        out["v_imp_midpoints"] = slopes["v_imp_midpoints"]
        out[f"l0={l0:g}"] = slopes["slope"]
    return out


def drive_ripple_scale(work: Path, device: str) -> dict[str, Any]:
    """Half the τ = 1 drive's wavelength, c·τ/2, at the closed-form sound speed of the g = 1 column (no run)."""
    half = an.column_sound_speed(np.array(RIPPLE_DEPTHS), gravity=1.0, a=5657.0) * 1.0 / 2
    return {"tau": 1.0, "depth": list(RIPPLE_DEPTHS), "c_tau_over_2_grains": half.tolist()}


# ---- impact chains ----------------------------------------------------------------------------------


def soliton_numbers(t, v, v_imp: float) -> dict[str, float]:
    """Speed from the head's passage at the two traced grains (sub-sample by a parabola), v_m = the deeper
    grain's largest velocity, the speed over Nesterenko's for that v_m, and the FWHM in grains."""
    passage = []
    for column in range(2):
        i = int(np.argmax(v[:, column]))
        passage.append(t[i] + (an._parabolic_peak(v[:, column], i) - i) * (t[1] - t[0]))
    speed = (NESTERENKO_GRAINS[1] - NESTERENKO_GRAINS[0]) / (passage[1] - passage[0])
    v_m = float(v[:, 1].max())
    return {
        "speed": speed,
        "v_m": v_m,
        "v_m_over_v_imp": v_m / v_imp,
        "speed_over_nesterenko": speed / float(an.nesterenko_speed(v_m)),
        "fwhm_grains": an.full_width_half_maximum(t, v[:, 1]) * speed,
    }


def nesterenko(work: Path, device: str) -> dict[str, Any]:
    """The l0 = 0 soliton on a 120-grain chain between walls (traces of grains 40 and 80 every step) at
    dt = 1.25e-4 and 2.5e-5: :func:`soliton_numbers` per impact speed and their relative change with dt."""
    from hertzian.core.runner import run_ensemble
    from hertzian.core.scene import scene_from_dict

    out: dict[str, Any] = {
        "nesterenko_fwhm": an.NESTERENKO_FWHM,
        "nesterenko_prefactor": float(an.nesterenko_speed(1.0)),
    }
    for dt in (1.25e-4, 2.5e-5):
        record = {"every": 10.5, "traces": list(NESTERENKO_GRAINS), "trace_every": dt}
        scenes = [
            scene_from_dict(
                {
                    "chain": {"grains": 120, "l0": 0.0},
                    "excitation": {"impact": v},
                    "integrator": {"dt": dt, "duration": 10.5},
                    "record": record,
                }
            )
            for v in NESTERENKO_IMPACTS
        ]
        result = run_ensemble(scenes, device)
        rows = {
            f"v_imp={v:g}": soliton_numbers(result.trace_t, result.traces["v"][k], v)
            for k, v in enumerate(NESTERENKO_IMPACTS)
        }
        out[f"dt={dt:g}"] = {"rows": rows, **_run_summary(result)}
    a, b = out["dt=0.000125"]["rows"], out["dt=2.5e-05"]["rows"]
    out["dt_relative_differences"] = {
        key: {q: abs(a[key][q] / b[key][q] - 1) for q in ("speed", "v_m", "fwhm_grains")} for key in a
    }
    return out


def load_speeds(work: Path, device: str) -> dict[str, Any]:
    """Fig. 1(d)'s chains at l0 = 1e-5, v_imp = 0.1 and 1e-2, with a surface wall and with a constant-force
    surface: pulse speeds fitted as in Fig. 1(d) (heads between grains 100 and 800)."""
    from hertzian.core.runner import run_ensemble
    from hertzian.core.scene import scene_from_dict
    from hertzian.sweeping.spec import load_sweep, sweep_scenes

    chosen = [
        s
        for s in sweep_scenes(load_sweep(_sweep("fig1d")))
        if math.isclose(s.chain.l0, 1e-5) and any(math.isclose(s.excitation.impact, v) for v in (0.1, 0.01))
    ]
    out: dict[str, Any] = {"sweep": rp.GROUPS["fig1d"].sweep, "l0": 1e-5}
    for surface in ("wall", "load"):
        scenes = []
        for s in chosen:
            data = s.to_dict()
            data["boundary"]["surface"] = surface
            scenes.append(scene_from_dict(data))
        result = run_ensemble(scenes, device)
        heads = an.head_positions(result.v)
        out[surface] = {
            f"v_imp={s.excitation.impact:g}": an.pulse_speed(result.t, h, first_grain=100, last_grain=800).slope
            for s, h in zip(scenes, heads)
        }
        out[surface + "_run"] = _run_summary(result)
    return out


def fig3_raw_tails(work: Path, device: str) -> dict[str, Any]:
    """Fig. 3 at full size: R² of exponential fits to the raw (not enveloped) compressive tails, beside the
    enveloped fits of measurements.json."""
    store = work / "fig3.zarr"
    out: dict[str, Any] = {"run": _summary(rp.run_sweep_group(_sweep("fig3"), {}, store, device))}
    with _open(store) as ds:
        measured = rp.measure("fig3", ds)
        t = ds.t.values
        for k in range(ds.sizes["l0"]):
            point = ds.isel(l0=k)
            l0 = float(point.l0)
            u, heads = point.u.values, an.head_positions(point.v.values)
            rows = []
            for when in rp.TAIL_TIMES[l0]:
                r = int(np.argmin(np.abs(t - when)))
                raw = an.tail_decay(u[r], heads[r], envelope=1)
                rows.append({"t": float(t[r]), "raw_decay_length": raw.decay_length, "raw_r_squared": raw.r_squared})
            enveloped = [
                {q: f[q] for q in ("t", "decay_length", "r_squared", "decay_over_ct")}
                for f in measured[f"l0={l0:g}"]["tail"]
            ]
            out[f"l0={l0:g}"] = {"raw": rows, "envelope": enveloped}
    return out


def head_speed_amplitude(t, v, t_wall: float, grains: int) -> dict[str, list[float]]:
    """Largest |v| of each snapshot: in-going (head between grain 100 and 0.9 N), reflected (from 5 time units
    after the head reached the wall to the end); [min, max] of each and the times they span."""
    heads = an.head_positions(v)
    beyond = np.flatnonzero(heads > 0.9 * grains)
    stop = beyond[0] if beyond.size else len(t)
    ingoing = [r for r in range(stop) if heads[r] >= 100]
    reflected = [r for r in range(len(t)) if t[r] >= t_wall + 5.0]
    amp = np.max(np.abs(v), axis=-1)
    return {
        "in_going": [float(amp[ingoing].min()), float(amp[ingoing].max())],
        "in_going_t": [float(t[ingoing[0]]), float(t[ingoing[-1]])],
        "reflected": [float(amp[reflected].min()), float(amp[reflected].max())],
        "reflected_t": [float(t[reflected[0]]), float(t[reflected[-1]])],
    }


def fig4(work: Path, device: str) -> dict[str, Any]:
    """Fig. 4 at full size: the head's |v| before and after reflection; a dt = 1.25e-5 rerun to t = 10 against
    the dt = 1.25e-4 run (fields and pulse speed); the top's tilts at 300 and 500 grains."""
    full, fine = work / "fig4.zarr", work / "fig4_dt.zarr"
    out: dict[str, Any] = {"run": _summary(rp.run_sweep_group(_sweep("fig4"), {}, full, device))}
    with _open(full) as ds:
        measured = rp.measure("fig4", ds)
        out["tilt"] = measured
        t0, u0, v0 = ds.t.values, ds.u.values, ds.v.values
        out["head_speed_amplitude"] = head_speed_amplitude(t0, v0, measured["t_wall"], ds.sizes["grain"])
    check = rp.run_sweep_group(_sweep("fig4"), {"integrator.dt": 1.25e-5, "integrator.duration": 10.0}, fine, device)
    out["dt_check_run"] = _summary(check)
    with _open(fine) as ds:
        t, u, v = ds.t.values, ds.u.values, ds.v.values
    n = len(t)
    last = 0.9 * u.shape[-1]
    speeds = [an.pulse_speed(t, an.head_positions(w), first_grain=100, last_grain=last).slope for w in (v0[:n], v)]
    out["dt_check"] = {
        "t_max": float(t[-1]),
        "max_abs_du_over_max_abs_u": float(np.max(np.abs(u - u0[:n])) / np.max(np.abs(u))),
        "max_abs_dv_over_max_abs_v": float(np.max(np.abs(v - v0[:n])) / np.max(np.abs(v))),
        "speed_dt_1.25e-4": speeds[0],
        "speed_dt_1.25e-5": speeds[1],
    }
    for grains, duration in ((300, 13.0), (500, 22.0)):
        store = work / f"fig4_{grains}.zarr"
        small = rp.run_sweep_group(
            _sweep("fig4"), {"chain.grains": grains, "integrator.duration": duration}, store, device
        )
        with _open(store) as ds:
            out[f"grains={grains}"] = {"run": _summary(small), "tilt": rp.measure("fig4", ds)}
    return out


def echo_numbers(ds) -> dict[str, dict[str, float]]:
    """Arrival, amplitude, leading and peak sign of each echo at the surface grain (20 % threshold)."""
    table = an.echo_table(ds, traced=0, fraction=0.2)
    keys = ("arrival_time", "amplitude", "leading_sign", "peak_sign")
    return {key: {q: getattr(b, q) for q in keys} for key, b in table.items()}


def fig7_8_dt(work: Path, device: str) -> dict[str, Any]:
    """Figs. 7–8 (six chains) at dt = 1.25e-4 and 1.25e-5 over the whole run: velocity differences per chain
    (snapshots and traces) and the echo numbers at the surface grain."""
    stores = {dt: work / f"fig7_8_dt{dt:g}.zarr" for dt in (1.25e-4, 1.25e-5)}
    out: dict[str, Any] = {}
    for dt, store in stores.items():
        out[f"run dt={dt:g}"] = _summary(rp.run_sweep_group(_sweep("fig7_8"), {"integrator.dt": dt}, store, device))
    with _open(stores[1.25e-4]) as coarse, _open(stores[1.25e-5]) as fine:
        for name, field in (("snapshots", "v"), ("traces", "trace_v")):
            a, b = coarse[field].values, fine[field].values
            out[f"max_abs_dv_over_max_abs_v ({name}, per chain)"] = (
                (np.max(np.abs(a - b), axis=(-1, -2)) / np.max(np.abs(b), axis=(-1, -2))).ravel().tolist()
            )
        out["chain_order"] = [f"{m:g}/{c}" for m in coarse.impurity_mass.values for c in coarse.contact.values]
        echoes = {"dt=1.25e-4": echo_numbers(coarse), "dt=1.25e-5": echo_numbers(fine)}
    out["echo at grain 0 (threshold 20 %)"] = echoes
    out["echo relative differences"] = {
        key: {
            q: abs(echoes["dt=1.25e-4"][key][q] / echoes["dt=1.25e-5"][key][q] - 1)
            for q in ("arrival_time", "amplitude")
        }
        for key in echoes["dt=1.25e-4"]
    }
    return out


# ---- driven columns ---------------------------------------------------------------------------------


def _per_tau(ds, values) -> dict[str, Any]:
    return {f"tau={tau:g}": values(i) for i, tau in enumerate(ds.tau.values)}


def preview_numbers(ds, standing_wave: list[list[dict]]) -> dict[str, Any]:
    """The reduced Figs. 9–10 store's numbers: window-mean kinetic energy per grain at each paper time (largest
    below the driven grain, in grains 1–99 and below), and the persistence of each paper time's pattern."""
    starts = np.flatnonzero(ds.window_lag.values == 0)
    ke = ds.ke_window.values  # grain 0 is the driven grain: its energy is set by the drive
    persistence = [
        [
            {"t": r["t"], "mean_correlation_lags_1.5_to_10.5": float(np.mean(r["correlation"][1:]))}
            | {k: r[k] for k in ("correlation", "node_count", "node_spacing", "node_shift")}
            for r in rows[:-1]
        ]
        for rows in standing_wave
    ]
    return {
        "paper_times_scaled": ds.window_t.values[starts].tolist(),
        "largest_window_mean_ke_per_grain (grains 1…)": _per_tau(ds, lambda i: ke[i, starts, 1:].max(axis=-1).tolist()),
        "mean_window_ke_in_grains_1_to_99": _per_tau(ds, lambda i: ke[i, starts, 1:100].mean(axis=-1).tolist()),
        "mean_window_ke_below_grain_100": _per_tau(ds, lambda i: ke[i, starts, 100:].mean(axis=-1).tolist()),
        "standing_wave": _per_tau(ds, lambda i: persistence[i]),
    }


def drive_1000(work: Path, device: str) -> dict[str, Any]:
    """The 1000-grain driven columns (``hertzian reproduce --figure fig9_10 --drive-grains 1000``): energy errors,
    the dt check at the first window, :func:`preview_numbers`, and Figs. 9–10 of the reduced column in ``work``."""
    from hertzian.plotting.figures import plot_figure

    main, check = rp.run_drive_group(rp.DriveJob(_sweep("fig9_10"), work, device, grains=1000, say=lambda line: None))
    out = {
        k: main[k]
        for k in ("taus", "grains", "duration", "steps", "dt", "kernel", "wall_seconds", "energy_error", "status")
    }
    out["dt_check"] = {k: check[k] for k in check if k not in ("store", "name")}
    with _open(work / "fig9_10.zarr") as ds:
        out |= preview_numbers(ds, main["standing_wave"])
        for figure in ("fig9", "fig10"):
            plot_figure(ds, figure, work / f"{figure}_reduced.png")
    out["figures"] = [f"{figure}_reduced.png" for figure in ("fig9", "fig10")]
    return out


def energy_history(t, energy, work) -> dict[str, Any]:
    """Energy balance |E − E0 − W| / max|W| of one driven chain over time: its largest jump between samples, the
    largest error before and after it, and every jump over 1e-6."""
    scale = float(np.max(np.abs(work)))
    balance = (energy - energy[0] - work) / scale
    steps = np.abs(np.diff(balance))
    k = int(np.argmax(steps))
    return {
        "max_abs_W": scale,
        "energy_error": float(np.max(np.abs(balance))),
        "largest_jump": {
            "between_t": [float(t[k]), float(t[k + 1])],
            "relative": float(steps[k]),
            "energy_change": float(energy[k + 1] - energy[k]),
            "work_change": float(work[k + 1] - work[k]),
        },
        "energy_error_before_it": float(np.max(np.abs(balance[: k + 1]))),
        "energy_error_after_it": float(np.max(np.abs(balance[k + 1 :] - balance[k + 1]))),
        "jumps_over_1e-6": [[float(t[j]), float(t[j + 1]), float(steps[j])] for j in np.flatnonzero(steps > 1e-6)],
    }


def record_changes(t, energy, work) -> dict[str, Any]:
    """:func:`energy_history` of one driven chain at evenly spaced records, with the percentiles
    (CHANGE_PERCENTILES) of the change of |E − E0 − W| / max|W| between successive records."""
    balance, _ = an.energy_drift(energy, work)
    changes = np.abs(np.diff(balance))
    label = ", ".join(f"{q:g}" for q in CHANGE_PERCENTILES)
    return energy_history(t, energy, work) | {
        f"change_percentiles ({label} %)": np.percentile(changes, CHANGE_PERCENTILES).tolist()
    }


def drive_1000_energy_history(work: Path, device: str) -> dict[str, Any]:
    """:func:`energy_history` of ``drive_1000``'s store (``work``/fig9_10.zarr; no run: run drive_1000 first)."""
    with _open(work / "fig9_10.zarr") as ds:
        t = ds.energy_t.values
        out: dict[str, Any] = {"samples": int(t.size), "t_last": float(t[-1])}
        for i, tau in enumerate(ds.tau.values):
            out[f"tau={tau:g}"] = energy_history(t, ds.energy.values[i], ds.work.values[i])
            out[f"tau={tau:g}"]["largest_abs_v_in_snapshots"] = float(np.max(np.abs(ds.v.values[i])))
    return out


def drive_tau1_energy(work: Path, device: str) -> dict[str, Any]:
    """Where the 1000-grain τ = 1 column's energy error comes from: the column (records every 0.5) to t = 78 with
    the per-step kernel and the device's default kernel at dt = 1.25e-4, and the default kernel at dt = 1.25e-5;
    energy error and largest |v| at every record, and :func:`record_changes` of the energy balance."""
    from hertzian.core.devices import init_warp
    from hertzian.core.model import build_model
    from hertzian.core.runner import Runner
    from hertzian.sweeping.spec import load_sweep, sweep_scenes

    init_warp()
    out: dict[str, Any] = {"grains": 1000, "tau": 1.0, "duration": 78.0}
    for dt, kernel in ((1.25e-4, "step"), (1.25e-4, "auto"), (1.25e-5, "auto")):
        overrides = {"chain.grains": 1000, "integrator.duration": 78.0, "integrator.dt": dt, "record.every": 0.5}
        scene = [s for s in sweep_scenes(load_sweep(_sweep("fig9_10"), overrides)) if s.excitation.drive_period == 1.0]
        result = Runner(build_model(scene, device), kernel=kernel).run()
        drift, scale = an.energy_drift(result.energy, result.work)
        out[f"dt={dt:g} {kernel}"] = {
            "kernel": result.kernel,
            **_run_summary(result),
            "t": result.t.tolist(),
            f"energy_error_by_record ({scale})": np.abs(drift[0]).tolist(),
            "largest_abs_v_by_record": np.max(np.abs(result.v[0]), axis=-1).tolist(),
            "energy_balance_between_records": record_changes(result.t, result.energy[0], result.work[0]),
        }
    return out


# ---- the long driven runs of docs/drive.md ("Settling Figs. 9–10") ------------------------------------


def mean_power(t, work, lo: float, hi: float) -> float:
    """The driver's mean power (W(end) − W(start)) / (end − start) over the records in [lo, hi]; NaN if < 2."""
    inside = np.flatnonzero((t >= lo - 1e-9) & (t <= hi + 1e-9))
    if inside.size < 2:
        return math.nan
    i, j = inside[0], inside[-1]
    return float((work[j] - work[i]) / (t[j] - t[i]))


def parting_time(t, v_a, v_b, *, fraction: float = 1e-2) -> float | None:
    """First time at which two runs' traced velocities (time, grain) differ by more than ``fraction`` of the
    first run's range; None if never (over their common records)."""
    n = min(len(v_a), len(v_b))
    scale = float(np.ptp(v_a[:n])) or 1.0
    apart = np.flatnonzero(np.abs(v_a[:n] - v_b[:n]).max(axis=-1) > fraction * scale)
    return float(t[apart[0]]) if apart.size else None


def window_numbers(point) -> dict[str, list]:
    """Per response window of one point: standing-wave ratio and nodes of |V_1|, node drift to the next window,
    the correlation of successive window kinetic-energy profiles (25-grain smoothing), the driver-open fraction."""
    v1 = np.abs(point.response.sel(harmonic=1).values)
    counts, drift = an.node_drift(v1)
    ke = point.window_ke.values
    successive = [an.profile_correlation(ke[w : w + 2], smooth=25)[1] for w in range(len(ke) - 1)]
    return {
        "window_start": point.window_start.values.tolist(),
        "swr": [an.standing_wave_ratio(v) for v in v1],
        "node_count": np.asarray(counts).tolist(),
        "node_drift": np.asarray(drift).tolist(),
        "ke_correlation_next": [float(c) for c in successive],
        "driver_open": point.driver_open.values.tolist(),
    }


def strobe(point, since: float) -> str:
    """Stroboscopic label of a point's traced grains (u and v at t = nτ from ``since``) and its sample count."""
    period = point_scene_value(point, "excitation.drive_period")
    trace = np.concatenate([point.trace_u.values, point.trace_v.values], axis=-1)
    samples = an.strobe_samples(point.trace_t.values, trace, period, since=since)
    return f"{an.LABELS[an.strobe_label(samples)]} ({len(samples)} samples)"


def window_medians(windows: dict[str, list], count: int | None = None) -> dict[str, float]:
    """Medians over the first ``count`` windows (default all) of :func:`window_numbers`' swr (where finite), node
    drift, successive-window correlation and driver-open fraction: docs/drive.md's table."""
    out = {}
    for key in ("swr", "node_drift", "ke_correlation_next", "driver_open"):
        x = np.asarray(windows[key][:count], dtype=float)
        x = x[np.isfinite(x)]
        out[key] = float(np.median(x)) if x.size else math.nan
    return out


def settle_point(point, half=None) -> dict[str, Any]:
    """One point of a long driven run: energy error, mean driver power over POWER_SPANS, strobe labels (all, and
    t ≥ 2500), :func:`window_numbers`; with ``half`` (the same point at dt/2) its window numbers, energy error and
    the time the traced grains' trajectories part."""
    t, work = point.t.values, point.work.values
    row = {
        "drive_period": point_scene_value(point, "excitation.drive_period"),
        "drive_amplitude": point_scene_value(point, "excitation.drive_amplitude"),
        "status": int(point.status),
        "energy_error": float(point.energy_error),
        "mean_power": {f"{lo:g}-{hi:g}": mean_power(t, work, lo, hi) for lo, hi in POWER_SPANS},
        "strobe_all": strobe(point, 0.0),
        "strobe_late": strobe(point, 2500.0),
        "windows": window_numbers(point),
    }
    if half is not None:
        same = min(point.trace_t.size, half.trace_t.size)
        row["half_dt"] = {
            "windows": window_numbers(half),
            "energy_error": float(half.energy_error),
            "trajectories_part_at": parting_time(
                point.trace_t.values[:same], point.trace_v.values, half.trace_v.values
            ),
        }
        shared = len(row["half_dt"]["windows"]["swr"])
        row["medians_over_shared_windows"] = {"dt": window_medians(row["windows"], shared)}
        row["medians_over_shared_windows"]["dt/2"] = window_medians(row["half_dt"]["windows"])
    row["medians"] = window_medians(row["windows"])
    return row


def settle(work: Path, device: str) -> dict[str, Any]:
    """docs/drive.md's long Figs. 9–10 runs: :func:`settle_point` for every point of ``work``/NAME.zarr (NAME in
    SETTLE_STORES) with its dt/2 twin ``work``/NAME_half.zarr where present (no run)."""
    runs = []
    for name in SETTLE_STORES:
        ds = _open(work / f"{name}.zarr")
        half_path = work / f"{name}_half.zarr"
        half = _open(half_path) if half_path.exists() else None
        dims = [str(d) for d in ds.status.dims]
        for index in np.ndindex(*[int(ds.sizes[d]) for d in dims]):
            where = dict(zip(dims, index))
            row = {"store": f"{name}.zarr", **{d: float(ds[d].values[i]) for d, i in where.items()}}
            runs.append(row | settle_point(ds.isel(where), None if half is None else half.isel(where)))
    return {"runs": runs}


def drive_map(work: Path, device: str) -> dict[str, Any]:
    """docs/drive.md's reduced response map: ``sweeps/drive_map.toml`` at its step and at half of it (stores
    ``work``/drive_map.zarr and drive_map_half.zarr), and per point the map's numbers (``analysis.response_map``) at
    both steps, their relative changes, whether the label agrees, each run's energy error and when the traced
    velocities of the two runs part (:func:`parting_time`)."""
    from hertzian.sweeping.pipeline import sweep
    from hertzian.sweeping.spec import load_sweep

    path = rp.default_sweeps_dir() / "drive_map.toml"
    dt = load_sweep(path).base.integrator.dt
    seconds = {}
    for name, step in (("drive_map", dt), ("drive_map_half", dt / 2)):
        start = time.perf_counter()
        overrides = {} if step == dt else {"integrator.dt": step}
        sweep(path, work / f"{name}.zarr", device=device, overwrite=True, overrides=overrides, notify=lambda line: None)
        seconds[name] = time.perf_counter() - start
    with _open(work / "drive_map.zarr") as full, _open(work / "drive_map_half.zarr") as half:
        numbers, halved = an.response_map(full), an.response_map(half)
        dims = numbers["dims"]
        rows = []
        for index in np.ndindex(*numbers["label"].shape):
            where = dict(zip(dims, index))
            a, b = full.isel(where), half.isel(where)
            row = {d: float(numbers["coords"][d][i]) for d, i in where.items()}
            for metric in an.MAP_METRICS:
                x, y = float(numbers[metric][index]), float(halved[metric][index])
                row |= {metric: x, f"{metric}_half_dt": y}
                row[f"{metric}_change"] = abs(y - x) / abs(x) if x and math.isfinite(x) and math.isfinite(y) else None
            row["label_agrees"] = row["label"] == row["label_half_dt"]
            row["energy_error"], row["energy_error_half_dt"] = float(a.energy_error), float(b.energy_error)
            same = min(a.trace_t.size, b.trace_t.size)
            row["trajectories_part_at"] = parting_time(a.trace_t.values[:same], a.trace_v.values, b.trace_v.values)
            rows.append(row)
    return {"dt": dt, "dt_half": dt / 2, "sweep_seconds": seconds, "points": rows}


# ---- the command -------------------------------------------------------------------------------------

MEASURES: dict[str, Callable[[Path, str], dict[str, Any]]] = {
    "fig1d_local_slopes": fig1d_local_slopes,
    "nesterenko": nesterenko,
    "load_speeds": load_speeds,
    "fig3_raw_tails": fig3_raw_tails,
    "fig4": fig4,
    "fig7_8_dt": fig7_8_dt,
    "drive_1000": drive_1000,
    "drive_1000_energy_history": drive_1000_energy_history,
    "drive_tau1_energy": drive_tau1_energy,
    "drive_ripple_scale": drive_ripple_scale,
    "settle": settle,
    "drive_map": drive_map,
}
"""``hertzian reproduce --measure NAME``: every item's function (stores in ``work``, device)."""
DAGGERS = tuple(name for name in MEASURES if name not in ("settle", "drive_map"))
"""``--measure daggers``: the items of docs/records/reproduction/daggers_cpu.json."""


def measure_items(names: list[str], record: Path, work: Path, device: str, *, command: str, say=print) -> dict:
    """Run the items ``names`` in order and merge each into the JSON ``record`` (created if missing; other items
    kept) under ``items.NAME``: command, date, wall seconds (compiling and analysis included), values."""
    import warp as wp

    work.mkdir(parents=True, exist_ok=True)
    log = json.loads(record.read_text()) if record.exists() else {"items": {}}
    log |= {"device": device, "device_name": wp.get_device(device).name, "cpu_count": rp._cpu_count()}
    log |= {"platform": platform.platform(), "warp_version": wp.config.version}
    for name in names:
        date = datetime.now(timezone.utc).isoformat(timespec="seconds")
        start = time.perf_counter()
        values = MEASURES[name](work, device)
        wall = time.perf_counter() - start
        log["items"][name] = {"command": command, "date": date, "wall_seconds": wall, "values": values}
        record.write_text(json.dumps(rp.finite(log), indent=1) + "\n")
        say(f"{name}: {wall:.1f} s")
    return log
