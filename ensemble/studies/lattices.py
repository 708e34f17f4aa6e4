"""β-FPUT equilibration time against energy density, over thermal realisations (docs/lattices.md).

``python -m hertzian.studies.lattices --out docs/records/lattices_cpu.json`` runs, for each energy density ε, an
ensemble of β-FPUT chains (N = 32, walls at both ends, a = 1, β = 1) started with the energy N·ε shared by the
lowest ``--packet`` normal modes, each with a random phase (``excitation.thermal``, one seed per chain). The mode
energies are recorded on the device (``record.modes``). A chain's equilibration time is the first record at which
its normalised spectral entropy

    η(t) = (S_eq − S(t)) / (S_eq − S(0)),   S_eq = ln N' − (1 − γ),

falls to ``--threshold`` (0.1), where N' counts the modes and S_eq is the mean entropy of energies drawn from an
exponential distribution (equipartition in the canonical ensemble; γ is Euler's constant). The record keeps, per ε,
the ensemble mean with its standard error, the quantiles, the chains that had not equilibrated by the end, and the
seconds; then power laws fitted to the means at the weak (ε ≤ 0.05) and strong (ε ≥ 0.2) ends and the local
exponents between neighbouring densities, and the densities of ``--halved`` again at dt/2 (a chaotic chain's
trajectory does not survive halving dt; the statistics must).
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import time
from datetime import date
from pathlib import Path

import numpy as np
from hertzian.core.outputs import exit_unless_replaceable

EULER_GAMMA = 0.5772156649015329
RECORDS = 1000
"""Records per run: the equilibration time's resolution is the run's length / RECORDS."""
DENSITIES = {
    0.02: (2.0e5, 0.1),
    0.03: (8.0e4, 0.1),
    0.05: (2.0e4, 0.1),
    0.1: (4.0e3, 0.1),
    0.2: (2.0e3, 0.1),
    0.5: (1.0e3, 0.05),
    1.0: (1.0e3, 0.025),
}
"""Energy density ε → (run length, dt): the run several times the slowest of 20 chains of a trial (none left
unequilibrated); dt such that the energy error stays below 1e-3 (dt = 0.1 is too coarse for ε ≥ 0.5)."""


def scenes(density: float, realisations: int, *, grains: int, packet: int, dt: float, duration: float, every: float):
    """The ensemble of one energy density: one scene per seed 0 … realisations − 1."""
    from hertzian.core.scene import scene_from_dict

    base = {
        "chain": {"grains": grains, "potential": "fput", "a": 1.0, "beta": 1.0},
        "excitation": {"thermal": density, "thermal_modes": [1, packet]},
        "integrator": {"method": "yoshida4", "dt": dt, "duration": duration},
        "record": {"every": every, "fields": [], "modes": True},
    }
    template = scene_from_dict(base)
    return [template.with_overrides({"excitation.seed": seed}) for seed in range(realisations)]


def equilibration_times(t: np.ndarray, entropy: np.ndarray, modes: int, threshold: float) -> np.ndarray:
    """Per chain (rows of ``entropy``, chains × records), the first record time with η ≤ ``threshold``; NaN for a
    chain that never gets there."""
    equilibrium = math.log(modes) - (1.0 - EULER_GAMMA)
    eta = (equilibrium - entropy) / (equilibrium - entropy[:, :1])
    reached = eta <= threshold
    first = np.argmax(reached, axis=1)
    return np.where(reached.any(axis=1), t[first], np.nan)


def measure(density: float, duration: float, dt: float, args) -> tuple[np.ndarray, dict]:
    """One energy density's ensemble, run to ``duration`` with RECORDS records: every chain's equilibration time and
    their statistics."""
    from hertzian.core.runner import run_ensemble

    ensemble = scenes(
        density,
        args.realisations,
        grains=args.grains,
        packet=args.packet,
        dt=dt,
        duration=duration,
        every=duration / RECORDS,
    )
    clock = time.perf_counter()
    result = run_ensemble(ensemble, args.device)
    seconds = time.perf_counter() - clock
    times = equilibration_times(result.t, result.spectrum["spectral_entropy"], args.grains, args.threshold)
    done = times[np.isfinite(times)]
    return times, {
        "density": density,
        "dt": dt,
        "duration": float(result.t[-1]),
        "record_every": float(result.t[1] - result.t[0]),
        "realisations": len(times),
        "not_equilibrated": int(np.count_nonzero(~np.isfinite(times))),
        "mean": float(done.mean()) if done.size else None,
        "standard_error": float(done.std(ddof=1) / math.sqrt(done.size)) if done.size > 1 else None,
        "std": float(done.std(ddof=1)) if done.size > 1 else None,
        "q05": float(np.quantile(done, 0.05)) if done.size else None,
        "q50": float(np.quantile(done, 0.5)) if done.size else None,
        "q95": float(np.quantile(done, 0.95)) if done.size else None,
        "energy_error_max": float(np.max(result.energy_error)),
        "status_counts": {int(k): int(v) for k, v in zip(*np.unique(result.status, return_counts=True))},
        "seconds": seconds,
    }


def fit(points: list[dict]) -> dict:
    """The power law T_eq = C ε^p fitted to the means by weighted least squares in logs (weights from the standard
    errors), with the slope's standard error."""
    x = np.log([p["density"] for p in points])
    y = np.log([p["mean"] for p in points])
    sigma = np.array([p["standard_error"] / p["mean"] for p in points])
    weights = 1.0 / sigma**2
    design = np.stack([np.ones_like(x), x], axis=1)
    cov = np.linalg.inv(design.T @ (design * weights[:, None]))
    coeff = cov @ design.T @ (weights * y)
    return {
        "exponent": float(coeff[1]),
        "exponent_error": float(math.sqrt(cov[1, 1])),
        "prefactor": float(np.exp(coeff[0])),
    }


