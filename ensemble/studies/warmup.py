"""The kernels a job will launch, named before it starts (hertzian.core.solvers.compile.Need): a scene, a sweep file,
the paper reproduction, a detection. ``hertzian warmup`` and ``hertzian reproduce`` compile them at once with
:func:`hertzian.core.solvers.compile.prepare_kernels`."""

from __future__ import annotations

from hertzian.core.model import features_of
from hertzian.core.scene import Scene
from hertzian.core.solvers.prepare import Need
from hertzian.studies.detection.forward import detect_needs  # noqa: F401  (re-exported: hertzian warmup --detect)
from hertzian.studies.reproduce import paper_needs  # noqa: F401  (re-exported: hertzian warmup --paper)
from hertzian.sweeping.distributed import sweep_needs  # noqa: F401  (re-exported: hertzian warmup SWEEP)


def scene_needs(scene: Scene, kernel: str = "auto") -> list[Need]:
    """The launch group of one ``hertzian run`` of ``scene``."""
    return [Need(features_of([scene]), scene.chain.grains, 1, scene.step_count, kernel, bool(scene.record.fields))]
