"""The table of docs/drive.md ("Settling Figs. 9-10") from docs/logs/fig9_10_settle.json.

    python docs/logs/fig9_10_settle_table.py docs/logs/fig9_10_settle.json > docs/logs/fig9_10_settle_table.txt
Window statistics (medians over the response windows; the standing-wave ratio over windows where it is
finite) at dt over the whole run and, side by side, at dt and dt/2 over the windows both cover (t <= 1000).
"""

import json
import sys

import numpy as np


def med(x):
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return float(np.median(x)) if x.size else float("nan")


def stats(w, n=None):
    s = slice(0, n)
    return (med(w["swr"][s]), med(w["node_drift"][s]), med(w["ke_correlation_next"][s]), med(w["driver_open"][s]))


def main(path):
    d = json.load(open(path))
    print("| τ | A | energy error (dt; dt/2) | strobe label, all / t ≥ 2500 | trajectories part (dt vs dt/2) at t "
          "| mean driver power 0–1000 / 1000–2500 / 2500–5000 | swr | node drift [grains] | KE corr. of successive windows "
          "| driver open | t ≤ 1000 at dt: swr, drift, corr, open | t ≤ 1000 at dt/2: the same |")
    print("| " + " | ".join(["---"] * 12) + " |")
    for r in d["runs"]:
        w, h = r["windows"], r["half_dt"]["windows"]
        n = len(h["swr"])
        a, b, c = stats(w), stats(w, n), stats(h)
        p = r["mean_power"]
        part = r["half_dt"]["trajectories_part_at"]
        print(f"| {r['drive_period']:g} | {r['drive_amplitude']:g} | {r['energy_error']:.1e}; {r['half_dt']['energy_error']:.1e} "
              f"| {r['strobe_all'].split(' (')[0]} / {r['strobe_late'].split(' (')[0]} | {'never (t ≤ 1000)' if part is None else f'{part:g}'} "
              f"| {p['0-1000']:.3g} / {p['1000-2500']:.3g} / {p['2500-5000']:.3g} "
              f"| {a[0]:.3g} | {a[1]:.3g} | {a[2]:.3f} | {a[3]:.3f} "
              f"| {b[0]:.3g}, {b[1]:.3g}, {b[2]:.3f}, {b[3]:.3f} | {c[0]:.3g}, {c[1]:.3g}, {c[2]:.3f}, {c[3]:.3f} |")


if __name__ == "__main__":
    main(sys.argv[1])
