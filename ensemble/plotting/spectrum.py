"""The picture of a store with normal-mode energies (``record.modes``; docs/lattices.md): E_k(t) of every mode on a
log scale, and the spectral entropy and participation number against time."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hertzian.core.outputs import PNG_METADATA


def plot_spectrum_point(point, out: Path, plt, *, time_unit: str, energy_unit: str, where: str = "") -> Path:
    """One point: E_k(t) coloured by mode number, then S(t) and the participation number (its own axis); ``plt`` is
    the caller's pyplot, the units its labels, ``where`` the point's sweep coordinates (empty for a run)."""
    fig, axes = plt.subplots(2, 1, figsize=(7.0, 6.5), squeeze=False)
    axes = axes[:, 0]
    t = point.t.values
    energy = point.mode_energy.values
    modes = point.mode.values
    colours = plt.get_cmap("viridis")(np.linspace(0.0, 1.0, len(modes)))
    floor = max(float(np.nanmax(energy)) * 1e-16, 1e-300)
    for k, colour in zip(range(len(modes)), colours):
        axes[0].plot(t, np.maximum(energy[:, k], floor), color=colour, lw=0.7)
    axes[0].set_yscale("log")
    axes[0].set_ylabel(f"E_k [{energy_unit}]")
    axes[0].set_title(
        f"harmonic mode energies, modes {modes[0]} (dark) … {modes[-1]} (light)" + (f"; {where}" if where else "")
    )
    axes[1].plot(t, point.spectral_entropy.values, color="C0", label="spectral entropy S")
    axes[1].set_ylabel("S = −Σ e_k ln e_k", color="C0")
    twin = axes[1].twinx()
    twin.plot(t, point.participation.values, color="C3", lw=0.8, label="participation number")
    twin.set_ylabel("participation 1/Σ e_k²", color="C3")
    axes[1].set_xlabel(f"t [{time_unit}]")
    fig.tight_layout()
    fig.savefig(out, dpi=120, metadata=PNG_METADATA)
    plt.close(fig)
    return out