def toda_soliton(n: np.ndarray, t: float, kappa: float, centre: float) -> tuple[np.ndarray, np.ndarray]:
    """(u, v) of Toda's one-soliton solution for a = b = m = 1 (Toda, Theory of Nonlinear Lattices, §2.4):
    u_n = ln[(1 + e^{2(κ(n−1) − ωt − κc)}) / (1 + e^{2(κn − ωt − κc)})], ω = sinh κ."""
    omega = math.sinh(kappa)
    behind, ahead = 2.0 * (kappa * (n - 1) - omega * t - kappa * centre), 2.0 * (kappa * n - omega * t - kappa * centre)
    u = np.logaddexp(0.0, behind) - np.logaddexp(0.0, ahead)
    v = omega * (np.tanh(0.5 * ahead) - np.tanh(0.5 * behind))
    return u, v


def soliton_error(dt: float, device: str) -> dict:
    """A κ = 1 Toda soliton across a free 200-grain chain for 100 time units (yoshida6): the largest deviation of
    any grain from the closed form at any of 11 records."""
    from hertzian.core.model import build_model
    from hertzian.core.runner import Runner
    from hertzian.core.scene import scene_from_dict

    grains, centre = 200, 50.0
    scene = scene_from_dict(
        {
            "chain": {"grains": grains, "potential": "toda", "a": 1.0, "b": 1.0},
            "boundary": {"surface": "free", "bottom": "free"},
            "integrator": {"method": "yoshida6", "dt": dt, "duration": 100.0},
            "record": {"every": 10.0, "fields": ["u"]},
        }
    )
    runner = Runner(build_model([scene], device))
    n = np.arange(grains, dtype=np.float64)
    u, v = toda_soliton(n, 0.0, 1.0, centre)
    force = np.expm1(u[:-1] - u[1:])
    acceleration = np.concatenate([[0.0], force]) - np.concatenate([force, [0.0]])
    runner.buffers[0].x.assign(np.stack([u, dt * v, dt * dt / 2 * acceleration])[:, None, :])
    result = runner.run()
    exact = np.stack([toda_soliton(n, t, 1.0, centre)[0] for t in result.t])
    return {"dt": dt, "max_error": float(np.abs(result.u[0] - exact).max()), "seconds": result.wall_seconds}


