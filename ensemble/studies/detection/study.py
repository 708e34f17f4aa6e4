"""Accuracy study of ``hertzian detect``: plant impurities, add noise, detect, tabulate.

A study file (TOML, e.g. ``sweeps/detect_study.toml``) holds a BASE scene (``[scene]``, any scene keys),
the sampling (``[study] spacing``; ``window_past_bottom``, default 1: the analysis window's end as a multiple of
the bottom reflection's return), and host variants (``[[hosts]]``: gravity, block length, step, and
which SNRs, mass ratios, depth fractions and clean trials to run on it). For each host:

1. the truths — BASE + one block of mass ratio μ at depth round(f·N) (clipped to N − block) for every
   μ and f, and the clean chain — are run as one ensemble at **half** the detector's step, tracing
   grain 0 at the sample times (independent of the detector's library, and not on its grid);
2. for each SNR, seeded Gaussian noise of σ = peak / 10^(SNR/20) is added, peak = max |v − v_clean|
   over the analysed window (until the bottom reflection returns); clean trials use the σ of the
   host's median echo peak;
3. ``detect`` runs on every signal (the library is built once per host and then cached).

Records (one per detection) and summaries (class accuracy, depth within ±1, mass-ratio interval
coverage, confusion matrices per SNR, seconds per detection) go to a JSON file.
"""

from __future__ import annotations

import json
import math
import platform
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
from hertzian.core.runner import run_ensemble
from hertzian.core.scene import SceneError, apply_overrides, read_toml, refuse_other_kind, scene_from_dict
from hertzian.studies.detection import detect
from hertzian.studies.detection.forward import forward_scene, impurity_scene
from hertzian.studies.detection.library import cached_fronts
from hertzian.studies.detection.scoring import bisect_increasing
from hertzian.studies.detection.signal import signal_from_arrays

HOST_KEYS = {
    "name",
    "gravity",
    "block",
    "dt",
    "snr_db",
    "mass_ratios",
    "depth_fractions",
    "clean_trials",
    "noise_trials",
}
STUDY_KEYS = {
    "spacing",
    "seed",
    "mass_steps",
    "refine",
    "iterations",
    "probe_duration",
    "mass_range",
    "window_past_bottom",
}


def load_study(path: str | Path) -> dict:
    data = read_toml(path, "detection study file")
    refuse_other_kind(data, path, "detection study")
    for key in ("scene", "study", "hosts"):
        if key not in data:
            raise SceneError(f"{path}: {key}", None, "is required ([scene], [study], [[hosts]])")
    unknown = set(data["study"]) - STUDY_KEYS
    if unknown:
        raise SceneError("study", sorted(unknown), f"unknown keys; allowed: {', '.join(sorted(STUDY_KEYS))}")
    past = data["study"].get("window_past_bottom", 1.0)
    if isinstance(past, bool) or not isinstance(past, (int, float)) or not 1.0 <= past <= 2.0:
        raise SceneError(
            "study.window_past_bottom",
            past,
            "must be a number in [1, 2] (the analysis window's end as a multiple of the bottom reflection's return)",
        )
    for k, host in enumerate(data["hosts"]):
        unknown = set(host) - HOST_KEYS
        if unknown:
            raise SceneError(f"hosts[{k}]", sorted(unknown), f"unknown keys; allowed: {', '.join(sorted(HOST_KEYS))}")
        repeats = host.get("noise_trials", 1)
        if isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 1:
            raise SceneError(
                f"hosts[{k}].noise_trials", repeats, "must be an integer ≥ 1 (noise draws per planted case)"
            )
    return data


