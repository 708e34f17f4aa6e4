"""Rerun the numbers of docs/reproduction.md that had no raw log (its † marks) and log them.

Usage, from the repository root (stores go to ``--work``, default out/daggers, not committed):

    python docs/logs/reproduction/daggers.py                 # every item
    python docs/logs/reproduction/daggers.py --only fig4 nesterenko

Writes docs/logs/reproduction/daggers_cpu.json: per item the device, date, command, wall seconds
(everything: kernel compilation, integration, analysis) and the measured values. Items not rerun
keep their previous entry, so items can be run one at a time. The scenes are the paper sweeps of
``sweeps/`` (through ``hertzian.ensemble.reproduce``, as ``hertzian reproduce`` runs them) with the
overrides written in each item; the measures are those of ``hertzian.ensemble.analysis`` and
``hertzian.ensemble.reproduce.measure``.

Items:

* ``fig1d_local_slopes`` — local slopes d ln c / d ln v_imp of Fig. 1(d) at each l0, from the committed
  measurements.json (no run).
* ``nesterenko`` — the l0 = 0 soliton on a 120-grain chain (traces of grains 40 and 80 every step):
  speed, v_m / v_imp, speed / Nesterenko(v_m), FWHM; at dt = 1.25e-4 and 2.5e-5.
* ``load_speeds`` — Fig. 1(d)'s chains at l0 = 1e-5, v_imp = 0.1 and 1e-2 with a surface wall and
  with a constant-force surface (``boundary.surface = "load"``): pulse speeds.
* ``fig3_raw_tails`` — Fig. 3 at full size: R² of exponential fits to the raw (not enveloped) tails.
* ``fig4`` — Fig. 4 at full size: |v| of the head before and after reflection; dt = 1.25e-5 rerun to
  t = 10 against the dt = 1.25e-4 run; the tilts at 300 and 500 grains.
* ``fig7_8_dt`` — Figs. 7–8 (six chains) at dt = 1.25e-4 and 1.25e-5 over the whole run: velocity
  differences and the echo table at the surface grain.
* ``drive_1000`` — the 1000-grain driven columns (Figs. 9–10 reduced, ``hertzian reproduce --figure
  fig9_10 --drive-grains 1000``): energy errors, the dt check at the first window, the window
  numbers quoted in the preview paragraph; redraws docs/figures/fig9_reduced_cpu.png, fig10_reduced_cpu.png.
* ``drive_tau1_energy`` — the 1000-grain τ = 1 column to t = 78 with the per-step and the fused sweep
  kernel (dt = 1.25e-4) and at dt = 1.25e-5: where its energy error comes from.
* ``drive_ripple_scale`` — c·τ/2 for τ = 1 at the column's closed-form sound speed (no run).
* ``drive_1000_energy_history`` — the energy balance of ``drive_1000``'s store over time (no run; run
  ``drive_1000`` first with the same ``--work``).
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from hertzian.ensemble import analysis as an
from hertzian.ensemble import reproduce as rp

HERE = Path(__file__).resolve().parent
LOG = HERE / "daggers_cpu.json"
FIGURES = Path("docs/figures")
DEVICE = "cpu"


def sweep_path(group: str) -> Path:
    return rp.default_sweeps_dir() / rp.GROUPS[group].sweep


def open_store(path: Path):
    import xarray as xr

    return xr.open_zarr(path)


def run_group(group: str, overrides: dict, out: Path) -> dict:
    """One paper sweep (with ``overrides``) into a store, as ``hertzian reproduce`` runs it."""
    return rp.run_sweep_group(sweep_path(group), overrides, out, DEVICE)


def run_summary(entry: dict) -> dict:
    keys = ("points", "grains", "steps", "dt", "wall_seconds", "grain_steps_per_second", "energy_error_max",
            "status_counts")
    return {k: entry[k] for k in keys}


# ---- items -----------------------------------------------------------------------------------------


def fig1d_local_slopes(work: Path) -> dict:
    log = json.loads((HERE / "measurements.json").read_text())
    m = log["groups"]["fig1d"]["measurements"]
    v = np.array(m["v_imp"])
    run_date = log["groups"]["fig1d"]["run"]["date"]
    out = {"source": f"measurements.json groups.fig1d.measurements.speed (run of {run_date})",
           "v_imp_midpoints": np.sqrt(v[1:] * v[:-1]).tolist()}
    for l0, c in zip(m["l0"], m["speed"]):
        out[f"l0={l0:g}"] = (np.diff(np.log(c)) / np.diff(np.log(v))).tolist()
    return out


NESTERENKO_IMPACTS = (1e-3, 1e-2, 1e-1)
NESTERENKO_GRAINS = (40, 80)


def nesterenko(work: Path) -> dict:
    """Speed from the head's passage times at two traced grains (sub-sample by a parabola), v_m the largest
    velocity at the deeper one, FWHM its time width × speed; as tests/test_paper.py measures it."""
    from hertzian.ensemble.runner import run_ensemble
    from hertzian.ensemble.scene import scene_from_dict

    out: dict = {"chain": {"grains": 120, "l0": 0.0, "boundary": "walls", "traced": list(NESTERENKO_GRAINS)},
                 "nesterenko_fwhm": an.NESTERENKO_FWHM, "nesterenko_prefactor": float(an.nesterenko_speed(1.0))}
    for dt in (1.25e-4, 2.5e-5):
        scenes = [scene_from_dict({"chain": {"grains": 120, "l0": 0.0}, "excitation": {"impact": v},
                                   "integrator": {"dt": dt, "duration": 10.5},
                                   "record": {"every": 10.5, "traces": list(NESTERENKO_GRAINS), "trace_every": dt}})
                  for v in NESTERENKO_IMPACTS]
        result = run_ensemble(scenes, DEVICE)
        rows = {}
        t = result.trace_t
        for k, v_imp in enumerate(NESTERENKO_IMPACTS):
            v = result.traces["v"][k]
            passage = []
            for column in range(2):
                i = int(np.argmax(v[:, column]))
                passage.append(t[i] + (an._parabolic_peak(v[:, column], i) - i) * (t[1] - t[0]))
            speed = (NESTERENKO_GRAINS[1] - NESTERENKO_GRAINS[0]) / (passage[1] - passage[0])
            v_m = float(v[:, 1].max())
            rows[f"v_imp={v_imp:g}"] = {"speed": speed, "v_m": v_m, "v_m_over_v_imp": v_m / v_imp,
                                        "speed_over_nesterenko": speed / float(an.nesterenko_speed(v_m)),
                                        "fwhm_grains": an.full_width_half_maximum(t, v[:, 1]) * speed}
        out[f"dt={dt:g}"] = {"rows": rows, "energy_error_max": float(np.max(result.energy_error)),
                             "status": result.status.tolist(), "steps": result.steps,
                             "run_wall_seconds": result.wall_seconds}
    a, b = out["dt=0.000125"]["rows"], out["dt=2.5e-05"]["rows"]
    out["dt_relative_differences"] = {key: {q: abs(a[key][q] / b[key][q] - 1) for q in ("speed", "v_m", "fwhm_grains")}
                                      for key in a}
    return out


def load_speeds(work: Path) -> dict:
    """Fig. 1(d)'s scenes at l0 = 1e-5, v_imp = 0.1 and 1e-2; c fitted as in Fig. 1(d) (heads 100…800)."""
    from hertzian.ensemble.runner import run_ensemble
    from hertzian.ensemble.scene import scene_from_dict
    from hertzian.ensemble.sweep import load_sweep, sweep_scenes

    chosen = [s for s in sweep_scenes(load_sweep(sweep_path("fig1d")))
              if math.isclose(s.chain.l0, 1e-5) and any(math.isclose(s.excitation.impact, v) for v in (0.1, 0.01))]
    out: dict = {"sweep": rp.GROUPS["fig1d"].sweep, "l0": 1e-5}
    for surface in ("wall", "load"):
        scenes = []
        for s in chosen:
            data = s.to_dict()
            data["boundary"]["surface"] = surface
            scenes.append(scene_from_dict(data))
        result = run_ensemble(scenes, DEVICE)
        heads = an.head_positions(result.v)
        out[surface] = {f"v_imp={s.excitation.impact:g}": an.pulse_speed(result.t, h, first_grain=100,
                                                                          last_grain=800).slope
                        for s, h in zip(scenes, heads)}
        out[surface + "_run"] = {"energy_error_max": float(np.max(result.energy_error)),
                                 "status": result.status.tolist(), "steps": result.steps,
                                 "run_wall_seconds": result.wall_seconds}
    return out


