"""``hertzian tune``: time the fused launch shapes of a job's launch groups on this GPU and remember the fastest.

A run never times anything (hertzian.core.solvers.calibrate.choose_config): on a GPU it takes the shape this
command remembered for its model, else the shipped rule's (hertzian.core.solvers.shape_rule). Each launch group of
the job (a scene's one run, each launch group and batch size of a sweep file, each figure group of the paper) is
built as the run would build it, its candidate shapes are timed, and the fastest is written to the calibration
cache; the report sets the rule's shape beside it, so the rule's cost on this machine is known.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path


def scene_or_sweep_models(path: Path, device: str, overrides: dict | None = None) -> Iterator:
    """The models a ``hertzian run`` of the scene ``path``, or a ``hertzian sweep`` of the sweep file ``path``
    (one per launch group and batch size), builds on ``device``."""
    from hertzian.core.model import build_model
    from hertzian.core.scene import load_scene, read_toml
    from hertzian.sweeping.planner import plan_sweep
    from hertzian.sweeping.spec import expand, load_sweep

    if "scene" not in read_toml(path):
        yield build_model([load_scene(path)], device)
        return
    points = expand(load_sweep(path, overrides or {}))
    plan = plan_sweep(load_sweep(path, overrides or {}), points, device)
    seen = set()
    for batch in plan.batches:
        if (batch.group, batch.size) not in seen:
            seen.add((batch.group, batch.size))
            yield build_model(points.chains(batch.points), device, features=plan.groups[batch.group].features)


def paper_models(device: str, *, quick: bool = False) -> Iterator:
    """The models of every figure group of ``hertzian reproduce`` (``--quick``: of ``reproduce --quick``)."""
    from hertzian.core.model import build_model
    from hertzian.studies.reproduce import DRIVE_DT, GROUPS, default_sweeps_dir, drive_scenes

    sweeps = default_sweeps_dir()
    for name, group in GROUPS.items():
        if name == "fig9_10":
            grains = group.quick["chain.grains"] if quick else 10000
            _, scenes = drive_scenes(sweeps / group.sweep, grains, 1.0, DRIVE_DT)
            yield build_model(list(scenes), device)
            continue
        yield from scene_or_sweep_models(sweeps / group.sweep, device, group.quick if quick else {})


def tune_model(model, kernel: str = "auto", log=None) -> dict:
    """Time ``model``'s candidate shapes and remember the fastest (calibrate.tune). Returns one report row:
    grains, chains, features, and either ``kernel`` (the per-step kernel, with ``reason``: nothing to time) or
    ``fastest`` and ``rule`` (each a shape and its grain-steps per second) and ``rule_gap`` (1 − rule/fastest)."""
    from hertzian.core.solvers.calibrate import step_reason, tune
    from hertzian.studies.warmup import feature_summary

    row = {"grains": model.grain_count, "chains": model.chain_count, "features": feature_summary(model.features)}
    reason = step_reason(model, model.scenes[0].step_count) if kernel in ("auto", "fused") else None
    if reason:
        return {**row, "kernel": "step", "reason": reason}
    best, rule, results = tune(model, kernel=kernel, log=log)
    rate = {config: model.grain_count * model.chain_count / seconds for config, seconds in results}
    out = {**row, "fastest": {"shape": best.describe(), "grain_steps_per_second": rate[best]}}
    if rule in rate:
        out["rule"] = {"shape": rule.describe(), "grain_steps_per_second": rate[rule]}
        out["rule_gap"] = 1.0 - rate[rule] / rate[best]
    return out


def describe_row(row: dict) -> str:
    """One line of a report row."""
    head = f"{row['grains']} grains x {row['chains']} chains ({row['features'] or 'plain'})"
    if "reason" in row:
        return f"{head}: per-step kernel, nothing to time ({row['reason']})"
    fastest = row["fastest"]
    text = f"{head}: fastest {fastest['shape']} {fastest['grain_steps_per_second']:.3g} grain-steps/s"
    if "rule" in row:
        text += f"; rule {row['rule']['shape']} {100 * row['rule_gap']:.1f} % slower"
    return text