def _truth_velocities(forward, cases, block: int, device: str) -> np.ndarray:
    """Grain 0's velocity of each (depth, μ) case (depth None: clean) at half the forward step, with event-aware
    steps wherever a contact can open (``integrator.events = "auto"``) whatever BASE says: the planted signals
    stay the more accurate, independent model when the detector's candidates take plain steps."""
    fine = forward.with_overrides({"integrator.dt": forward.integrator.dt / 2, "integrator.events": "auto"})
    scenes = [fine if depth is None else impurity_scene(fine, depth, mu, block) for depth, mu in cases]
    result = run_ensemble(scenes, device)
    if np.any(result.status != 0):
        raise RuntimeError(f"truth runs flagged: status {result.status.tolist()}")
    return result.traces["v"][:, :, 0]


def run_study(path: str | Path, device: str, *, progress=None) -> dict:
    """Run every host of a study file; returns {"meta", "records", "summary"}."""
    study = load_study(path)
    options = study["study"]
    spacing = float(options.get("spacing", 0.01))
    seed = int(options.get("seed", 1))
    detect_options = {k: options[k] for k in ("mass_steps", "refine", "iterations") if k in options}
    # the analysis window: detect's default (until the bottom reflection returns, 2 t_front(N − 1)), or this
    # multiple of it (deep impurities' echoes return with the bottom reflection; docs/detection.md, failure 1)
    past_bottom = float(options.get("window_past_bottom", 1.0))
    if "mass_range" in options:
        detect_options["mass_ratio_range"] = tuple(options["mass_range"])
    records, hosts_meta = [], []
    rng = np.random.default_rng(seed)
    started = time.perf_counter()
    for host in study["hosts"]:
        block = int(host.get("block", 1))
        overrides = {"chain.gravity": float(host.get("gravity", 0.0))}
        if "dt" in host:
            overrides["integrator.dt"] = float(host["dt"])
        base = scene_from_dict(apply_overrides(study["scene"], overrides))
        n = base.chain.grains
        # sample until a little after the bottom reflection returns (the detector stops there)
        probe = forward_scene(base, spacing, int(round(options.get("probe_duration", 60.0) / spacing)) + 1)
        fronts = cached_fronts(probe, device, True)
        window = 2 * float(fronts[-1])
        samples = int(math.ceil(max(1.1, past_bottom) * window / spacing)) + 1
        forward = forward_scene(base, spacing, samples)
        depths = sorted({min(max(1, int(round(f * n))), n - block) for f in host["depth_fractions"]})
        cases = [(d, float(mu)) for d in depths for mu in host["mass_ratios"]]
        t0 = time.perf_counter()
        truths = _truth_velocities(forward, [(None, 1.0)] + cases, block, device)
        truth_seconds = time.perf_counter() - t0
        clean = truths[0]
        in_window = np.arange(samples) * spacing <= window * (1 + 1e-12)
        peaks = [float(np.max(np.abs(v - clean)[in_window])) for v in truths[1:]]
        t = np.arange(samples) * spacing
        # each planted case with ``noise_trials`` independent noise draws
        trials = [(d, mu, truths[1 + k], peaks[k]) for k, (d, mu) in enumerate(cases)] * int(
            host.get("noise_trials", 1)
        )
        trials += [(None, 1.0, clean, float(np.median(peaks)))] * int(host.get("clean_trials", 0))
        name = host.get("name", f"g{overrides['chain.gravity']:g}-block{block}")
        hosts_meta.append(
            {
                "name": name,
                "grains": n,
                "gravity": overrides["chain.gravity"],
                "block": block,
                "dt": forward.integrator.dt,
                "truth_dt": forward.integrator.dt / 2,
                "window": window,
                "samples": samples,
                "depths": depths,
                "truth_seconds": truth_seconds,
            }
        )
        for snr in host["snr_db"]:
            for depth, mu, velocity, peak in trials:
                sigma = peak / 10 ** (float(snr) / 20)
                signal = signal_from_arrays(t, velocity + rng.normal(scale=sigma, size=samples), source="study")
                result, _ = detect(
                    signal,
                    base,
                    block=block,
                    device=device,
                    window=None if past_bottom == 1.0 else past_bottom * window,
                    **detect_options,
                )
                truth_class = "none" if depth is None else ("light" if mu < 1 else "heavy")
                interval = result.mass_ratio_interval
                records.append(
                    {
                        "host": name,
                        "snr_db": float(snr),
                        "true_class": truth_class,
                        "true_depth": depth,
                        "true_mass_ratio": mu,
                        "depth_fraction": None if depth is None else depth / n,
                        "sigma": sigma,
                        "echo_peak": peak,
                        **result.to_dict(),
                        "class_correct": result.kind == truth_class,
                        "depth_error": None if (depth is None or result.depth is None) else result.depth - depth,
                        "mass_ratio_covered": (
                            None if depth is None or interval is None else bool(interval[0] <= mu <= interval[1])
                        ),
                    }
                )
                if progress is not None:
                    progress(records[-1])
    meta = {
        "study_file": str(path),
        "device": device,
        "cpu": platform.processor() or platform.machine(),
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "hosts": hosts_meta,
        "scene": study["scene"],
        "study": options,
        "wall_seconds": time.perf_counter() - started,
    }
    return {"meta": meta, "summary": summarize(records), "records": records}


