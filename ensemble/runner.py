"""Run an ensemble: step between records (a CUDA graph on GPUs), reduce on the device at records.

``run_ensemble(scenes)`` is the whole job for compatible scenes; ``run_scene(scene)`` runs one.
The host synchronises only at record times; everything between two records is launched
without reading anything back.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import warp as wp

from kernels.features import Features
from kernels.records import record_kernel, track_extremes
from kernels.step import step_kernel

from .model import Model, State, build_model
from .scene import Scene
from .status import Status

GRAPH_STEPS = 512
"""Steps per captured CUDA graph (even, so that the ping-pong parity is unchanged by a replay)."""
MONITOR_MIN_STEPS = 512
MONITOR_STEPS_PER_GRAIN = 16
"""Between records, energy, overlap and finiteness are also checked on the device every
max(MONITOR_MIN_STEPS, MONITOR_STEPS_PER_GRAIN · grains) steps (the check loops over a chain's
grains in one thread, so its cadence scales with the grain count to cost ≲ 1 %)."""


class Stepper:
    """Advances a model's state: ``step(state_in, state_out)`` never reads and writes one buffer."""

    def __init__(self, model: Model):
        self.model = model
        self.kernel = step_kernel(model.features)

    def launch_args(self, state_in: State, state_out: State, trace_buffer: wp.array, status: wp.array):
        m = self.model
        scene = m.scenes[0]
        inputs = [state_in.x, state_in.clock, m.inverse_mass, m.contact_constant, m.static_overlap, m.exponent,
                  m.drive, status, m.trace_slot, scene.trace_stride, state_in.work, state_in.power, m.dt]
        outputs = [state_out.x, state_out.clock, trace_buffer, state_out.work, state_out.power]
        return inputs, outputs

    def step(self, state_in: State, state_out: State, trace_buffer: wp.array, status: wp.array) -> None:
        """One step for every chain; ``status`` (per chain) freezes non-finite chains."""
        inputs, outputs = self.launch_args(state_in, state_out, trace_buffer, status)
        wp.launch(self.kernel, dim=(self.model.chain_count, self.model.grain_count), inputs=inputs,
                  outputs=outputs, device=self.model.device)

    def recorded_launch(self, state_in: State, state_out: State, trace_buffer: wp.array, status: wp.array):
        inputs, outputs = self.launch_args(state_in, state_out, trace_buffer, status)
        return wp.launch(self.kernel, dim=(self.model.chain_count, self.model.grain_count), inputs=inputs,
                         outputs=outputs, device=self.model.device, record_cmd=True)


