"""Run an ensemble: start → for each record: advance (a solver) → record → hand off.

``run_ensemble(scenes)`` is the whole job for compatible scenes; ``run_scene(scene)`` runs one.
The host synchronises only at record times; everything between two records is launched
without reading anything back. Stepping is the solver's (ensemble/core/solvers), the device checks
and host copies the recorder's (ensemble/core/recorder.py); this module only sequences them.
"""

from __future__ import annotations

import contextlib
import gc
import time
from dataclasses import dataclass, field, replace

import numpy as np
import warp as wp
from hertzian.core import timeline
from hertzian.core.devices import default_device, init_warp
from hertzian.core.error_estimate import mark_uncertain, meet_tolerance, model_orders, richardson_error, shadow_model
from hertzian.core.model import Model, State, build_model
from hertzian.core.recorder import Recorder
from hertzian.core.scene import Scene, SceneError
from hertzian.core.solvers import SolverConfig, choose_config, make_solver
from hertzian.core.solvers.calibrate import fused_lacks, step_reason
from hertzian.core.solvers.prepare import Need, prepare_kernels
from hertzian.core.spectrum import spectrum_kernels
from hertzian.core.status import Status
from hertzian.kernels.features import Features


@contextlib.contextmanager
def frozen_collector():
    """While a run's loop queues launches and records, the objects made before it (Warp's kernels and their syntax
    trees, the model, the store's handles) are frozen for Python's garbage collector, so its full passes skip them: a
    full pass over them stops every thread, and in a long run on a GPU the device then runs out of queued work.
    Unfrozen on exit."""
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


SAMPLED_PIECES_PER_GRAPH = 64
"""Advance-and-sample pieces of the response windows per captured CUDA graph (Runner._advance_sampled)."""
MONITOR_MIN_STEPS = 512
MONITOR_STEPS_PER_GRAIN = 16
"""Between records, energy, overlap and finiteness are also checked on the device every
max(MONITOR_MIN_STEPS, MONITOR_STEPS_PER_GRAIN · grains) steps (the check loops over a chain's
grains in one thread, so its cadence scales with the grain count to cost ≲ 1 %)."""


@dataclass(frozen=True)
class RunResult:
    """What a run produced, as numpy arrays with a leading chain dimension."""

    scenes: tuple[Scene, ...]
    features: Features
    device: str
    t: np.ndarray
    """Record times, shape (R,)."""
    energy: np.ndarray
    """Energy relative to the static state, shape (chains, R). Differs from docs/model.md §5's E by a constant per chain."""
    work: np.ndarray | None
    """Driver's work up to each record, shape (chains, R), driven scenes only."""

    status: np.ndarray
    """Per-chain status code (see hertzian.core.status.Status), shape (chains,)."""
    max_overlap: np.ndarray
    """Largest overlap seen at any record [length], shape (chains,)."""
    energy_error: np.ndarray
    """max_t |E(t) − E(0) [− W(t)]| / E_inj (absolute where nothing is injected), shape (chains,)."""
    wall_seconds: float
    steps: int
    fields: dict[str, np.ndarray] = field(default_factory=dict)
    """Snapshots by name ('u', 'v'), each (chains, R, grains)."""
    trace_t: np.ndarray | None = None
    traces: dict[str, np.ndarray] = field(default_factory=dict)
    """Trace samples by name ('u', 'v'), each (chains, S, traced)."""
    kernel: str = "step"
    """Which solver advanced the state: 'step' (one step per launch), 'chain' or a fused kernel's description."""
    solver: SolverConfig | None = None
    """The SolverConfig that ran."""
    kernel_note: str | None = None
    """Why the per-step kernel ran (a feature or a short run), or None; also appended to ``kernel``."""
    timing: dict = field(default_factory=dict)
    """Seconds: ``setup`` (kernel choice, compile/load; ``setup_in_init`` of it in
    ``Runner.__init__``), ``advance`` (host time in the
    solver; on a CPU the kernels themselves), ``record`` (checks, host copies, unpacking), ``device``
    (CUDA: summed event time of the advances; CPU: = advance), ``wall`` (= wall_seconds)."""
    dissipated: np.ndarray | None = None
    """Energy dissipated by damping up to each record, shape (chains, R), damped scenes only."""
    response: dict[str, np.ndarray] = field(default_factory=dict)
    """Response windows (ensemble/core/response.py): 'response', 'window_ke', 'driver_open', 'window_start'."""
    spectrum: dict[str, np.ndarray] = field(default_factory=dict)
    """With ``record.modes`` (ensemble/core/spectrum.py): 'mode_energy' (chains, R, modes), 'spectral_entropy' and
    'participation' (chains, R)."""
    error_estimate: np.ndarray | None = None
    """Estimated max over records and grains of |u − u_exact| / max|u_exact| [relative], shape (chains,)
    (docs/accuracy.md, ensemble/core/error_estimate.py); None unless ``record.error_estimate``. Its shadow run's
    seconds are ``timing["error_estimate"]``, not part of ``wall_seconds``."""

    @property
    def chain_count(self) -> int:
        return len(self.scenes)

    @property
    def grain_count(self) -> int:
        return self.scenes[0].chain.grains

    @property
    def grain_steps_per_second(self) -> float:
        return self.chain_count * self.grain_count * self.steps / max(self.wall_seconds, 1e-12)

    @property
    def u(self) -> np.ndarray:
        return self.fields["u"]

    @property
    def v(self) -> np.ndarray:
        return self.fields["v"]