def fig3_raw_tails(work: Path) -> dict:
    store = work / "fig3.zarr"
    run = run_group("fig3", {}, store)
    out: dict = {"run": run_summary(run)}
    with open_store(store) as ds:
        measured = rp.measure("fig3", ds)
        t = ds.t.values
        for k in range(ds.sizes["l0"]):
            point = ds.isel(l0=k)
            l0 = float(point.l0)
            u, heads = point.u.values, an.head_positions(point.v.values)
            rows = []
            for time_ in rp.TAIL_TIMES[l0]:
                r = int(np.argmin(np.abs(t - time_)))
                raw = an.tail_decay(u[r], heads[r], envelope=1)
                rows.append({"t": float(t[r]), "raw_decay_length": raw.decay_length, "raw_r_squared": raw.r_squared,
                             "raw_points": raw.points})
            key = f"l0={l0:g}"
            out[key] = {"raw": rows,
                        "envelope (as measurements.json)": [{q: f[q] for q in ("t", "decay_length", "r_squared",
                                                                               "decay_over_ct")}
                                                            for f in measured[key]["tail"]]}
    return out


def _head_speed_amplitude(t, v, t_wall: float, grains: int) -> dict:
    """Largest |v| of each snapshot: in-going (head between grain 100 and 0.9 N), reflected (from 5 time
    units after the head reached the wall to the end)."""
    heads = an.head_positions(v)
    beyond = np.flatnonzero(heads > 0.9 * grains)
    stop = beyond[0] if beyond.size else len(t)
    ingoing = [r for r in range(stop) if heads[r] >= 100]
    reflected = [r for r in range(len(t)) if t[r] >= t_wall + 5.0]
    amp = np.max(np.abs(v), axis=-1)
    return {"in_going": [float(amp[ingoing].min()), float(amp[ingoing].max())],
            "in_going_t": [float(t[ingoing[0]]), float(t[ingoing[-1]])],
            "reflected": [float(amp[reflected].min()), float(amp[reflected].max())],
            "reflected_t": [float(t[reflected[0]]), float(t[reflected[-1]])]}


