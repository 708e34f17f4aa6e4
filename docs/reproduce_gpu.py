"""Full-size runs of Sen, Manciu & Wright (1998) that need a GPU, in one process.

Figs. 9-10: a 10 000-grain column compacted by gravity (g = 1), bottom grain fixed, surface grain
driven as u_0 = 2 sin(2πt/τ), for both readings of the period — τ = 10 (the text) and τ = 1
(Fig. 9's caption: 2 sin 2πt/1.012e-3 s, time in units of 1.012e-3 s) — to t = 492.75, with the
paper's own step for these figures (1.265e-7 s ≙ 1.25e-4 program units). Instead of storing every
snapshot, the run keeps velocity profiles only inside averaging windows of 1.5 time units (Fig. 9's
caption) at the paper's times t = 60, 132, 204, 276, 492 and at seven consecutive windows after each
(lags 1.5 … 10.5: how long the pattern persists), sampled every 0.01, plus coarse snapshots every
2 time units.

Checks: the energy balance of each run (|E − E0 − W| / max|W|, W the driver's work), and a
dt = 1.25e-5 rerun of both chains up to the first window (t = 60.75), compared window by window.

Also (unless --only-drive) every other paper sweep (sweeps/paper_*.toml) at full size, logging
wall time, energy error and the headline numbers (pulse speeds, α, depth law, echoes), to put GPU
numbers next to the CPU runs of docs/reproduction.md.

Usage (repository root; a few minutes on an H100, see the estimate in docs/reproduction.md):
    python docs/reproduce_gpu.py --out-dir gpu_out --device cuda
    hertzian plot gpu_out/fig9_10.zarr --figure fig9 --out docs/figures/fig9.png
    hertzian plot gpu_out/fig9_10.zarr --figure fig10 --out docs/figures/fig10.png
Writes gpu_out/fig9_10.zarr, gpu_out/fig9_10_dt_check.zarr and gpu_out/log.json.
``--grains N`` runs a shorter column with the paper's times scaled by (N/10^4)^(5/6) (the travel time
of a pulse down a compacted column grows as N^(5/6)); docs/reproduction.md's reduced CPU preview is
``--grains 1000 --device cpu --only-drive``. ``--quick`` runs a 300-grain, t ≤ 6 version (for testing
the script on a CPU).
"""

from __future__ import annotations

import argparse
import json
import math
import socket
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import warp as wp  # noqa: E402

from ensemble import analysis as an  # noqa: E402
from ensemble.model import build_model  # noqa: E402
from ensemble.runner import Runner, energy_errors  # noqa: E402
from ensemble.sweep import load_sweep, sweep_scenes  # noqa: E402

SWEEPS = ROOT / "sweeps"
WINDOW = 1.5
"""Averaging window [time units] (Fig. 9's caption)."""
PAPER_TIMES = np.array([60.0, 132.0, 204.0, 276.0, 492.0])
"""Times of Figs. 9(a)-(e) and 10(a)-(e) [time units]."""
LAGS = WINDOW * np.arange(8)
"""Each paper time's window and the seven consecutive windows after it [time units]."""
SAMPLE_EVERY = 0.01
"""Spacing of the velocity samples inside a window [time units]: a pulse moves ~1 grain in between."""
COARSE_EVERY = 2.0
"""Spacing of the coarse snapshots [time units]."""


def drive_scenes(grains: int, duration: float, dt: float):
    """The two driven columns (τ = 10 and τ = 1) of sweeps/paper_fig9_10.toml at the given size."""
    sweep = load_sweep(SWEEPS / "paper_fig9_10.toml", {"chain.grains": grains, "integrator.duration": duration,
                                                         "integrator.dt": dt, "record.every": duration})
    return sweep, sweep_scenes(sweep)


def run_driven(scenes, device: str, centres: np.ndarray, *, coarse_every: float) -> dict:
    """Integrate the driven columns, sampling velocities inside the windows; returns arrays and numbers."""
    model = build_model(list(scenes), device)
    runner = Runner(model)
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

    wp.load_module(runner.stepper.kernel.module, device=model.device)  # compile before the clock starts
    wp.load_module(runner.record.module, device=model.device)
    wp.synchronize_device(model.device)
    start = time.perf_counter()
    step = 0
    for mark in sorted(marks):
        if mark > step:
            runner.advance(mark - step)
            step = mark
        runner.reduce(step)
        velocity = runner.current.x[1].numpy() / dt
        energy.append(runner.energy.numpy().copy())
        work.append(runner.work.numpy().copy())
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
    status = runner.status.numpy()
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
        "status": status,
        "wall_seconds": wall,
        "steps": step,
        "device": str(model.device),
        "grain_steps_per_second": chains * grains * step / max(wall, 1e-12),
    }


def write_driven(path: Path, sweep, scenes, centres: np.ndarray, result: dict, block: np.ndarray,
                 lag: np.ndarray) -> None:
    """A Zarr store readable by xarray.open_zarr and `hertzian plot --figure fig9|fig10`."""
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
    ds.to_zarr(path, mode="w", consolidated=True)


def standing_wave_numbers(ke_window: np.ndarray, paper_times: np.ndarray, block: np.ndarray) -> list[dict]:
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