@dataclass
class RunResult:
    """What a run produced, as numpy arrays with a leading chain dimension."""

    scenes: tuple[Scene, ...]
    features: Features
    device: str
    t: np.ndarray
    """Record times, shape (R,)."""
    energy: np.ndarray
    """Energy relative to the static state, shape (chains, R). Differs from SPEC §5's E by a constant per chain."""
    work: np.ndarray | None
    """Driver's work up to each record, shape (chains, R), driven scenes only."""
    status: np.ndarray
    """Per-chain status code (see ensemble.status.Status), shape (chains,)."""
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
    kernel: str = "step"
    """Which kernel advanced the state: 'step' (one step per launch) or a fused kernel's description."""
    """Trace samples by name ('u', 'v'), each (chains, S, traced)."""

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
    """Integrates one model from t = 0 to its scenes' duration, keeping what the scenes ask for."""

    def __init__(self, model: Model, *, use_graph: bool | None = None, energy_tolerance: float = 1e-2,
                 kernel: str = "auto", monitor_every: int | None = None):
        self.model = model
        self.monitor_every = (max(MONITOR_MIN_STEPS, MONITOR_STEPS_PER_GRAIN * model.grain_count)
                              if monitor_every is None else monitor_every)
        """Steps between device-side checks of energy, overlap and finiteness (0: at records only)."""
        self.stepper = Stepper(model)
        self.record = record_kernel(model.features)
        self.use_graph = model.device.is_cuda if use_graph is None else use_graph
        self.energy_tolerance = energy_tolerance
        scene = model.scenes[0]
        c, real, dev = model.chain_count, model.real, model.device
        self.buffers = (model.initial_state(), model.state())
        self.parity = 0
        traced = len(scene.record.traces)
        capacity = scene.steps_per_record // scene.trace_stride if traced else 0
        self.trace_buffer = wp.zeros((2, c, capacity, traced) if traced else (2, 0, 0, 0), dtype=real, device=dev)
        self.energy = wp.zeros(c, dtype=wp.float64, device=dev)
        self.work = wp.zeros(c, dtype=wp.float64, device=dev)
        self.max_overlap = wp.zeros(c, dtype=wp.float64, device=dev)
        self.status = wp.zeros(c, dtype=wp.int32, device=dev)
        self.initial_energy = wp.zeros(c, dtype=wp.float64, device=dev)
        self.energy_deviation = wp.zeros(c, dtype=wp.float64, device=dev)
        self.largest_overlap = wp.full(c, -1.0e300, dtype=wp.float64, device=dev)
        self.graphs: dict[tuple[int, int], object] = {}
        self.commands = None
        # many steps per launch where the features allow (``kernel``: see ensemble/calibrate.py); None: per-step
        from .calibrate import make_stepper

        self.fused = make_stepper(model, kernel, run_steps=scene.step_count)
        if self.fused is not None:
            self.fused.load()

    # ---- stepping -----------------------------------------------------------------
    def _plain(self, n_steps: int) -> None:
        if self.commands is None:
            a, b = self.buffers
            self.commands = (self.stepper.recorded_launch(a, b, self.trace_buffer, self.status),
                             self.stepper.recorded_launch(b, a, self.trace_buffer, self.status))
        for _ in range(n_steps):
            self.commands[self.parity].launch()
            self.parity ^= 1

    def _graph(self, n_steps: int) -> None:
        key = (n_steps, self.parity)
        if key not in self.graphs:
            parity = self.parity
            with wp.ScopedCapture(device=self.model.device) as capture:
                for _ in range(n_steps):
                    self.stepper.step(self.buffers[parity], self.buffers[parity ^ 1], self.trace_buffer,
                                      self.status)
                    parity ^= 1
            self.graphs[key] = capture.graph
        wp.capture_launch(self.graphs[key])
        self.parity ^= n_steps & 1

    def advance(self, n_steps: int) -> None:
        """Take ``n_steps`` steps (no host synchronisation)."""
        if self.fused is not None:
            self.parity = self.fused.advance(self.buffers, self.parity, self.status, n_steps,
                                             use_graph=self.use_graph)
            return
        if not self.use_graph:
            self._plain(n_steps)
            return
        while n_steps >= GRAPH_STEPS:
            self._graph(GRAPH_STEPS)
            n_steps -= GRAPH_STEPS
        if n_steps:
            self._graph(n_steps)

    @property
    def current(self) -> State:
        return self.buffers[self.parity]

    def reduce(self, step: int) -> None:
        """Energy, work, largest overlap and status of every chain at ``step`` (device only, no sync)."""
        m, s = self.model, self.current
        wp.launch(self.record, dim=m.chain_count,
                  inputs=[s.x, m.inverse_mass, m.contact_constant, m.static_overlap, m.exponent, m.drive,
                          s.work, s.power, step, m.dt, m.validity_overlap],
                  outputs=[self.energy, self.work, self.max_overlap, self.status], device=m.device)
        if step == 0:
            wp.copy(self.initial_energy, self.energy)
        wp.launch(track_extremes, dim=m.chain_count,
                  inputs=[self.energy, self.work, self.initial_energy, int(m.features.surface == "driven"),
                          self.max_overlap],
                  outputs=[self.energy_deviation, self.largest_overlap], device=m.device)

    def advance_monitored(self, first_step: int, n_steps: int) -> None:
        """``advance`` in pieces of ``monitor_every`` steps with a device-side check after each piece."""
        every = self.monitor_every if self.monitor_every > 0 else n_steps
        done = 0
        while done < n_steps:
            piece = min(every, n_steps - done)
            self.advance(piece)
            done += piece
            if done < n_steps:
                self.reduce(first_step + done)

    # ---- the run --------------------------------------------------------------------
    def run(self, progress=None) -> RunResult:
        """Integrate to the end; ``progress(done_records, total_records)`` is called after each record."""
        m = self.model
        scene = m.scenes[0]
        real_np = np.float64 if m.features.precision == "float64" else np.float32
        # records at these steps; the pieces between them may differ in length (ensemble/scene.py)
        records, record_steps, stride = scene.record_count, scene.record_steps, scene.trace_stride
        c, n = m.chain_count, m.grain_count
        fields = {name: np.zeros((c, records, n), dtype=real_np) for name in scene.record.fields}
        traced = len(scene.record.traces)
        capacity = self.trace_buffer.shape[2]
        sample_count = scene.trace_sample_count
        traces = {name: np.zeros((c, sample_count, traced), dtype=real_np) for name in ("u", "v")} if traced else {}
        energy = np.zeros((c, records))
        work = np.zeros((c, records)) if m.features.surface == "driven" else None

        # compile before the clock starts (the per-step kernel only where it is the one that runs)
        if self.fused is None:
            wp.load_module(self.stepper.kernel.module, device=m.device)
        wp.load_module(self.record.module, device=m.device)
        wp.load_module(track_extremes.module, device=m.device)
        wp.synchronize_device(m.device)
        start = time.perf_counter()

        def take_record(r: int) -> None:
            self.reduce(int(record_steps[r]))
            x = self.current.x
            if "u" in fields:
                fields["u"][:, r] = x[0].numpy()
            if "v" in fields:
                fields["v"][:, r] = x[1].numpy() / real_np(m.dt)
            energy[:, r] = self.energy.numpy()
            if work is not None:
                work[:, r] = self.work.numpy()
            if traced:
                if r == 0:
                    traces["u"][:, 0] = x[0].numpy()[:, list(scene.record.traces)]
                    traces["v"][:, 0] = x[1].numpy()[:, list(scene.record.traces)] / real_np(m.dt)
                else:
                    # sample k (at step k·stride) sits in ring slot k % capacity
                    rows = slice(int(record_steps[r - 1]) // stride + 1, int(record_steps[r]) // stride + 1)
                    buffer = self.trace_buffer.numpy()[:, :, np.arange(rows.start, rows.stop) % capacity]
                    traces["u"][:, rows] = buffer[0]
                    traces["v"][:, rows] = buffer[1] / real_np(m.dt)
            if progress is not None:
                progress(r + 1, records)

        take_record(0)
        for r in range(1, records):
            self.advance_monitored(int(record_steps[r - 1]), int(record_steps[r] - record_steps[r - 1]))
            take_record(r)
        wp.synchronize_device(m.device)
        wall = time.perf_counter() - start

        status = self.status.numpy().copy()
        max_overlap = self.largest_overlap.numpy()
        # max over records and the checks between them (the records alone would miss peaks in between)
        energy_error = energy_errors(energy, work, m.injected_energy, deviation=self.energy_deviation.numpy())
        drift = (status == Status.OK) & (energy_error > self.energy_tolerance) & (
            (m.injected_energy > 0) | (work is not None))
        status[drift] = Status.ENERGY_DRIFT
        return RunResult(
            scenes=m.scenes, features=m.features, device=str(m.device),
            t=record_steps * m.dt, energy=energy, work=work, status=status,
            max_overlap=max_overlap, energy_error=energy_error, wall_seconds=wall,
            steps=int(record_steps[-1]), fields=fields,
            trace_t=(np.arange(sample_count) * stride * m.dt) if traced else None, traces=traces,
            kernel="step" if self.fused is None else self.fused.describe(),
        )


def energy_errors(energy: np.ndarray, work: np.ndarray | None, injected: np.ndarray, *,
                  deviation: np.ndarray | None = None) -> np.ndarray:
    """SPEC §5: max_t |E(t) − E(0)| / E_inj; driven: |E − E(0) − W| / max|W|; absolute if nothing injected.

    ``energy``/``work`` are the records (chains, R); ``deviation`` (chains,), if given, is the running
    max of |E − E(0) [− W]| over finer device-side checks and is folded into the max.
    """
    change = energy - energy[:, :1]
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


def default_device() -> str:
    """'cuda' when a CUDA device is present, else 'cpu'."""
    return "cuda" if wp.is_cuda_available() else "cpu"


def run_ensemble(scenes: list[Scene], device: str | None = None, *, progress=None,
                 use_graph: bool | None = None) -> RunResult:
    """Run compatible scenes as one ensemble (one kernel launch per step for all chains)."""
    wp.init()
    model = build_model(list(scenes), device or default_device())
    return Runner(model, use_graph=use_graph).run(progress)


def run_scene(scene: Scene, device: str | None = None, *, progress=None) -> RunResult:
    """Run one scene (an ensemble of one)."""
    return run_ensemble([scene], device, progress=progress)
