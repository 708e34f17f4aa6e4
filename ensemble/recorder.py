"""Recorder: per-chain checks on the device between records, and the records themselves on the host.

``check(state, step)`` launches the record kernel (energy, driver's work, largest overlap and the
status flags, which a non-finite chain's later steps read to freeze it) and folds the result into
running extremes; it never synchronises. ``record(state, r)`` does a check and then copies what the
scenes keep (snapshots, energy, work, the trace ring) into host arrays.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from kernels.records import record_kernel, track_extremes

from .model import Model, State
from .response import ResponseAccumulator


class Recorder:
    """The device reductions and host arrays of one run of ``model``."""

    def __init__(self, model: Model):
        self.model = model
        m, scene = model, model.scenes[0]
        c, dev = m.chain_count, m.device
        self.kernel = record_kernel(m.features)
        self.energy_now = wp.zeros(c, dtype=wp.float64, device=dev)
        self.work_now = wp.zeros(c, dtype=wp.float64, device=dev)
        self.max_overlap_now = wp.zeros(c, dtype=wp.float64, device=dev)
        self.initial_energy = wp.zeros(c, dtype=wp.float64, device=dev)
        self.energy_deviation = wp.zeros(c, dtype=wp.float64, device=dev)
        """Running max over checks of |E − E(0) [− W]| (device)."""
        self.largest_overlap = wp.full(c, -1.0e300, dtype=wp.float64, device=dev)
        """Running max over checks of the largest overlap (device)."""
        damped = m.features.damping != "none"
        self.dissipated_now = wp.zeros(c if damped else 0, dtype=wp.float64, device=dev)
        """Energy dissipated by damping up to the last check, per chain (device; size 0 without damping)."""

        self.real_np = np.float64 if m.features.precision == "float64" else np.float32
        records, n = scene.record_count, m.grain_count
        self.fields = {name: np.zeros((c, records, n), dtype=self.real_np) for name in scene.record.fields}
        self.traced = list(scene.record.traces)
        self.capacity = m.trace_capacity
        self.record_steps = scene.record_steps
        self.stride = scene.trace_stride
        sample_count = scene.trace_sample_count
        self.traces = ({name: np.zeros((c, sample_count, len(self.traced)), dtype=self.real_np)
                        for name in ("u", "v")} if self.traced else {})
        self.trace_t = (np.arange(sample_count) * scene.trace_stride * m.dt) if self.traced else None
        self.energy = np.zeros((c, records))
        self.work = np.zeros((c, records)) if m.features.surface == "driven" else None
        self.dissipated = np.zeros((c, records)) if damped else None
        self.response = ResponseAccumulator(m) if scene.has_response else None

    def load(self) -> None:
        """Compile and load the reduction kernels (before a clock starts)."""
        wp.load_module(self.kernel.module, device=self.model.device)
        wp.load_module(track_extremes.module, device=self.model.device)
        if self.response is not None:
            self.response.load()

    def check(self, state: State, step: int) -> None:
        """Energy, work, largest overlap and status of every chain at ``step`` (device only, no sync)."""
        m = self.model
        wp.launch(self.kernel, dim=m.chain_count,
                  inputs=[state.x, m.inverse_mass, m.contact_constant, m.static_overlap, m.exponent, m.drive,
                          state.work, state.power, step, m.dt, m.validity_overlap],
                  outputs=[self.energy_now, self.work_now, self.max_overlap_now, state.status, m.damping,
                           state.dissipated, self.dissipated_now], device=m.device)
        if step == 0:
            wp.copy(self.initial_energy, self.energy_now)
        wp.launch(track_extremes, dim=m.chain_count,
                  inputs=[self.energy_now, self.work_now, self.initial_energy,
                          int(m.features.surface == "driven"), self.max_overlap_now],
                  outputs=[self.energy_deviation, self.largest_overlap, self.dissipated_now], device=m.device)

    def record(self, state: State, r: int, step: int) -> None:
        """Check at ``step`` and keep record ``r`` (snapshots, energy, work, the traces since record r − 1)."""
        self.check(state, step)
        dt = self.real_np(self.model.dt)
        x = state.x
        if "u" in self.fields:
            self.fields["u"][:, r] = x[0].numpy()
        if "v" in self.fields:
            self.fields["v"][:, r] = x[1].numpy() / dt
        self.energy[:, r] = self.energy_now.numpy()
        if self.work is not None:
            self.work[:, r] = self.work_now.numpy()
        if self.dissipated is not None:
            self.dissipated[:, r] = self.dissipated_now.numpy()
        if self.traced:
            if r == 0:
                self.traces["u"][:, 0] = x[0].numpy()[:, self.traced]
                self.traces["v"][:, 0] = x[1].numpy()[:, self.traced] / dt
            else:
                # sample k (taken at step k·stride) sits in ring slot k % capacity
                rows = slice(int(self.record_steps[r - 1]) // self.stride + 1,
                             int(self.record_steps[r]) // self.stride + 1)
                ring = state.traces.numpy()[:, :, np.arange(rows.start, rows.stop) % self.capacity]
                self.traces["u"][:, rows] = ring[0]
                self.traces["v"][:, rows] = ring[1] / dt