class Runner:
    """Integrates one model from t = 0 to its scenes' duration, keeping what the scenes ask for.

    ``kernel``: a SolverConfig, or a kind for ``hertzian.core.solvers.choose_config`` ('auto', 'step', 'tile',
    'window', 'chain'). ``use_graph`` overrides the config's CUDA-graph choice. ``trace_values``: what the result's
    traces keep, ``("u", "v")`` or one of them. ``on_unpacked(recorder, r)``: called once record r is on the host
    (see Recorder). ``traces_on_device``: the traces stay in the state's ring on the device (``current.traces``,
    with ``recorder.traced_start``), none in the result. ``on_queued()``: see the attribute.
    """

    def __init__(
        self,
        model: Model,
        *,
        use_graph: bool | None = None,
        energy_tolerance: float = 1e-2,
        kernel: str | SolverConfig = "auto",
        monitor_every: int | None = None,
        trace_values: tuple[str, ...] = ("u", "v"),
        on_unpacked=None,
        traces_on_device: bool = False,
        on_queued=None,
    ):
        setup_start = time.perf_counter()
        tolerance = model.scenes[0].integrator.tolerance
        if tolerance is not None:
            raise SceneError(
                "integrator.tolerance",
                tolerance,
                "a tolerance picks dt before the run: run it with hertzian.run or hertzian run",
            )
        self.model = model
        self.monitor_every = (
            max(MONITOR_MIN_STEPS, MONITOR_STEPS_PER_GRAIN * model.grain_count)
            if monitor_every is None
            else monitor_every
        )
        """Steps between device-side checks of energy, overlap and finiteness (0: at records only)."""
        self.energy_tolerance = energy_tolerance
        self.buffers = model.state_pair()
        """The two state halves (sharing status and the trace ring); ``current`` is the one holding now."""
        self.current: State = self.buffers[0]
        config = (
            kernel
            if isinstance(kernel, SolverConfig)
            else choose_config(model, kernel, run_steps=model.scenes[0].step_count)
        )
        self.kernel_note = None
        """Why the per-step kernel runs (one line), or None."""
        if config.kind == "step":
            self.kernel_note = (
                step_reason(model, model.scenes[0].step_count)
                if kernel == "auto"
                else f"the fused kernels lack {fused_lacks(model.features, model.device.is_cpu)}"
                if kernel == "fused"
                else "per-step kernel requested"
            )
        if use_graph is not None:
            config = replace(config, use_graph=use_graph)
        prepared = prepare_kernels(
            [
                Need(
                    model.features,
                    model.grain_count,
                    model.chain_count,
                    kernel=config,
                    fields=bool(model.scenes[0].record.fields),
                ),
                *(spectrum_kernels(model.features) if model.scenes[0].record.modes else []),
            ],
            model.device,
        )
        timeline.mark("kernels_loaded", kernel=config.describe(), variants=prepared["loads"])
        self.kernel_request = kernel if isinstance(kernel, str) else "auto"
        """The kernel kind asked for; a shadow run for the error estimate asks for the same."""
        self.solver = make_solver(model, config)
        self.solver.load()
        self.recorder = Recorder(
            model, trace_values=trace_values, on_unpacked=on_unpacked, traces_on_device=traces_on_device
        )
        self.on_queued = on_queued
        """Called with no argument once every launch and record of ``run`` is queued, before it waits for the device
        (a caller's host work, such as allocating page-locked memory for what it will copy, overlaps the run)."""
        self.setup_seconds = time.perf_counter() - setup_start
        """Kernel choice, solver construction and kernel compile/load [s]."""

    def advance(self, n_steps: int) -> None:
        """Take ``n_steps`` steps from ``current`` (no host synchronisation)."""
        other = self.buffers[1] if self.current is self.buffers[0] else self.buffers[0]
        self.current = self.solver.advance(self.current, other, n_steps)

    def advance_monitored(self, first_step: int, n_steps: int) -> None:
        """``advance`` in pieces of ``monitor_every`` steps with a device-side check after each piece,
        stopping also at the response windows' sample steps (sampled on the device, no sync)."""
        every = self.monitor_every if self.monitor_every > 0 else n_steps
        response = self.recorder.response
        samples = set(response.sample_steps(first_step, first_step + n_steps)) if response is not None else set()
        checks = set(range(first_step + every, first_step + n_steps, every))
        done = first_step  # steps taken, or queued in the pending run of samples
        run_gap, run_count = 0, 0  # the pending run: sample-only stops, equally spaced

        def flush() -> None:
            nonlocal run_count
            if run_count:
                self._advance_sampled(run_gap, run_count)
                run_count = 0

        for stop in sorted(samples | checks | {first_step + n_steps}):
            gap = stop - done
            done = stop
            if stop in samples and stop not in checks:
                if run_count and (gap != run_gap or run_count == SAMPLED_PIECES_PER_GRAPH):
                    flush()
                run_gap, run_count = gap, run_count + 1
                continue
            flush()
            self.advance(gap)
            if stop in checks:
                self.recorder.check(self.current, stop)
            if stop in samples:
                response.sample(self.current)
        flush()

    def _advance_sampled(self, gap: int, count: int) -> None:
        """``count`` times: take ``gap`` steps, then add the state to the response windows. On CUDA the whole
        sequence is one captured graph, replayed wherever it recurs (the response kernels read the step from
        the state's clock), so sampling every few steps costs no host round trip per sample."""
        response = self.recorder.response
        solver = self.solver

        def pieces(state_in: State, state_out: State, _n_steps: int) -> State:
            current, other = state_in, state_out
            for _ in range(count):
                end = solver.launches(current, other, gap)
                current, other = end, (other if end is current else current)
                response.sample(current)
            return current

        other = self.buffers[1] if self.current is self.buffers[0] else self.buffers[0]
        if solver.use_graph:
            self.current = solver.graphs.run(pieces, self.current, other, gap * count, tag=("sampled", gap, count))
        else:
            self.current = pieces(self.current, other, gap * count)

    def run(self, progress=None) -> RunResult:
        """Integrate to the end; ``progress(done_records, total_records)`` is called after each record."""
        m, rec = self.model, self.recorder
        scene = m.scenes[0]
        # records at these steps; the pieces between them may differ in length (Scene.record_steps)
        record_steps = [int(k) for k in scene.record_steps]
        clock = time.perf_counter()
        rec.load()  # compile before the clock starts (the solver loaded in __init__)
        wp.synchronize_device(m.device)
        setup = self.setup_seconds + time.perf_counter() - clock
        events = [] if m.device.is_cuda else None
        advance_seconds = record_seconds = 0.0
        with frozen_collector():
            start = time.perf_counter()
            with m.exact_start(self.current):  # t = 0 as it is, not in gear4's steady-state form
                if rec.response is not None and rec.response.start_step == 0:
                    rec.response.sample(self.current)
                clock = time.perf_counter()
                rec.record(self.current, 0, record_steps[0])
            if progress is not None:
                progress(1, len(record_steps))
            record_seconds += time.perf_counter() - clock
            for r, step in enumerate(record_steps[1:], start=1):
                clock = time.perf_counter()
                if events is not None:
                    events.append(wp.get_stream(m.device).record_event(wp.Event(m.device, enable_timing=True)))
                self.advance_monitored(record_steps[r - 1], step - record_steps[r - 1])
                if events is not None:
                    events.append(wp.get_stream(m.device).record_event(wp.Event(m.device, enable_timing=True)))
                advance_seconds += time.perf_counter() - clock
                clock = time.perf_counter()
                rec.record(self.current, r, step)
                if progress is not None:
                    progress(r + 1, len(record_steps))
                record_seconds += time.perf_counter() - clock
            if self.on_queued is not None:
                self.on_queued()
            clock = time.perf_counter()
            rec.finish()
            wp.synchronize_device(m.device)
            rec.release()
        record_seconds += time.perf_counter() - clock
        wall = time.perf_counter() - start
        device_seconds = (
            advance_seconds
            if events is None
            else sum(wp.get_event_elapsed_time(a, b) for a, b in zip(events[::2], events[1::2])) / 1e3
        )
        timing = {
            "setup": setup,
            "setup_in_init": self.setup_seconds,
            "advance": advance_seconds,
            "record": record_seconds,
            "device": device_seconds,
            "wall": wall,
        }

        status = self.current.status.numpy().copy()
        # max over records and the checks between them (the records alone would miss peaks in between)
        energy_error = energy_errors(
            rec.energy, rec.work, m.injected_energy, deviation=rec.energy_deviation.numpy(), dissipated=rec.dissipated
        )
        drift = (
            (status == Status.OK)
            & (energy_error > self.energy_tolerance)
            & ((m.injected_energy > 0) | (rec.work is not None))
        )
        status[drift] = Status.ENERGY_DRIFT
        error_estimate = None
        if scene.record.error_estimate:
            error_estimate, uncertain, timing["error_estimate"] = self.shadow_estimate(rec.fields["u"])
            mark_uncertain(status, uncertain)
        return RunResult(
            scenes=m.scenes,
            features=m.features,
            device=str(m.device),
            t=np.array(record_steps) * m.dt,
            energy=rec.energy,
            work=rec.work,
            status=status,
            max_overlap=rec.largest_overlap.numpy(),
            energy_error=energy_error,
            wall_seconds=wall,
            steps=record_steps[-1],
            fields=rec.fields,
            trace_t=rec.trace_t,
            traces=rec.traces,
            kernel=self.solver.describe() + (f" ({self.kernel_note})" if self.kernel_note else ""),
            solver=self.solver.config,
            kernel_note=self.kernel_note,
            timing=timing,
            dissipated=rec.dissipated,
            response=rec.response.result() if rec.response is not None else {},
            spectrum=rec.spectrum.result() if rec.spectrum is not None else {},
            error_estimate=error_estimate,
        )

    def shadow_estimate(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """(per-chain error estimate of positions ``u`` (chains, records, grains), per chain whether it is
        uncertain, seconds it took): the same chains integrated at 2·dt on the model's arrays, checked at the
        records only, compared there (ensemble/core/error_estimate.py)."""
        clock = time.perf_counter()
        shadow = Runner(shadow_model(self.model), kernel=self.kernel_request, monitor_every=0)
        u_shadow = shadow.run().u
        orders, uncertain = model_orders(self.model, u, u_shadow)
        return richardson_error(u, u_shadow, orders), uncertain, time.perf_counter() - clock


def energy_errors(
    energy: np.ndarray,
    work: np.ndarray | None,
    injected: np.ndarray,
    *,
    deviation: np.ndarray | None = None,
    dissipated: np.ndarray | None = None,
) -> np.ndarray:
    """docs/model.md §5: max_t |E(t) − E(0)| / E_inj; driven: |E − E(0) − W| / max|W|; absolute if nothing injected.
    With damping the dissipated energy D is added: |E + D − E(0) [− W]|.

    ``energy``/``work``/``dissipated`` are the records (chains, R); ``deviation`` (chains,), if given, is the
    running max of |E − E(0) [− W] [+ D]| over finer device-side checks and is folded into the max.
    """
    change = energy - energy[:, :1]
    if dissipated is not None:
        change = change + dissipated
    scale = np.asarray(injected, dtype=float).copy()
    if work is not None:
        change = change - work
        scale = np.max(np.abs(work), axis=1)
    scale = np.where(scale > 0, scale, 1.0)
    with np.errstate(invalid="ignore"):
        largest = np.max(np.abs(change), axis=1)
        if deviation is not None:
            largest = np.where(np.isnan(largest), largest, np.maximum(largest, deviation))
        err = largest / scale
    return np.where(np.isfinite(err), err, np.inf)


def run_ensemble(
    scenes: list[Scene], device: str | None = None, *, progress=None, use_graph: bool | None = None
) -> RunResult:
    """Run compatible scenes as one ensemble (one kernel launch per step for all chains). Scenes with
    ``integrator.tolerance`` run at the step (and method) a search picks (ensemble/core/error_estimate.py)."""
    init_warp()
    device = device or default_device()
    if scenes[0].integrator.tolerance is not None:
        return meet_tolerance(list(scenes), lambda chosen: run_ensemble(chosen, device, use_graph=use_graph)).result
    model = build_model(list(scenes), device)
    return Runner(model, use_graph=use_graph).run(progress)


def run_scene(scene: Scene, device: str | None = None, *, progress=None) -> RunResult:
    """Run one scene (an ensemble of one)."""
    return run_ensemble([scene], device, progress=progress)
