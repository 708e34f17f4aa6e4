"""Reduce the full-size Figs. 9-10 response runs (sweeps/drive_fig9_10_gpu.toml, t = 5 000) to one JSON log.

Usage, from the repository root (the package importable as ``hertzian``), after the sweeps of docs/drive.md
("Settling Figs. 9-10"):
    python docs/logs/fig9_10_settle.py tau10.zarr tau1.zarr [--half tau10_half.zarr tau1_half.zarr] > fig9_10_settle.json
Per store (τ) and point (A): per response window the standing-wave ratio of |V_1| and its node count, the
node drift between successive windows, the correlation of successive window-averaged kinetic-energy profiles
(smoothed over 25 grains), the driver-open fraction, the driver's mean power over [0, 1000], [1000, 2500],
[2500, 5000], the stroboscopic label of the traced grains (all of the run, and t >= 2500), the energy error.
With --half (the same runs at dt/2 over the first windows): the per-window numbers of both, and the time the
traced grains' trajectories part (velocities differing by more than 1 % of their range).
"""

import argparse
import json
import math
import sys
from datetime import datetime, timezone

import numpy as np
import xarray as xr

from hertzian.ensemble import analysis as an
from hertzian.ensemble.analysis.drive import point_scene_value


def _smooth(p: np.ndarray, n: int = 25) -> np.ndarray:
    return np.convolve(p, np.ones(n) / n, mode="same")


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    a, b = _smooth(a), _smooth(b)
    if np.std(a) == 0 or np.std(b) == 0:
        return math.nan
    return float(np.corrcoef(a, b)[0, 1])


def _mean_power(t: np.ndarray, work: np.ndarray, lo: float, hi: float) -> float:
    inside = np.flatnonzero((t >= lo - 1e-9) & (t <= hi + 1e-9))
    if inside.size < 2:
        return math.nan
    i, j = inside[0], inside[-1]
    return float((work[j] - work[i]) / (t[j] - t[i]))


def per_window(point) -> dict:
    v1 = np.abs(point.response.sel(harmonic=1).values)        # (window, grain)
    counts, drift = an.node_drift(v1)
    ke = point.window_ke.values
    return {
        "window_start": point.window_start.values.tolist(),
        "swr": [an.standing_wave_ratio(v) for v in v1],
        "node_count": np.asarray(counts).tolist(),
        "node_drift": np.asarray(drift).tolist(),
        "ke_correlation_next": [_corr(ke[w], ke[w + 1]) for w in range(len(ke) - 1)],
        "ke_correlation_first": [_corr(ke[0], ke[w]) for w in range(len(ke))],
        "driver_open": point.driver_open.values.tolist(),
    }


def strobe(point, since: float) -> str:
    period = point_scene_value(point, "excitation.drive_period")
    samples = an.strobe_samples(point.trace_t.values,
                                np.concatenate([point.trace_u.values, point.trace_v.values], axis=-1),
                                period, since=since)
    return an.LABELS[an.strobe_label(samples)] + f" ({len(samples)} samples)"


def parting_time(a, b) -> float | None:
    n = min(a.trace_t.size, b.trace_t.size)
    ta, tb = a.trace_t.values[:n], b.trace_t.values[:n]
    if not np.allclose(ta, tb):
        return None
    va, vb = a.trace_v.values[:n], b.trace_v.values[:n]
    scale = float(np.ptp(va)) or 1.0
    apart = np.flatnonzero(np.abs(va - vb).max(axis=-1) > 1e-2 * scale)
    return float(ta[apart[0]]) if apart.size else None


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("stores", nargs="+")
    parser.add_argument("--half", nargs="*", default=[])
    args = parser.parse_args()
    out = {"date": datetime.now(timezone.utc).isoformat(timespec="seconds"), "command": " ".join(sys.argv),
           "runs": []}
    for k, path in enumerate(args.stores):
        ds = xr.open_zarr(path)
        half = xr.open_zarr(args.half[k]) if k < len(args.half) else None
        dims = [str(d) for d in ds.status.dims]
        for index in np.ndindex(*[int(ds.sizes[d]) for d in dims]):
            where = dict(zip(dims, index))
            point = ds.isel(where)
            t, work = point.t.values, point.work.values
            row = {"store": path, **{d: float(ds[d].values[i]) for d, i in where.items()},
                   "drive_period": point_scene_value(point, "excitation.drive_period"),
                   "drive_amplitude": point_scene_value(point, "excitation.drive_amplitude"),
                   "status": int(point.status), "energy_error": float(point.energy_error),
                   "mean_power": {f"{lo:g}-{hi:g}": _mean_power(t, work, lo, hi)
                                  for lo, hi in ((0, 1000), (1000, 2500), (2500, 5000))},
                   "strobe_all": strobe(point, 0.0), "strobe_late": strobe(point, 2500.0),
                   "windows": per_window(point)}
            if half is not None:
                hp = half.isel(where)
                row["half_dt"] = {"windows": per_window(hp), "energy_error": float(hp.energy_error),
                                  "trajectories_part_at": parting_time(point, hp)}
            out["runs"].append(row)
    json.dump(out, sys.stdout, indent=1, default=lambda o: None)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
