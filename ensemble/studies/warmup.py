"""The kernels a job will launch, named before it starts (hertzian.core.solvers.compile.Need): a scene, a sweep file,
the paper reproduction, a detection. ``hertzian warmup`` and ``hertzian reproduce`` compile them at once with
:func:`hertzian.core.solvers.compile.prepare_kernels`."""

from __future__ import annotations

from hertzian.core.model import features_of
from hertzian.core.scene import Scene
from hertzian.core.solvers.prepare import Need
from hertzian.studies.reproduce import paper_needs  # noqa: F401  (re-exported: hertzian warmup --paper)
from hertzian.sweeping.distributed import sweep_needs  # noqa: F401  (re-exported: hertzian warmup SWEEP)


def scene_needs(scene: Scene, kernel: str = "auto") -> list[Need]:
    """The launch group of one ``hertzian run`` of ``scene``."""
    return [Need(features_of([scene]), scene.chain.grains, 1, scene.step_count, kernel)]


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
