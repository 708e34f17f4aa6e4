"""Error against cost at representative points of the GPU sweep (sweeps/gpu_10k.toml), events auto vs off.

Reads the work–precision logs ``docs/accuracy/gpu10k_<point>.json`` (``hertzian accuracy … --json``, one
record per run; the commands are in docs/accuracy/README.md) and prints, per point and step:

* ``error``: max over snapshots and grains |u − u_ref| / max |u_ref| against the study's gear6 float64
  reference (``*``: reference_limited, i.e. within 10× of the reference's Richardson error estimate, so the
  number is an upper bound set by the reference, not a resolved error);
* ``energy``: the run's own energy error max_t |E(t) − E(0)| / E_inj;
* ``CPU s``: the measured wall seconds of that run on the CPU (one chain, ``sweep`` kernel);
* ``H100 s (est.)``: an ESTIMATE, not a measurement, of the H100 kernel time of the whole 10^4-chain sweep at
  that step: gpu_10k is 5e11 grain-steps at dt = 5e-5 (∝ 1/dt), divided by the two throughputs measured for
  the fused tile kernel on one H100 (docs/gpu_logs/h100_2026-11-23b/event_variants.json): 1.9e10
  grain-steps/s with events = auto, 3.8e11 with events = off. Those throughputs were measured on the whole
  sweep (all 10^4 points in one launch), so the estimate is the same for every point: it prices a step
  choice for the sweep, not for one chain.

Then, per point, the cheapest studied plain step (events off) that matches each events-auto row, on the
position error and on the energy error, with both estimated H100 times ("none" where no studied plain step
reaches the events-auto value; a reference-limited events-auto error is matched against its bound).

Finally, from ``gpu10k_openings.json`` (docs/accuracy/gpu10k_openings.py) where present: whether event code
is compiled for the point, how many contacts open, and the sampled share of grain-steps taken as event steps.

Usage (from the repository root; numpy only):

    python docs/accuracy/gpu10k_table.py > docs/accuracy/gpu10k_table.txt
    python docs/accuracy/gpu10k_table.py docs/accuracy/gpu10k_vimp1e-1_l01e-6_fine.json   # other logs
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

HERE = Path(__file__).parent
POINTS = ["vimp1e-3_l01e-6", "vimp1e-3_l01e-3", "vimp1e-1_l01e-6", "vimp1e-1_l01e-3", "vimp1e-2_l03.05e-5"]
SWEEP_GRAIN_STEPS = 5e11
"""gpu_10k: 10^4 chains × 500 grains × 1e5 steps (duration 5 at dt = 5e-5)."""
SWEEP_DT = 5e-5
H100_GRAIN_STEPS_PER_SECOND = {"auto": 1.9e10, "off": 3.8e11}
"""Measured on one H100, fused tile kernel, whole gpu_10k sweep (docs/gpu_logs/h100_2026-11-23b)."""


def h100_estimate(dt: float, events: str) -> float:
    """Estimated H100 kernel seconds of the whole gpu_10k sweep at step ``dt`` (see the module docstring)."""
    return SWEEP_GRAIN_STEPS * (SWEEP_DT / dt) / H100_GRAIN_STEPS_PER_SECOND[events]


def fmt(value: float, limited: bool = False) -> str:
    return f"{value:.2e}{'*' if limited else ' '}"


def point_table(name: str, records: list[dict]) -> list[str]:
    first = records[0]
    lines = [f"## {name}: reference gear6 float64 at dt = {first['reference_dt']:g}, "
             f"estimated reference error {first['reference_error']:.1e} (kernel {first['kernel']})",
             f"{'dt':>9} {'events':>6} {'error':>10} {'energy':>10} {'CPU s':>7} {'H100 s (est.)':>14}"]
    for r in sorted(records, key=lambda r: (r["events"] != "auto", -r["dt"])):
        lines.append(f"{r['dt']:>9g} {r['events']:>6} {fmt(r['error'], r['reference_limited']):>10} "
                     f"{fmt(r['energy_error']):>10} {r['seconds']:>7.2f} {h100_estimate(r['dt'], r['events']):>14.2f}")
    auto = {r["dt"]: r for r in records if r["events"] == "auto"}
    off = {r["dt"]: r for r in records if r["events"] == "off"}
    same = all(d in off and auto[d]["error"] == off[d]["error"] and auto[d]["energy_error"] == off[d]["energy_error"]
               for d in auto)
    if same:
        lines.append("events auto and off give identical errors at every step: no event code runs at this point.")
        return lines
    lines.append("cheapest studied plain step (events off) reaching each events-auto value, estimated H100 s "
                 "(auto → off):")
    for measure, key in (("error", "error"), ("energy", "energy_error")):
        bounded = key == "error"  # only the position error is measured against the reference
        for dt in sorted(auto, reverse=True):
            a = auto[dt]
            target = a[key]
            head = f"  {measure:>6} auto dt = {dt:<8g} {fmt(target, bounded and a['reference_limited'])}"
            meeting = [r for r in off.values() if r[key] <= target and r["status"] == 0]
            if meeting:
                best = max(meeting, key=lambda r: r["dt"])
                t_auto, t_off = h100_estimate(dt, "auto"), h100_estimate(best["dt"], "off")
                verdict = "off cheaper" if t_off < t_auto else "auto cheaper"
                matched = fmt(best[key], bounded and best["reference_limited"])
                lines.append(f"{head} → off dt = {best['dt']:<8g} {matched}"
                             f" {t_auto:7.2f} s → {t_off:6.2f} s  ({verdict}, ×{t_auto / t_off:.1f})")
            else:
                finest = min(off)
                lines.append(f"{head} → none: off at the finest studied dt = {finest:g} gives {fmt(off[finest][key])}"
                             f" ({h100_estimate(dt, 'auto'):.2f} s with events)")
    return lines


def openings_table(path: Path) -> list[str]:
    data = json.loads(path.read_text())
    lines = [f"## contacts that open ({path.name}: {data['command']}; {data['device']}, Warp {data['warp']}, "
             f"{data['date']}; gear4 events auto dt = {data['points'][0]['dt']:g}, snapshots every "
             f"{data['points'][0]['snapshot_every']:g})",
             f"{'point':>20} {'event code':>10} {'opened':>12} {'flagged grain-steps':>20} {'grains flagged':>14} "
             f"{'grains moved':>12}"]
    for p in data["points"]:
        lines.append(f"{p['name']:>20} {'yes' if p['event_code'] else 'no':>10} "
                     f"{p['contacts_opened']:>5}/{p['contacts']:<6} {p['flagged_fraction']:>20.2%} "
                     f"{p['grains_ever_flagged']:>14} {p['grains_moved']:>12}")
    return lines


def main(paths: list[str]) -> None:
    files = [Path(p) for p in paths] or [HERE / f"gpu10k_{name}.json" for name in POINTS]
    print("gpu_10k points: gear4 float64, 500 grains between walls, duration 5, CPU of this machine (2 cores, shared),")
    print("one chain per run. error = max|u − u_ref|/max|u_ref| (* reference-limited: an upper bound); energy =")
    print("max|E(t) − E(0)|/E_inj; CPU s measured. H100 s (est.) is an ESTIMATE for the whole 10^4-chain sweep from")
    print("two measured H100 tile-kernel throughputs only: 1.9e10 grain-steps/s events auto, 3.8e11 events off;")
    print("5e11 grain-steps at dt = 5e-5, ∝ 1/dt.")
    for path in files:
        print()
        print("\n".join(point_table(path.stem.removeprefix("gpu10k_"), json.loads(path.read_text()))))
    openings = HERE / "gpu10k_openings.json"
    if not paths and openings.exists():
        print()
        print("\n".join(openings_table(openings)))


if __name__ == "__main__":
    main(sys.argv[1:])
