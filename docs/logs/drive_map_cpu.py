"""Reduce the worked CPU response map (docs/drive.md) and its dt-halving check into one JSON log.

Usage, from the repository root, after the two sweeps of docs/drive.md ("A worked map"):
    python docs/logs/drive_map_cpu.py drive_map.zarr drive_map_half.zarr > docs/logs/drive_map_cpu.json
Per point: the map's numbers at dt and dt/2, their relative change, whether the label agrees, and when
the two trajectories part (the first trace sample where the traced grains' velocities differ by more
than 1 % of their range over the run; null if they never do).
"""

import json
import math
import platform
import subprocess
import sys
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import xarray as xr

from ensemble import analysis as an


def parting_time(a, b) -> float | None:
    va, vb = a.trace_v.values, b.trace_v.values
    scale = float(np.ptp(va)) or 1.0
    apart = np.flatnonzero(np.abs(va - vb).max(axis=-1) > 1e-2 * scale)
    return float(a.trace_t.values[apart[0]]) if apart.size else None


def main(full: str, half: str) -> None:
    a, b = xr.open_zarr(full), xr.open_zarr(half)
    ma, mb = an.response_map(a), an.response_map(b)
    dims = ma["dims"]
    points = []
    for index in np.ndindex(*ma["label"].shape):
        where = {d: float(ma["coords"][d][i]) for d, i in zip(dims, index)}
        row = {**where}
        for m in an.MAP_METRICS:
            x, y = float(ma[m][index]), float(mb[m][index])
            row[m] = x
            row[m + "_half_dt"] = y
            if m != "label":
                row[m + "_change"] = abs(x - y) / abs(y) if y not in (0.0,) and math.isfinite(y) else None
        row["label_name"] = an.LABELS[int(ma["label"][index])]
        row["label_agrees"] = int(ma["label"][index]) == int(mb["label"][index])
        pa, pb = a.isel(dict(zip(dims, index))), b.isel(dict(zip(dims, index)))
        row["trajectories_part_at"] = parting_time(pa, pb)
        row["energy_error"] = float(pa.energy_error)
        row["energy_error_half_dt"] = float(pb.energy_error)
        points.append(row)
    prov = json.loads(json.dumps(a.attrs.get("provenance", {}), default=str))
    out = {
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "device": f"CPU of the development machine ({platform.processor() or platform.machine()}, 2 cores, "
                  "shared with other jobs); no GPU this session",
        "commit": subprocess.run(["git", "-C", str(Path(__file__).resolve().parent), "rev-parse", "--short", "HEAD"],
                                 capture_output=True, text=True).stdout.strip(),
        "commands": ["hertzian sweep sweeps/drive_map.toml --out drive_map.zarr --device cpu",
                     "hertzian sweep sweeps/drive_map.toml --set integrator.dt=6.25e-5 --out drive_map_half.zarr "
                     "--device cpu",
                     f"python docs/logs/drive_map_cpu.py {full} {half}"],
        "provenance_dt": prov,
        "wall_seconds": float(np.nanmax(a.wall_seconds.values)) * int(a.status.size),
        "wall_seconds_half_dt": float(np.nanmax(b.wall_seconds.values)) * int(b.status.size),
        "points": points,
    }
    json.dump(out, sys.stdout, indent=1, default=lambda o: None)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
