"""The kernels a job will launch, named before it starts (hertzian.core.solvers.compile.Need): a scene, a sweep file,
the paper reproduction, a detection. ``hertzian warmup`` and ``hertzian reproduce`` compile them at once with
:func:`hertzian.core.solvers.compile.prepare_kernels`."""

from __future__ import annotations

from hertzian.core.model import features_of
from hertzian.core.scene import Scene
from hertzian.core.solvers.prepare import Need
from hertzian.core.spectrum import spectrum_kernels
from hertzian.studies.detection.forward import detect_needs  # noqa: F401  (re-exported: hertzian warmup --detect)
from hertzian.studies.reproduce import paper_needs  # noqa: F401  (re-exported: hertzian warmup --paper)
from hertzian.sweeping.distributed import sweep_needs  # noqa: F401  (re-exported: hertzian warmup SWEEP)


def scene_needs(scene: Scene, kernel: str = "auto") -> list[Need]:
    """The launch group of one ``hertzian run`` of ``scene`` (and the mode-energy kernels of ``record.modes``)."""
    features = features_of([scene])
    need = Need(features, scene.chain.grains, 1, scene.step_count, kernel, bool(scene.record.fields))
    return [need, *(spectrum_kernels(features) if scene.record.modes else [])]


def file_needs(path, device: str, kernel: str = "auto") -> list[Need]:
    """The launch groups of a scene or sweep file ``path`` on ``device``. ``auto`` stands for what a run takes once
    its kernels are cached: ``fused`` (a short CPU run on a cold cache may take the per-step kernel,
    hertzian.core.solvers.calibrate.cpu_auto_config; once warm it takes the chain one)."""
    from hertzian.core.scene import load_scene, read_toml

    warm = "fused" if kernel == "auto" else kernel
    if path.is_file() and "scene" in read_toml(path):  # a sweep file holds its base scene in [scene]
        return sweep_needs(path, {}, device, warm)
    return scene_needs(load_scene(path), warm)


def any_length_needs(needs: list, device) -> list[Need]:
    """What ``hertzian warmup --any-length`` adds to ``needs`` on ``device`` (a Warp device): for each feature set
    among them, every launch shape the shipped rule gives it for 2 to 10⁵ grains in any number (a GPU's,
    hertzian.core.solvers.calibrate.shape_family) and the record kernels of long chains; on a CPU, where the chain
    kernel takes any length, the long chains' record kernels."""
    from hertzian.core.solvers.calibrate import shape_family
    from hertzian.kernels.records import STAGED_GRAINS

    out: list[Need] = []
    for features in dict.fromkeys(n.features for n in needs if isinstance(n, Need)):
        if device.is_cpu:
            out.append(Need(features, STAGED_GRAINS, 1, None, "fused"))
            continue
        for config, grains, chains in shape_family(features, sm_count=device.sm_count, arch=device.arch):
            out.append(Need(features, grains, chains, None, config))
            if config.kind == "window":  # a window takes any length: the long chains' record kernels too
                out.append(Need(features, max(grains, STAGED_GRAINS), chains, None, config))
    return out


def with_any_length(needs: list, device: str) -> list:
    """``needs`` and what ``--any-length`` adds to them on ``device`` (:func:`any_length_needs`)."""
    from hertzian.kernels.features import device_of

    return [*needs, *any_length_needs(needs, device_of(device))]


def gpu_family_variants(needs: list, gpu) -> list[tuple]:
    """The (Warp module, block_dim) a GPU ``gpu`` (a PlannedGPU, planned here without one) loads for ``needs`` at any
    chain length and count: their own launch groups, every shape their feature sets take
    (:func:`any_length_needs`) and the record kernels of short and long chains, at the GPU's block sizes."""
    from hertzian.core.solvers.prepare import kernel_variants

    return kernel_variants(with_any_length(needs, gpu), gpu)


def family_needs(device: str) -> list[Need]:
    """The default family's launch groups on ``device``: one ``hertzian run`` of each shipped example scene, every
    shipped sweep file (each launch group and batch size, with the kernel a warm ``auto`` takes) and both paper
    reproductions (``reproduce`` and ``reproduce --quick``). What ``hertzian prebuild`` compiles ahead of time."""
    from hertzian.core.scene import load_scene, read_toml
    from hertzian.core.shipped import shipped_file, shipped_names

    needs: list = []
    for name in shipped_names():
        path = shipped_file(name)
        table = read_toml(path)
        if "design" in table:  # a design file: its kernels depend on what the optimizer draws
            continue
        if "scene" in table and "study" not in table:  # a sweep file (a detection study is not a sweep)
            needs.extend(sweep_needs(path, {}, device, "fused"))
        elif "scene" not in table and "study" not in table:
            needs.extend(scene_needs(load_scene(path), "fused"))
    for quick in (False, True):
        needs.extend(paper_needs(device, quick=quick))
    return needs


def family_rows(needs: list, device: str) -> list[dict]:
    """One row per kernel variant of ``needs`` on ``device``: {"module", "block_dim", "features" (the fields that
    differ from the defaults), "shapes" (grains x chains of the launch groups that load it)}."""
    from hertzian.core.solvers.prepare import kernel_variants

    rows: dict[tuple, dict] = {}
    for need in needs:
        for module, block in kernel_variants([need], device):
            row = rows.setdefault(
                (module.name, block), {"module": module.name, "block_dim": block, "features": None, "shapes": []}
            )
            if isinstance(need, Need):
                row["features"] = row["features"] or feature_summary(need.features)
                shape = f"{need.grains}x{need.chains}"
                if shape not in row["shapes"]:
                    row["shapes"].append(shape)
    return list(rows.values())


def feature_summary(features) -> str:
    """The feature switches of ``features`` that differ from a plain float64 gear4 chain, as ``key=value`` pairs."""
    from dataclasses import fields

    from hertzian.kernels.features import Features

    plain = Features()
    changed = [
        f"{f.name}={getattr(features, f.name)}"
        for f in fields(features)
        if getattr(features, f.name) != getattr(plain, f.name)
    ]
    return " ".join(changed) or "plain"