def other_sweeps(device: str) -> list[dict]:
    """Every other paper sweep at full size: wall time, energy error, headline numbers."""
    from ensemble.runner import run_ensemble

    records = []
    for path in sorted(SWEEPS.glob("paper_*.toml")):
        if path.stem == "paper_fig9_10":
            continue
        sweep = load_sweep(path)
        scenes = sweep_scenes(sweep)
        result = run_ensemble(scenes, device)
        rec = {"sweep": path.name, "device": result.device, "chains": result.chain_count,
               "grains": result.grain_count, "steps": result.steps, "dt": scenes[0].integrator.dt,
               "wall_seconds": result.wall_seconds, "grain_steps_per_second": result.grain_steps_per_second,
               "energy_error_max": float(np.max(result.energy_error)), "status": result.status.tolist()}
        if "v" in result.fields:
            heads = an.head_positions(result.v)
            n = result.grain_count
            rec["pulse_speed"] = [an.pulse_speed(result.t, h, first_grain=0.1 * n, last_grain=0.8 * n).slope
                                  for h in heads]
        records.append(rec)
        print(f"{path.name}: {result.wall_seconds:.1f} s, energy error {rec['energy_error_max']:.2e}", flush=True)
    return records


def _finite(value):
    """NaN/inf → None, so the log is standard JSON."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out-dir", type=Path, default=Path("gpu_out"))
    parser.add_argument("--device", default=None, help="cuda (default when present) or cpu")
    parser.add_argument("--quick", action="store_true", help="300 grains, t ≤ 6: test the script on a CPU")
    parser.add_argument("--grains", type=int, default=10000,
                        help="column length; the paper's times are scaled by (N/10^4)^(5/6)")
    parser.add_argument("--only-drive", action="store_true", help="skip the other paper sweeps")
    args = parser.parse_args()
    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    device = args.device or ("cuda" if wp.is_cuda_available() else "cpu")
    args.out_dir.mkdir(parents=True, exist_ok=True)
    log: dict = {"host": socket.gethostname(), "device": device, "warp": wp.config.version, "runs": []}
    begin = time.perf_counter()

    if args.quick:
        grains, paper_times = 300, np.array([2.0, 4.0])
    else:
        grains = args.grains
        paper_times = np.round(PAPER_TIMES * (grains / 10000.0) ** (5.0 / 6.0), 3)
    check_until = paper_times[0]
    block = np.repeat(np.arange(len(paper_times)), len(LAGS))
    lag = np.tile(LAGS, len(paper_times))
    centres = paper_times[block] + lag
    duration = float(centres[-1] + WINDOW)

    # the full-size runs at the paper's step for these figures
    sweep, scenes = drive_scenes(grains, duration, 1.25e-4)
    result = run_driven(scenes, device, centres, coarse_every=COARSE_EVERY if not args.quick else 0.5)
    write_driven(args.out_dir / "fig9_10.zarr", sweep, scenes, centres, result, block, lag)
    log["runs"].append({"name": "fig9_10", "grains": grains, "dt": 1.25e-4, "duration": duration,
                        "taus": [s.excitation.drive_period for s in scenes], "device": result["device"],
                        "steps": result["steps"], "wall_seconds": result["wall_seconds"],
                        "grain_steps_per_second": result["grain_steps_per_second"],
                        "energy_error": result["energy_error"].tolist(), "status": result["status"].tolist(),
                        "standing_wave": standing_wave_numbers(result["ke_window"], paper_times, block)})
    print(f"fig9_10: {result['wall_seconds']:.1f} s, energy error {result['energy_error']}", flush=True)

    # dt check: dt = 1.25e-5 up to the first window
    first = centres[centres <= check_until]
    _, fine_scenes = drive_scenes(grains, float(first[-1] + WINDOW), 1.25e-5)
    fine = run_driven(fine_scenes, device, first, coarse_every=float(first[-1] + WINDOW))
    write_driven(args.out_dir / "fig9_10_dt_check.zarr", sweep, fine_scenes, first, fine, block[:len(first)],
                 lag[:len(first)])
    coarse_ke = result["ke_window"][:, :len(first)]
    difference = np.linalg.norm(fine["ke_window"] - coarse_ke, axis=-1) / np.linalg.norm(fine["ke_window"], axis=-1)
    log["runs"].append({"name": "fig9_10_dt_check", "grains": grains, "dt": 1.25e-5,
                        "duration": float(first[-1] + WINDOW), "device": fine["device"], "steps": fine["steps"],
                        "wall_seconds": fine["wall_seconds"], "energy_error": fine["energy_error"].tolist(),
                        "window_t": first.tolist(),
                        "relative_l2_difference_of_window_ke(dt=1.25e-4 vs 1.25e-5)": difference.tolist()})
    print(f"dt check: {fine['wall_seconds']:.1f} s, relative KE-profile difference {difference.tolist()}", flush=True)

    if not args.only_drive and not args.quick and grains == 10000:
        log["sweeps"] = other_sweeps(device)
    log["total_seconds"] = time.perf_counter() - begin
    (args.out_dir / "log.json").write_text(json.dumps(_finite(log), indent=1, default=float))
    print(f"wrote {args.out_dir}/fig9_10.zarr, fig9_10_dt_check.zarr, log.json in {log['total_seconds']:.0f} s")


if __name__ == "__main__":
    main()