def fig4(work: Path) -> dict:
    full, fine = work / "fig4.zarr", work / "fig4_dt.zarr"
    out: dict = {}
    run = run_group("fig4", {}, full)
    out["run"] = run_summary(run)
    with open_store(full) as ds:
        measured = rp.measure("fig4", ds)
        out["tilt (as measurements.json)"] = measured
        t_coarse, u_coarse, v_coarse = ds.t.values, ds.u.values, ds.v.values   # (record, grain): one point
        out["head_speed_amplitude"] = _head_speed_amplitude(t_coarse, v_coarse, measured["t_wall"], ds.sizes["grain"])
    check = run_group("fig4", {"integrator.dt": 1.25e-5, "integrator.duration": 10.0}, fine)
    out["dt_check_run"] = run_summary(check)
    with open_store(fine) as ds:
        t = ds.t.values
        u, v = ds.u.values, ds.v.values
    n = len(t)
    assert np.allclose(t, t_coarse[:n])
    grains = u.shape[-1]
    speeds = [an.pulse_speed(t, an.head_positions(vv), first_grain=100, last_grain=0.9 * grains).slope
              for vv in (v_coarse[:n], v)]
    out["dt_check"] = {"t_max": float(t[-1]),
                       "max_abs_du_over_max_abs_u": float(np.max(np.abs(u - u_coarse[:n])) / np.max(np.abs(u))),
                       "max_abs_dv_over_max_abs_v": float(np.max(np.abs(v - v_coarse[:n])) / np.max(np.abs(v))),
                       "speed_dt_1.25e-4": speeds[0], "speed_dt_1.25e-5": speeds[1]}
    for grains_, duration in ((300, 13.0), (500, 22.0)):
        store = work / f"fig4_{grains_}.zarr"
        small = run_group("fig4", {"chain.grains": grains_, "integrator.duration": duration}, store)
        with open_store(store) as ds:
            out[f"grains={grains_}"] = {"run": run_summary(small), "tilt": rp.measure("fig4", ds)}
    return out