def summarize(records: list[dict]) -> dict:
    """Per host and SNR: class accuracy, depth within ±1, coverage, confusion matrix, seconds."""
    out = {}
    for host in sorted({r["host"] for r in records}):
        per_snr = {}
        for snr in sorted({r["snr_db"] for r in records if r["host"] == host}, reverse=True):
            rows = [r for r in records if r["host"] == host and r["snr_db"] == snr]
            impure = [r for r in rows if r["true_class"] != "none"]
            located = [r for r in impure if r["depth_error"] is not None]
            covered = [r for r in impure if r["mass_ratio_covered"] is not None]
            confusion = {
                tc: {
                    pc: sum(1 for r in rows if r["true_class"] == tc and r["class"] == pc)
                    for pc in ("none", "light", "heavy")
                }
                for tc in ("none", "light", "heavy")
            }
            correct = sum(r["class_correct"] for r in rows)
            within = sum(r["class_correct"] and abs(r["depth_error"]) <= 1 for r in located)
            per_snr[str(snr)] = {
                "detections": len(rows),
                "class_accuracy": correct / len(rows),
                "class_accuracy_lower95": binomial_lower_bound(correct, len(rows)),
                "depth_within_1_lower95": binomial_lower_bound(within, len(impure)) if impure else None,
                "depth_within_1": (
                    sum(r["class_correct"] and abs(r["depth_error"]) <= 1 for r in located) / len(impure)
                )
                if impure
                else None,
                "depth_exact": (sum(r["class_correct"] and r["depth_error"] == 0 for r in located) / len(impure))
                if impure
                else None,
                "mass_ratio_interval_coverage": (
                    sum(r["mass_ratio_covered"] for r in covered) / len(covered) if covered else None
                ),
                "confusion": confusion,
                "seconds_per_detection_median": float(np.median([r["seconds"]["total"] for r in rows])),
                "by_depth_fraction": _by(impure, "depth_fraction"),
                "by_mass_ratio": _by(impure, "true_mass_ratio"),
            }
        out[host] = per_snr
    return out


def binomial_lower_bound(successes: int, trials: int, confidence: float = 0.95) -> float:
    """Clopper–Pearson lower limit of a success rate (two-sided ``confidence``): the p at which seeing
    ``successes`` or more of ``trials`` has probability (1 − confidence)/2; 0 with no success."""
    if successes <= 0:
        return 0.0
    tail = (1 - confidence) / 2

    def at_least(p: float) -> float:  # P(X ≥ successes | p)
        terms = [
            math.exp(
                math.lgamma(trials + 1)
                - math.lgamma(k + 1)
                - math.lgamma(trials - k + 1)
                + k * math.log(p)
                + (trials - k) * math.log1p(-p)
            )
            for k in range(successes, trials + 1)
        ]
        return math.fsum(terms)

    return bisect_increasing(at_least, tail, 0.0, 1.0, steps=200)


