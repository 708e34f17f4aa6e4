"""Normal-mode energies recorded on the device (``record.modes``; kernels/spectrum.py, docs/lattices.md).

At every record the chains' harmonic mode energies E_k (hertzian.core.modes' basis and frequencies), their spectral
entropy and participation number are computed on the device into arrays that hold the whole run; the host reads
them once, at the end.
"""

from __future__ import annotations

import numpy as np
import warp as wp
from hertzian.core.model import Model, State
from hertzian.core.modes import normal_modes
from hertzian.kernels.spectrum import mode_energy_kernel, spectral_summary

DEVICE_BYTES = 1 << 30
"""Largest device memory the recorded mode energies may take [bytes] (records × chains × modes × 8)."""


def spectrum_kernels(features) -> list:
    """The Warp kernels ``record.modes`` launches for ``features`` (named ahead by hertzian warmup and the runner)."""
    return [
        mode_energy_kernel(features.precision, features.nordsieck_values if features.compensation else 0),
        spectral_summary,
    ]


class SpectrumRecorder:
    """The mode energies, spectral entropy and participation number of every chain at every record."""

    def __init__(self, model: Model):
        scene = model.scenes[0]
        numbers, basis, omega = normal_modes(scene)
        records, c = scene.record_count, model.chain_count
        size = records * c * len(numbers) * 8
        if size > DEVICE_BYTES:
            from hertzian.core.errors import SceneError

            raise SceneError(
                "record.modes",
                True,
                f"{records} records × {c} chains × {len(numbers)} modes take {size / 2**30:.1f} "
                f"GiB, more than {DEVICE_BYTES / 2**30:g}: record less often (record.every) or run fewer chains",
            )
        self.model = model
        self.mode = numbers
        self.frequency = omega
        dev = model.device
        self.basis = wp.array(basis, dtype=wp.float64, device=dev)
        self.omega = wp.array(omega, dtype=wp.float64, device=dev)
        self.energy = wp.zeros((records, c, len(numbers)), dtype=wp.float64, device=dev)
        self.entropy = wp.zeros((records, c), dtype=wp.float64, device=dev)
        self.participation = wp.zeros((records, c), dtype=wp.float64, device=dev)
        self.kernel = spectrum_kernels(model.features)[0]
        self.mass = float(scene.chain.mass)

    def load(self) -> None:
        """Compile and load the kernels (before a clock starts)."""
        wp.load_module(self.kernel.module, device=self.model.device)
        wp.load_module(spectral_summary.module, device=self.model.device)

    def sample(self, state: State, r: int) -> None:
        """Record r's mode energies and their summary (queued on the device, no wait)."""
        m = self.model
        wp.launch(
            self.kernel,
            dim=(m.chain_count, len(self.mode)),
            inputs=[state.x, self.basis, self.omega, self.mass, m.dt, r],
            outputs=[self.energy],
            device=m.device,
        )
        wp.launch(
            spectral_summary,
            dim=m.chain_count,
            inputs=[self.energy, self.omega, r],
            outputs=[self.entropy, self.participation],
            device=m.device,
        )

    def result(self) -> dict[str, np.ndarray]:
        """``mode_energy`` (chains, records, modes), ``spectral_entropy`` and ``participation`` (chains, records)."""
        return {
            "mode_energy": np.ascontiguousarray(self.energy.numpy().transpose(1, 0, 2)),
            "spectral_entropy": np.ascontiguousarray(self.entropy.numpy().T),
            "participation": np.ascontiguousarray(self.participation.numpy().T),
        }
