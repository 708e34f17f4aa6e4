"""The functions behind ``import hertzian as hz`` that are not one of the library's own: loading a scene from a
file, a shipped name or a parsed table; running scenes with the checks of ``hertzian run``; opening a store.

Bad input raises one line, as the command line prints it: :class:`~hertzian.core.scene.SceneError` for a scene
key, :class:`~hertzian.core.errors.OptionError` for an argument, :class:`~hertzian.core.errors.RefusedError` for a
run that cannot fit.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from hertzian.core import runner as core_runner
from hertzian.core import timeline
from hertzian.core.check import memory_refusal
from hertzian.core.devices import check_device
from hertzian.core.errors import OptionError, RefusedError, check_path
from hertzian.core.model import build_model
from hertzian.core.runner import Runner
from hertzian.core.scene import Scene, SceneError, apply_overrides, scene_from_dict
from hertzian.core.scene import load_scene as load_scene_file
from hertzian.core.shipped import shipped_file
from hertzian.core.solvers import KERNELS


def load_scene(source: str | Path | dict, overrides: dict[str, Any] | None = None) -> Scene:
    """A scene from a TOML file (a path, or the name of a shipped example such as ``impact``) or from a parsed TOML
    table (a dict), with ``overrides`` ({"chain.l0": 1e-4, …}) applied; validated."""
    if isinstance(source, dict):
        return scene_from_dict(apply_overrides(source, overrides or {}, replacing=True))
    if not isinstance(source, (str, Path)):
        raise OptionError("source", type(source).__name__, "a path, a shipped example's name (e.g. 'impact') or a dict")
    return load_scene_file(shipped_file(source), overrides)


@dataclass(frozen=True)
class RunResult(core_runner.RunResult):
    """What ``hz.run`` returns: the run's arrays (``hertzian.core.runner.RunResult``: a leading chain dimension) and
    the dataset ``hertzian run --out`` stores (:meth:`to_xarray`)."""

    def to_xarray(self, axes: dict[str, Any] | None = None):
        """The result as an in-memory ``xarray.Dataset`` with the variables, dimensions and attributes (units
        included) of the store ``hertzian run --out`` writes. ``axes`` (name → coordinate values, C order) shape an
        ensemble's chains; without them an ensemble has one axis ``chain``."""
        from hertzian.sweeping.sweep_store import result_dataset  # the store layer: xarray and Zarr load here

        return result_dataset(self, axes)

    @classmethod
    def of(cls, result: core_runner.RunResult) -> RunResult:
        """``result`` (the same arrays, not copied) as a RunResult with its dataset."""
        return cls(**{f.name: getattr(result, f.name) for f in fields(result)})


@dataclass
class PreparedRun:
    """A run that passed every check of ``hertzian run`` and ``hz.run`` (the one path of both), built and ready to
    integrate. ``notes``: what to tell the user before it runs ('warning: …', 'note: …' lines). A scene with
    ``integrator.tolerance`` has no runner yet: :meth:`run` runs the pilot runs, and keeps their ``choice``."""

    scenes: list[Scene]
    device: str
    kernel: str
    runner: Runner | None
    notes: list[str] = field(default_factory=list)
    choice: Any = None
    """The tolerance's ``ToleranceChoice`` once :meth:`run` has run a tolerance scene, else None."""

    def run(self, progress: Callable[[int, int], None] | None = None) -> RunResult:
        """Integrate (``progress(done_records, total_records)`` after each record; not for a tolerance run)."""
        if self.runner is not None:
            return RunResult.of(self.runner.run(progress))
        from hertzian.core.error_estimate import meet_tolerance

        self.choice = meet_tolerance(self.scenes, lambda chosen: _runner(chosen, self.device, self.kernel).run())
        return RunResult.of(self.choice.result)


def _scene_list(scenes) -> list[Scene]:
    """``scenes`` (a Scene, or an iterable of them) as a list; anything else is one line naming what was given."""
    listed = [scenes] if isinstance(scenes, Scene) else None
    if listed is None and not isinstance(scenes, (str, bytes, Path, dict)):
        try:
            listed = list(scenes)
        except TypeError:
            listed = None
    if not listed or not all(isinstance(s, Scene) for s in listed):
        shown = scenes if isinstance(scenes, (str, Path)) else type(scenes).__name__
        shown = f"{shown} of {len(listed)}" if listed is not None else shown
        raise OptionError("scenes", shown, "a Scene or a non-empty list of Scenes (hz.load_scene makes one)")
    return listed