def fig7_8_dt(work: Path) -> dict:
    stores = {dt: work / f"fig7_8_dt{dt:g}.zarr" for dt in (1.25e-4, 1.25e-5)}
    out: dict = {}
    for dt, store in stores.items():
        out[f"run dt={dt:g}"] = run_summary(run_group("fig7_8", {"integrator.dt": dt}, store))
    with open_store(stores[1.25e-4]) as coarse, open_store(stores[1.25e-5]) as fine:
        assert np.allclose(coarse.t.values, fine.t.values) and np.allclose(coarse.trace_t.values, fine.trace_t.values)
        vc, vf = coarse.v.values, fine.v.values
        tc, tf = coarse.trace_v.values, fine.trace_v.values
        per_chain_snap = np.max(np.abs(vc - vf), axis=(-1, -2)) / np.max(np.abs(vf), axis=(-1, -2))
        per_chain_trace = np.max(np.abs(tc - tf), axis=(-1, -2)) / np.max(np.abs(tf), axis=(-1, -2))
        out["max_abs_dv_over_max_abs_v (snapshots, per chain)"] = per_chain_snap.ravel().tolist()
        out["max_abs_dv_over_max_abs_v (traces, per chain)"] = per_chain_trace.ravel().tolist()
        out["chain_order"] = [f"{m:g}/{c}" for m in coarse.impurity_mass.values for c in coarse.contact.values]
        echoes = {}
        for name, ds in (("dt=1.25e-4", coarse), ("dt=1.25e-5", fine)):
            table = an.echo_table(ds, traced=0, fraction=0.2)
            echoes[name] = {key: {"arrival": b.arrival_time, "amplitude": b.amplitude, "leading_sign": b.leading_sign,
                                  "peak_sign": b.peak_sign} for key, b in table.items()}
        out["echo at grain 0 (threshold 20 %)"] = echoes
        out["echo relative differences"] = {
            key: {q: abs(echoes["dt=1.25e-4"][key][q] / echoes["dt=1.25e-5"][key][q] - 1)
                  for q in ("arrival", "amplitude")}
            for key in echoes["dt=1.25e-4"]}
    return out