def fput_recurrence(dt: float, device: str) -> dict:
    """N = 32, α = 1/4, all energy in mode 1 at amplitude 1: the time, in periods T_1 of mode 1, at which mode 1's
    share of the harmonic energy returns to its first maximum after falling below 10 %."""
    from hertzian.core.runner import run_scene
    from hertzian.core.scene import scene_from_dict

    grains, alpha = 32, 0.25
    omega1 = 2.0 * math.sin(math.pi / (2 * (grains + 1)))
    period = 2 * math.pi / omega1
    scene = scene_from_dict(
        {
            "chain": {"grains": grains, "potential": "fput", "a": 1.0, "alpha": alpha},
            "excitation": {"modes": [1], "mode_energy": 0.5 * omega1**2 * (grains + 1) / 2},
            "integrator": {"method": "yoshida6", "dt": dt, "duration": 170 * period},
            "record": {"every": period / 8, "fields": [], "modes": True},
        }
    )
    result = run_scene(scene, device)
    energy = result.spectrum["mode_energy"][0]
    share = energy[:, 0] / energy.sum(axis=1)
    low = int(np.argmin(share[result.t < 120 * period]))
    back = low + int(np.argmax(share[low:]))
    y0, y1, y2 = share[back - 1 : back + 2]
    peak = result.t[back] + 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2) * (period / 8)
    return {
        "dt": dt,
        "recurrence_periods": float(peak / period),
        "lowest_share": float(share[low]),
        "returned_share": float(share[back]),
        "zabusky_estimate_periods": 0.44 * math.sqrt(grains**3 / alpha),
        "seconds": result.wall_seconds,
    }


def _halved(density: float, args, at_dt: tuple[np.ndarray, dict]) -> dict:
    """``density`` again at dt/2: its statistics, and whether each chain (same seed) equilibrates when it did at dt
    (within one record interval), i.e. whether single trajectories survive halving dt."""
    duration, dt = args.points[density]
    times, stats = measure(density, duration, dt / 2, args)
    before = at_dt[0]
    both = np.isfinite(times) & np.isfinite(before)
    difference = np.abs(times[both] - before[both])
    return {
        **stats,
        "same_chain_within_one_record": float(np.mean(difference <= stats["record_every"] * (1 + 1e-9))),
        "same_chain_median_difference": float(np.median(difference)),
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument(
        "--points",
        type=lambda s: {float(p.split(":")[0]): tuple(map(float, p.split(":")[1:])) for p in s.split(",")},
        default=DENSITIES,
        help="ε:duration:dt triples, comma-separated (default: DENSITIES)",
    )
    parser.add_argument("--realisations", type=int, default=1000)
    parser.add_argument("--grains", type=int, default=32)
    parser.add_argument("--packet", type=int, default=4, help="the lowest modes that share the energy at t = 0")
    parser.add_argument("--threshold", type=float, default=0.1)
    parser.add_argument(
        "--halved",
        type=lambda s: [float(v) for v in s.split(",")],
        default=[],
        help="densities (of --points) also run at dt/2",
    )
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--validation-only", action="store_true", help="only the soliton and the FPUT recurrence")
    args = parser.parse_args(argv)
    exit_unless_replaceable(args.out, "--out")
    validation = {
        "toda_soliton": [soliton_error(dt, args.device) for dt in (0.02, 0.01)],
        "fput_recurrence": [fput_recurrence(dt, args.device) for dt in (0.2, 0.1)],
    }
    if args.validation_only:
        record = {"device": args.device, "host": platform.node(), "date": date.today().isoformat()}
        args.out.write_text(json.dumps({**record, "validation": validation}, indent=1) + "\n")
        print(f"wrote {args.out}")
        return
    measured = {density: measure(density, duration, dt, args) for density, (duration, dt) in args.points.items()}
    points = [stats for _, stats in measured.values()]
    record = {
        "device": args.device,
        "host": platform.node(),
        "date": date.today().isoformat(),
        "command": "python -m hertzian.studies.lattices " + " ".join(argv or __import__("sys").argv[1:]),
        "chain": {"grains": args.grains, "potential": "fput", "a": 1.0, "beta": 1.0, "ends": "walls"},
        "start": {"packet": [1, args.packet], "phases": "uniform, one seed per chain"},
        "integrator": {"method": "yoshida4"},
        "criterion": {"threshold": args.threshold, "equilibrium_entropy": f"ln {args.grains} − (1 − γ)"},
        "points": points,
        "fit": {
            "weak": fit([p for p in points if p["density"] <= 0.05]),
            "strong": fit([p for p in points if p["density"] >= 0.2]),
            "local": [
                {
                    "densities": [a["density"], b["density"]],
                    "exponent": math.log(b["mean"] / a["mean"]) / math.log(b["density"] / a["density"]),
                }
                for a, b in zip(points, points[1:])
            ],
        },
        "validation": validation,
    }
    if args.halved:
        record["halved"] = [_halved(d, args, measured[d]) for d in args.halved]
    args.out.write_text(json.dumps(record, indent=1) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