def prepare_run(
    scenes: Scene | Iterable[Scene], device: str | None = None, *, kernel: str = "auto", strict: bool = False
) -> PreparedRun:
    """Check and build a run: the scenes (one, or compatible ones as one ensemble), the kernel, the memory (of the
    host before Warp starts, then of the GPU), the step (``hertzian check``'s warning: a note, or with ``strict`` a
    :class:`RefusedError`; a tolerance scene's step is chosen by its pilot runs), the device; then the model and
    its runner, with a note where ``auto`` leaves a launch group on the per-step kernel or takes event-aware steps.
    Bad input raises one line (OptionError, SceneError, RefusedError)."""
    from hertzian.core.check import dt_warning
    from hertzian.core.devices import open_device
    from hertzian.core.solvers.calibrate import event_cost_note

    scenes = _scene_list(scenes)
    if kernel not in KERNELS:
        raise OptionError("kernel", kernel, f"one of {', '.join(KERNELS)}")
    largest = max(scenes, key=lambda s: s.chain.grains)
    too_big = memory_refusal(largest, chains=len(scenes))  # the host first, before Warp starts
    if too_big:
        raise RefusedError(too_big)
    notes = []
    tolerance = scenes[0].integrator.tolerance is not None
    unsafe = None if tolerance else next(filter(None, (dt_warning(s) for s in dict.fromkeys(scenes))), None)
    if unsafe and strict:
        raise RefusedError(unsafe)
    if unsafe:
        notes.append(f"warning: {unsafe}")
    dev = check_device(device)
    open_device(dev)
    too_big = memory_refusal(largest, dev, chains=len(scenes)) if dev.startswith("cuda") else None
    if too_big:
        raise RefusedError(too_big)
    if tolerance:  # pilot runs pick the step (and, with "auto", the method): nothing to build yet
        return PreparedRun(scenes, dev, kernel, None, notes)
    timeline.mark("library_imported")
    runner = _runner(scenes, dev, kernel, mark=True)
    if runner.kernel_note:
        notes.append(f"note: per-step kernel: {runner.kernel_note}")
    events = event_cost_note(runner.model.features, runner.model.device.is_cpu)
    if events:
        notes.append(f"note: {events}")
    return PreparedRun(scenes, dev, kernel, runner, notes)


def run(
    scenes: Scene | Iterable[Scene],
    device: str | None = None,
    *,
    kernel: str = "auto",
    progress: Callable[[int, int], None] | None = None,
    strict: bool = False,
) -> RunResult:
    """Run one scene, or compatible scenes as one ensemble, on ``device`` ('cpu', 'cuda', 'cuda:N'; default: cuda if
    present, else cpu) with the solver ``kernel`` ('auto' or one of hertzian.core.solvers.KERNELS; results are the
    same), through the checks of ``hertzian run`` (:func:`prepare_run`: its warnings come as Python warnings;
    ``strict`` refuses a step that looks unstable or inaccurate). ``progress(done_records, total_records)`` is
    called after each record. Times are in program units (1.0102e-3 s); ``RunResult.to_xarray()`` gives what
    ``hertzian run --out`` stores. Scenes with ``integrator.tolerance`` run as ``hertzian run`` runs them: pilot runs
    pick the step (and, with ``integrator.method = "auto"``, the method); ``progress`` is not called then."""
    prepared = prepare_run(scenes, device, kernel=kernel, strict=strict)
    for line in prepared.notes:
        if line.startswith("warning: "):
            warnings.warn(line.removeprefix("warning: "), stacklevel=2)
    return prepared.run(progress)


def _runner(scenes: list[Scene], device: str, kernel: str, *, mark: bool = False) -> Runner:
    """The model of ``scenes`` on ``device`` and its runner (``mark``: the timeline's ``model_built`` between)."""
    try:
        model = build_model(scenes, device)
        if mark:
            timeline.mark("model_built")
        return Runner(model, kernel=kernel)
    except SceneError:  # scenes that cannot share one ensemble: names their key
        raise
    except ValueError as err:  # a forced kernel that cannot run these scenes here
        raise OptionError("kernel", kernel, str(err).split(": ", 1)[-1]) from None


def design(
    path: str | Path,
    out: str | Path,
    device: str | None = None,
    *,
    resume: bool = False,
    overwrite: bool = False,
    scene_overrides: dict[str, Any] | None = None,
    **overrides: Any,
):
    """Run ``hertzian design``: the design file ``path`` (``overrides`` replace its ``[design]`` keys, e.g.
    ``generations=10``; ``scene_overrides`` dotted keys of its ``[scene]``, e.g. ``{"chain.grains": 40}``) into the
    store ``out``; returns a ``DesignResult`` (best objective, genome and scene; with
    several objectives, the Pareto front). Bad input raises one line (OptionError, SceneError) before anything
    runs."""
    from hertzian.studies.design import load_design, optimise
    from hertzian.sweeping.storage import check_out

    check_path("path", path)
    check_path("out", out)
    scene, spec = load_design(shipped_file(path), overrides, scene_overrides)
    check_out(out, overwrite=overwrite, resume=resume)
    return optimise(scene, spec, out, device=check_device(device), resume=resume)


def open_store(path: str | Path):
    """A store as a labelled ``xarray.Dataset``: one ``hertzian run`` or ``hertzian sweep`` wrote
    (hertzian.sweeping.store.open_dataset, lazy), or a design store (hertzian.studies.design_store.design_dataset);
    FileNotFoundError or ValueError (one line) for anything else, StoreDamagedError for a damaged store."""
    from hertzian.studies.design_store import design_dataset, is_design_store

    check_path("path", path)
    if is_design_store(path):
        return design_dataset(path)
    from hertzian.sweeping.store import open_dataset

    return open_dataset(path)