def drive_1000(work: Path) -> dict:
    runs = rp.run_drive_group(sweep_path("fig9_10"), work, DEVICE, quick=False, grains=1000)
    main, check = runs
    out: dict = {"command_equivalent": "hertzian reproduce --figure fig9_10 --drive-grains 1000 --device cpu",
                 "taus": main["taus"], "grains": main["grains"], "duration": main["duration"], "steps": main["steps"],
                 "dt": main["dt"], "kernel": main["kernel"], "run_wall_seconds": main["wall_seconds"],
                 "grain_steps_per_second": main["grain_steps_per_second"], "energy_error": main["energy_error"],
                 "status": main["status"], "dt_check": {k: check[k] for k in check if k not in ("store", "name")}}
    with open_store(work / "fig9_10.zarr") as ds:
        lag = ds.window_lag.values
        starts = np.flatnonzero(lag == 0)
        out["paper_times_scaled"] = ds.window_t.values[starts].tolist()
        ke = ds.ke_window.values
        # grain 0 is the driven grain (its mean kinetic energy is set by the drive: ½ (2π A/τ)² / 2)
        out["largest_window_mean_ke_per_grain (grains 1…)"] = {f"tau={tau:g}": [float(ke[i, s, 1:].max())
                                                                              for s in starts]
                                                             for i, tau in enumerate(ds.tau.values)}
        out["window_mean_ke_of_driven_grain"] = {f"tau={tau:g}": [float(ke[i, s, 0]) for s in starts]
                                                 for i, tau in enumerate(ds.tau.values)}
        out["mean_window_ke_in_grains_1_to_99"] = {f"tau={tau:g}": [float(ke[i, s, 1:100].mean()) for s in starts]
                                                       for i, tau in enumerate(ds.tau.values)}
        out["mean_window_ke_below_grain_100"] = {f"tau={tau:g}": [float(ke[i, s, 100:].mean()) for s in starts]
                                                 for i, tau in enumerate(ds.tau.values)}
        persistence = {}
        for i, tau in enumerate(ds.tau.values):
            rows = main["standing_wave"][i][:-1]
            persistence[f"tau={tau:g}"] = [{"t": r["t"],
                                            "mean_correlation_lags_1.5_to_10.5": float(np.mean(r["correlation"][1:])),
                                            "correlation": r["correlation"], "node_count": r["node_count"],
                                            "node_spacing": r["node_spacing"], "node_shift": r["node_shift"]}
                                           for r in rows]
        out["standing_wave"] = persistence
        for figure in ("fig9", "fig10"):
            from hertzian.ensemble.plot import plot_figure

            png = FIGURES / f"{figure}_reduced_cpu.png"
            plot_figure(ds, figure, png)
            out.setdefault("figures", {})[figure] = (f"hertzian plot {work / 'fig9_10.zarr'} --figure {figure} "
                                                     f"--out {png}")
    return out


def drive_tau1_energy(work: Path) -> dict:
    """Where the energy error of the 1000-grain τ = 1 column comes from: the same column (records every 0.5)
    to t = 78 with the per-step kernel and the fused sweep kernel at dt = 1.25e-4, and with the sweep
    kernel at dt = 1.25e-5; energy error and largest |v| at every record."""
    from hertzian.ensemble.model import build_model
    from hertzian.ensemble.devices import init_warp
    from hertzian.ensemble.runner import Runner
    from hertzian.ensemble.sweep import load_sweep, sweep_scenes

    init_warp()
    out: dict = {"grains": 1000, "tau": 1.0, "duration": 78.0}
    for label, dt, kernel in (("dt=1.25e-4 step", 1.25e-4, "step"), ("dt=1.25e-4 sweep", 1.25e-4, "sweep"),
                              ("dt=1.25e-5 sweep", 1.25e-5, "sweep")):
        sweep = load_sweep(sweep_path("fig9_10"), {"chain.grains": 1000, "integrator.duration": 78.0,
                                                   "integrator.dt": dt, "record.every": 0.5})
        scene = [s for s in sweep_scenes(sweep) if s.excitation.drive_period == 1.0]
        result = Runner(build_model(scene, DEVICE), kernel=kernel).run()
        drift, scale = an.energy_drift(result.energy, result.work)
        out[label] = {"kernel": result.kernel, "steps": result.steps, "run_wall_seconds": result.wall_seconds,
                      "energy_error_max": float(np.max(result.energy_error)), "status": result.status.tolist(),
                      "t": result.t.tolist(), "energy_error_by_record (" + scale + ")": np.abs(drift[0]).tolist(),
                      "largest_abs_v_by_record": np.max(np.abs(result.v[0]), axis=-1).tolist()}
    return out


def drive_ripple_scale(work: Path) -> dict:
    """Half the τ = 1 drive's wavelength, c·τ/2, at the closed-form column sound speed (g = 1, no run): the
    scale to compare node spacings of the driven columns with."""
    depths = [500.0, 750.0, 1000.0, 5000.0, 7500.0, 10000.0]
    half = an.column_sound_speed(np.array(depths), gravity=1.0, a=5657.0) * 1.0 / 2
    return {"tau": 1.0, "depth": depths, "c_tau_over_2_grains": half.tolist()}


