"""The kernels a job will launch, named before it starts (hertzian.core.solvers.compile.Need): a scene, a sweep file,
the paper reproduction, a detection. ``hertzian warmup`` and ``hertzian reproduce`` compile them at once with
:func:`hertzian.core.solvers.compile.prepare_kernels`."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from hertzian.core.model import features_of
from hertzian.core.scene import Scene
from hertzian.core.solvers.compile import Need


def scene_needs(scene: Scene, kernel: str = "auto") -> list[Need]:
    """The launch group of one ``hertzian run`` of ``scene``."""
    return [Need(features_of([scene]), scene.chain.grains, 1, scene.step_count, kernel)]


def sweep_needs(path: Path, overrides: dict[str, Any], device: str, kernel: str = "auto") -> list[Need]:
    """Every launch group and batch size of the sweep file ``path`` (with ``overrides``) on ``device``."""
    from hertzian.sweeping.distributed import runs_of
    from hertzian.sweeping.planner import plan_sweep
    from hertzian.sweeping.spec import expand, load_sweep

    points = expand(load_sweep(path, overrides))
    plan = plan_sweep(load_sweep(path, overrides), points, device)
    return [Need(*run, kernel) for run in dict.fromkeys(runs_of(plan, points, plan.batches))]


def paper_needs(
    device: str,
    *,
    quick: bool = False,
    events: str | None = None,
    kernel: str | None = None,
    groups: list[str] | None = None,
) -> list:
    """Every launch group of ``hertzian reproduce`` (each figure group's sweep of ``groups``, default all; the driven
    column of Figs. 9-10 and its window kernels), with the kernel choice ``reproduce`` makes per group."""
    from hertzian.kernels.windows import window_kernels
    from hertzian.studies import reproduce as rp

    needs: list = []
    sweeps = rp.default_sweeps_dir()
    for name in groups or list(rp.GROUPS):
        group = rp.GROUPS[name]
        overrides = {**(group.quick if quick else {}), **({"integrator.events": events} if events else {})}
        if name == "fig9_10":
            grains = group.quick["chain.grains"] if quick else 10000
            _, scenes = rp.drive_scenes(sweeps / group.sweep, grains, 1.0, rp.DRIVE_DT, events)
            needs.append(Need(features_of(list(scenes)), grains, len(scenes), None, "auto"))
            needs.extend(window_kernels(needs[-1].features.precision))
            continue
        from hertzian.sweeping.spec import expand, load_sweep

        choice = kernel
        if choice is None:
            choice = rp.group_kernel(
                expand(load_sweep(sweeps / group.sweep, overrides)).scene(0).integrator.events, device
            )
        needs.extend(sweep_needs(sweeps / group.sweep, overrides, device, choice))
    return needs


def detect_needs(base: Scene, candidates: int = 64) -> list:
    """The runs of a first ``hertzian detect`` with BASE: the clean forward run, an ensemble of ``candidates``
    impurity chains, and the library's assembly kernels (the signal's spacing changes no compiled code)."""
    from hertzian.kernels.library import library_kernels
    from hertzian.studies.detect import forward_scene, impurity_scene

    forward = forward_scene(base, base.integrator.dt, 2)
    grains = forward.chain.grains
    impure = impurity_scene(forward, grains // 2, 2.0)
    return [
        Need(features_of([forward]), grains, 1, None, "fused"),
        Need(features_of([forward, impure]), grains, candidates, None, "fused"),
        *library_kernels(forward.integrator.precision),
    ]