def _by(rows: list[dict], key: str) -> dict:
    table = {}
    for value in sorted({r[key] for r in rows}):
        group = [r for r in rows if r[key] == value]
        table[f"{value:.3g}"] = {
            "n": len(group),
            "class_accuracy": sum(r["class_correct"] for r in group) / len(group),
            "depth_within_1": sum(
                r["depth_error"] is not None and abs(r["depth_error"]) <= 1 and r["class_correct"] for r in group
            )
            / len(group),
        }
    return table


def write_study(result: dict, path: str | Path) -> None:
    Path(path).write_text(json.dumps(result, indent=1, default=float))


def markdown_tables(result: dict) -> str:
    """The study's summary as Markdown tables (what docs/detection.md quotes)."""
    lines = []
    meta = result["meta"]
    lines.append(
        f"Study file `{meta['study_file']}`, device {meta['device']} ({meta['cpu']}), {meta['date']}, "
        f"{meta['wall_seconds']:.0f} s wall in all.\n"
    )
    lines.append("| host | grains | g | block | dt (truth dt) | window | depths planted |")
    lines.append("| --- | --- | --- | --- | --- | --- | --- |")
    for h in meta["hosts"]:
        lines.append(
            f"| {h['name']} | {h['grains']} | {h['gravity']:g} | {h['block']} | {h['dt']:g} ({h['truth_dt']:g}) "
            f"| t ≤ {h['window']:.4g} | {', '.join(map(str, h['depths']))} |"
        )
    lines.append("")
    lines.append(
        "| host | SNR [dB] | detections | class correct | depth exact | depth ±1 | μ in 95 % interval "
        "| s / detection (median) |"
    )
    lines.append("| --- | --- | --- | --- | --- | --- | --- | --- |")

    def fmt(x):
        return "–" if x is None else f"{x:.3f}"

    for host, per_snr in result["summary"].items():
        for snr, row in per_snr.items():
            lines.append(
                f"| {host} | {float(snr):g} | {row['detections']} | {fmt(row['class_accuracy'])} | "
                f"{fmt(row['depth_exact'])} | {fmt(row['depth_within_1'])} | "
                f"{fmt(row['mass_ratio_interval_coverage'])} | {row['seconds_per_detection_median']:.2f} |"
            )
    lines.append("")
    for host, per_snr in result["summary"].items():
        for snr, row in per_snr.items():
            c = row["confusion"]
            lines.append(f"Confusion, {host}, SNR {float(snr):g} dB (rows: truth, columns: detected)\n")
            lines.append("| truth \\ detected | none | light | heavy |")
            lines.append("| --- | --- | --- | --- |")
            for tc in ("none", "light", "heavy"):
                lines.append(f"| {tc} | {c[tc]['none']} | {c[tc]['light']} | {c[tc]['heavy']} |")
            lines.append("")
    for host, per_snr in result["summary"].items():
        snrs = list(per_snr)
        for key, title in (("by_depth_fraction", "depth / N"), ("by_mass_ratio", "mass ratio")):
            values = list(per_snr[snrs[0]][key])
            lines.append(f"{host}: class correct and depth within ±1 (with the class right) by {title}\n")
            lines.append(f"| {title} | " + " | ".join(f"{float(s):g} dB" for s in snrs) + " |")
            lines.append("| --- | " + " | ".join("---" for _ in snrs) + " |")
            for v in values:
                cells = []
                for s in snrs:
                    cell = per_snr[s][key].get(v)
                    cells.append(
                        "–" if cell is None else f"{cell['class_accuracy']:.2f} / {cell['depth_within_1']:.2f}"
                    )
                lines.append(f"| {v} | " + " | ".join(cells) + " |")
            lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":
    print(markdown_tables(json.loads(Path(sys.argv[1]).read_text())))