def drive_1000_energy_history(work: Path) -> dict:
    """The energy balance of ``drive_1000``'s run (its store, ``--work``/fig9_10.zarr, no new run): where
    |E − E0 − W| / max|W| changes by more than 1e-6 of max|W| from one sample to the next, and its largest
    value before and after the largest such jump."""
    with open_store(work / "fig9_10.zarr") as ds:
        t, energy, work_ = ds.energy_t.values, ds.energy.values, ds.work.values
        out: dict = {"samples": int(t.size), "t_last": float(t[-1])}
        for i, tau in enumerate(ds.tau.values):
            scale = float(np.max(np.abs(work_[i])))
            balance = (energy[i] - energy[i, 0] - work_[i]) / scale
            steps = np.abs(np.diff(balance))
            k = int(np.argmax(steps))
            out[f"tau={tau:g}"] = {
                "max_abs_W": scale, "energy_error": float(np.max(np.abs(balance))),
                "largest_jump": {"between_t": [float(t[k]), float(t[k + 1])], "relative": float(steps[k]),
                                 "energy_change": float(energy[i, k + 1] - energy[i, k]),
                                 "work_change": float(work_[i, k + 1] - work_[i, k])},
                "energy_error_before_it": float(np.max(np.abs(balance[:k + 1]))),
                "energy_error_after_it": float(np.max(np.abs(balance[k + 1:] - balance[k + 1]))),
                "jumps_over_1e-6": [[float(t[j]), float(t[j + 1]), float(steps[j])]
                                    for j in np.flatnonzero(steps > 1e-6)],
                "largest_abs_v_in_snapshots": float(np.max(np.abs(ds.v.values[i]))),
            }
    return out


ITEMS = {"fig1d_local_slopes": fig1d_local_slopes, "nesterenko": nesterenko, "load_speeds": load_speeds,
         "fig3_raw_tails": fig3_raw_tails, "fig4": fig4, "fig7_8_dt": fig7_8_dt, "drive_1000": drive_1000,
         "drive_tau1_energy": drive_tau1_energy, "drive_ripple_scale": drive_ripple_scale,
         "drive_1000_energy_history": drive_1000_energy_history}


def main() -> None:
    import warp as wp

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=list(ITEMS), default=list(ITEMS))
    parser.add_argument("--work", type=Path, default=Path("out/daggers"))
    args = parser.parse_args()
    args.work.mkdir(parents=True, exist_ok=True)
    log = json.loads(LOG.read_text()) if LOG.exists() else {"items": {}}
    ran: dict = {}
    log.update({"script": "docs/logs/reproduction/daggers.py", "device": DEVICE,
                "device_name": wp.get_device(DEVICE).name, "cpu_count": rp._cpu_count(),
                "platform": platform.platform(), "warp_version": wp.config.version,
                "note": "the development machine's CPU (2 cores), shared with other jobs; float64, gear4"})
    for name in args.only:
        command = " ".join(["python", "docs/logs/reproduction/daggers.py", "--only", name]
                           + (["--work", str(args.work)] if args.work != Path("out/daggers") else []))
        date = datetime.now(timezone.utc).isoformat(timespec="seconds")
        start = time.perf_counter()
        values = ITEMS[name](args.work)
        wall = time.perf_counter() - start
        ran[name] = {"command": command, "date": date, "wall_seconds": wall, "values": values}
        if LOG.exists():   # another invocation may have written other items meanwhile: keep them
            log["items"] = json.loads(LOG.read_text())["items"]
        log["items"].update(ran)
        log["total_wall_seconds"] = sum(item["wall_seconds"] for item in log["items"].values())
        LOG.write_text(json.dumps(rp.finite(log), indent=1) + "\n")
        print(f"{name}: {wall:.1f} s", flush=True)
    print(f"wrote {LOG.relative_to(Path.cwd()) if LOG.is_relative_to(Path.cwd()) else LOG.name}", file=sys.stderr)


if __name__ == "__main__":
    main()
