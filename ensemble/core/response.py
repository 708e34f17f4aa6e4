"""Response windows (docs/drive.md): the device sums of kernels/response.py and their host reduction.

Window w of chain c covers its own ``response_periods`` P_c drive periods from t = response_start + w·P_c·τ_c.
Chain c samples every ``stride[c]`` steps (its own ``Scene.response_stride``: a divisor of its period
in steps), so each period holds a whole number of uniform samples (≥ RESPONSE_MIN_SAMPLES_PER_PERIOD
where the period has that many steps): the rectangle rule over whole periods integrates a periodic
integrand exactly up to aliasing of harmonics ≥ the samples per period, i.e. spectrally. The runner
stops at the union of the chains' sample steps; a chain's sums are the same alone or in any ensemble.
From the sums:

* ``response`` V_k(z) = (c_k/M) Σ_j v(z, t_j) e^{−ikωt_j}, c_0 = 1, c_k = 2 (k ≥ 1), M samples per window;
* ``window_ke`` = (1/M) Σ_j ½ m v²;
* ``driver_open`` = the fraction of samples at which the driver–grain-1 contact is open (δ ≤ 0).
"""

from __future__ import annotations

import numpy as np
import warp as wp
from hertzian.core.chains import ChainSet
from hertzian.core.model import Model, State
from hertzian.core.scene import response_stride_of
from hertzian.kernels.response import response_kernel, response_phases


def chain_periods(model: Model) -> np.ndarray:
    """Drive period of each chain [time], shape (chains,)."""
    scenes = model.scenes
    if isinstance(scenes, ChainSet):
        return np.asarray(scenes.column("excitation.drive_period"), dtype=float)
    return np.array([s.excitation.drive_period for s in scenes])


def chain_window_periods(model: Model) -> np.ndarray:
    """Drive periods per response window of each chain (``record.response_periods``), shape (chains,): chains
    of one launch may differ (τ = 10 with windows of one period beside τ = 1 with windows of ten)."""
    scenes = model.scenes
    if isinstance(scenes, ChainSet):
        return np.rint(scenes.column("record.response_periods")).astype(np.int64)
    return np.array([s.record.response_periods for s in scenes], dtype=np.int64)


class ResponseAccumulator:
    """Device sums of one run's response windows, sampled every ``stride`` steps."""

    def __init__(self, model: Model):
        self.model = model
        scene = model.scenes[0]
        r = scene.record
        c, n, dev = model.chain_count, model.grain_count, model.device
        self.windows, self.harmonics = r.response_windows, r.harmonics
        self.periods = chain_window_periods(model)
        """Drive periods per window, per chain."""
        self.period_steps = np.rint(chain_periods(model) / model.dt).astype(np.int64)
        self.stride = np.array([response_stride_of([p]) for p in self.period_steps], dtype=np.int64)
        """Steps between a chain's samples (each chain's own), shape (chains,)."""
        self.start_step = scene.response_start_step
        self.window_steps = self.period_steps * self.periods
        self.end_step = self.start_step + int(self.window_steps.max()) * self.windows
        self.kernel = response_kernel(model.features)
        self.window_steps_device = wp.array(self.window_steps, dtype=wp.int64, device=dev)
        self.stride_device = wp.array(self.stride, dtype=wp.int64, device=dev)
        self.phases = wp.zeros((c, self.harmonics + 1, 2), dtype=wp.float64, device=dev)
        """cos(kωt), sin(kωt) per chain at the current sample step (scratch of ``response_phases``)."""
        pairs = np.unique(np.stack([self.stride, self.window_steps], axis=1), axis=0)
        self._schedules = [(int(s), self.start_step + int(w) * self.windows) for s, w in pairs]
        """(stride, end step) of each distinct sampling schedule."""
        shape = (c, self.windows, self.harmonics + 1, n)
        self.re = wp.zeros(shape, dtype=wp.float64, device=dev)
        self.im = wp.zeros(shape, dtype=wp.float64, device=dev)
        self.kinetic = wp.zeros((c, self.windows, n), dtype=wp.float64, device=dev)
        self.open_count = wp.zeros((c, self.windows), dtype=wp.float64, device=dev)

    def load(self) -> None:
        wp.load_module(self.kernel.module, device=self.model.device)
        wp.load_module(response_phases.module, device=self.model.device)

    def sample_steps(self, after: int, upto: int) -> list[int]:
        """Steps in (after, upto] at which some chain samples (and step 0 itself when ``after`` is −1), sorted."""
        steps = []
        for stride, end in self._schedules:
            first = max(self.start_step, after + 1)
            first = self.start_step + -(-(first - self.start_step) // stride) * stride
            last = min(upto, end - 1)
            if first <= last:
                steps.append(np.arange(first, last + 1, stride, dtype=np.int64))
        if not steps:
            return []
        return np.unique(np.concatenate(steps)).tolist()

    def sample(self, state: State) -> None:
        """Add ``state`` to the sums of the windows that hold its step (read from its clock on the device: no
        sync, and capturable in a CUDA graph)."""
        m = self.model
        wp.launch(
            response_phases,
            dim=m.chain_count,
            inputs=[
                m.drive,
                self.window_steps_device,
                self.stride_device,
                self.start_step,
                state.clock,
                self.windows,
                self.harmonics,
                m.dt,
            ],
            outputs=[self.phases],
            device=m.device,
        )
        wp.launch(
            self.kernel,
            dim=(m.chain_count, m.grain_count),
            inputs=[
                state.x,
                m.inverse_mass,
                m.contact_constant,
                m.static_overlap,
                m.law_parameters,
                self.window_steps_device,
                self.stride_device,
                self.start_step,
                state.clock,
                self.windows,
                self.harmonics,
                m.dt,
                self.phases,
            ],
            outputs=[self.re, self.im, self.kinetic, self.open_count],
            device=m.device,
        )

    def result(self) -> dict[str, np.ndarray]:
        """``response`` (chains, window, harmonic, grain) complex, ``window_ke`` (chains, window, grain),
        ``driver_open`` (chains, window), ``window_start`` (chains, window) [time]."""
        samples = (self.window_steps // self.stride).astype(float)  # M per chain (own stride)
        weight = np.full(self.harmonics + 1, 2.0)
        weight[0] = 1.0
        response = (self.re.numpy() + 1j * self.im.numpy()) * (
            weight[None, None, :, None] / samples[:, None, None, None]
        )
        starts = (self.start_step + self.window_steps[:, None] * np.arange(self.windows)[None, :]) * self.model.dt
        return {
            "response": response,
            "window_ke": self.kinetic.numpy() / samples[:, None, None],
            "driver_open": self.open_count.numpy() / samples[:, None],
            "window_start": starts,
        }
