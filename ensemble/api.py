"""The functions behind ``import hertzian as hz`` that are not one of the library's own: loading a scene from a
file, a shipped name or a parsed table; running scenes with the checks of ``hertzian run``; opening a store.

Bad input raises one line, as the command line prints it: :class:`~hertzian.core.scene.SceneError` for a scene
key, :class:`~hertzian.core.errors.OptionError` for an argument, :class:`~hertzian.core.errors.RefusedError` for a
run that cannot fit.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from hertzian.core.check import memory_refusal
from hertzian.core.devices import check_device
from hertzian.core.errors import OptionError, RefusedError
from hertzian.core.model import build_model
from hertzian.core.runner import Runner, RunResult
from hertzian.core.scene import Scene, SceneError, apply_overrides, scene_from_dict
from hertzian.core.scene import load_scene as load_scene_file
from hertzian.core.shipped import shipped_file
from hertzian.core.solvers import KERNELS


def load_scene(source: str | Path | dict, overrides: dict[str, Any] | None = None) -> Scene:
    """A scene from a TOML file (a path, or the name of a shipped example such as ``impact``) or from a parsed TOML
    table (a dict), with ``overrides`` ({"chain.l0": 1e-4, …}) applied; validated."""
    if isinstance(source, dict):
        return scene_from_dict(apply_overrides(source, overrides or {}))
    return load_scene_file(shipped_file(source), overrides)


def run(
    scenes: Scene | Iterable[Scene],
    device: str | None = None,
    *,
    kernel: str = "auto",
    progress: Callable[[int, int], None] | None = None,
) -> RunResult:
    """Run one scene, or compatible scenes as one ensemble, on ``device`` ('cpu', 'cuda', 'cuda:N'; default: cuda if
    present, else cpu) with the solver ``kernel`` ('auto' or one of hertzian.core.solvers.KERNELS; results are the
    same). ``progress(done_records, total_records)`` is called after each record. Times are in program units
    (1.0102e-3 s); ``RunResult.to_xarray()`` gives what ``hertzian run --out`` stores. Scenes with
    ``integrator.tolerance`` run as ``hertzian run`` runs them: pilot runs pick the step (and, with
    ``integrator.method = "auto"``, the method); ``progress`` is not called then."""
    scenes = [scenes] if isinstance(scenes, Scene) else list(scenes)
    if not scenes or not all(isinstance(s, Scene) for s in scenes):
        raise OptionError("scenes", type(scenes).__name__, "a Scene or a non-empty list of Scenes")
    if kernel not in KERNELS:
        raise OptionError("kernel", kernel, f"one of {', '.join(KERNELS)}")
    largest = max(scenes, key=lambda s: s.chain.grains)
    too_big = memory_refusal(largest, chains=len(scenes))
    dev = check_device(device)
    too_big = too_big or (memory_refusal(largest, dev, chains=len(scenes)) if dev.startswith("cuda") else None)
    if too_big:
        raise RefusedError(too_big)
    if scenes[0].integrator.tolerance is not None:  # as hertzian run: pilot runs pick the method and dt
        from hertzian.core.error_estimate import meet_tolerance

        return meet_tolerance(scenes, lambda chosen: _runner(chosen, dev, kernel).run()).result
    return _runner(scenes, dev, kernel).run(progress)


def _runner(scenes: list[Scene], device: str, kernel: str) -> Runner:
    try:
        return Runner(build_model(scenes, device), kernel=kernel)
    except SceneError:  # scenes that cannot share one ensemble: names their key
        raise
    except ValueError as err:  # a forced kernel that cannot run these scenes here
        raise OptionError("kernel", kernel, str(err).split(": ", 1)[-1]) from None
