"""Harmonic normal modes of a uniform chain, the modal and thermal starts, and the spectral observables
(docs/lattices.md).

A chain of equal grains m joined by equal springs of stiffness K = F'(δ0) (the contact law's at the static overlap)
has orthonormal normal modes S_k (rows of :func:`normal_modes`' basis) and frequencies ω_k:

* walls at both ends (the FPUT chain with fixed ends), k = 1 … N:
  S_k(n) = √(2/(N+1)) sin(π k (n+1)/(N+1)), ω_k = 2 √(K/m) sin(π k / (2(N+1)));
* free ends, k = 0 … N − 1 (k = 0 the rigid translation):
  S_k(n) = c_k cos(π k (n + ½)/N), c_0 = √(1/N), c_k = √(2/N), ω_k = 2 √(K/m) sin(π k / (2N));
* a ring (periodic ends), k = 0 … N − 1 with q = ⌈k/2⌉ the wavenumber: S_0 = √(1/N), S_{2q−1}(n) = √(2/N) cos(2π q n/N),
  S_{2q}(n) = √(2/N) sin(2π q n/N), and for even N S_{N−1}(n) = (−1)^n/√N; ω_k = 2 √(K/m) |sin(π q/N)|.

A mode's amplitude and rate are Q_k = S_k·u and P_k = S_k·v, its harmonic energy E_k = ½ m (P_k² + ω_k² Q_k²). The
spectral entropy of the normalised energies e_k = E_k / Σ E is S = −Σ e_k ln e_k, the participation number
1 / Σ e_k² (both over the modes with ω_k > 0).
"""

from __future__ import annotations

import functools

import numpy as np
from hertzian.core.potentials import law_of
from hertzian.core.scene import Scene
from hertzian.core.static import static_state


def normal_modes(scene: Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(mode numbers (K,), orthonormal basis (K, N), ω_k (K,)) of ``scene``'s harmonic chain (module docstring);
    read-only arrays, shared by the scenes of one chain length and ends."""
    st = static_state(scene)
    stiffness = float(law_of(scene.chain).stiffness(st.static_overlap[1], scene.chain.a))
    numbers, basis, shape = _unit_modes(scene.chain.grains, scene.boundary.surface)
    return numbers, basis, 2.0 * np.sqrt(stiffness / scene.chain.mass) * shape


@functools.lru_cache(maxsize=8)
def _unit_modes(n_grains: int, ends: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(mode numbers, basis, ω_k / (2 √(K/m))) of ``n_grains`` grains with walls, free ends or a ring (cached: an
    ensemble of thermal starts builds the same basis once)."""
    grain = np.arange(n_grains)
    if ends == "wall":
        k = np.arange(1, n_grains + 1)
        basis = np.sqrt(2.0 / (n_grains + 1)) * np.sin(np.pi * np.outer(k, grain + 1) / (n_grains + 1))
        shape = np.sin(np.pi * k / (2.0 * (n_grains + 1)))
    elif ends == "periodic":
        k = np.arange(n_grains)
        q = (k + 1) // 2
        phase = 2.0 * np.pi * np.outer(q, grain) / n_grains
        basis = np.sqrt(2.0 / n_grains) * np.where((k % 2 == 1)[:, None], np.cos(phase), np.sin(phase))
        basis[0] = np.sqrt(1.0 / n_grains)
        if n_grains % 2 == 0:
            basis[-1] = (-1.0) ** grain / np.sqrt(n_grains)
        shape = np.abs(np.sin(np.pi * q / n_grains))
    else:
        k = np.arange(n_grains)
        basis = np.sqrt(2.0 / n_grains) * np.cos(np.pi * np.outer(k, grain + 0.5) / n_grains)
        basis[0] = np.sqrt(1.0 / n_grains)
        shape = np.sin(np.pi * k / (2.0 * n_grains))
    for array in (k, basis, shape):
        array.flags.writeable = False
    return k, basis, shape


def start(scene: Scene) -> tuple[np.ndarray, np.ndarray] | None:
    """(u, v) at t = 0 of a modal or thermal start (None for the other excitations).

    Modes: Q_k = √(2E/m)/ω_k, P_k = 0 for each listed mode. Thermal: the N·ε of energy shared equally by the modes
    of ``thermal_modes`` (all with ω_k > 0 by default), each with a phase φ_k drawn uniformly by numpy's default
    generator seeded with ``seed``: Q_k = √(2E_k/m) cos φ_k / ω_k, P_k = √(2E_k/m) sin φ_k."""
    e = scene.excitation
    if not (e.modes or e.thermal):
        return None
    numbers, basis, omega = normal_modes(scene)
    mass = scene.chain.mass
    amplitude, rate = np.zeros(len(numbers)), np.zeros(len(numbers))
    if e.modes:
        chosen = np.isin(numbers, e.modes)
        amplitude[chosen] = np.sqrt(2.0 * e.mode_energy / mass) / omega[chosen]
    else:
        first, last = e.thermal_modes or (int(numbers[omega > 0][0]), int(numbers[-1]))
        chosen = (numbers >= first) & (numbers <= last)
        energy = scene.chain.grains * e.thermal / np.count_nonzero(chosen)
        phase = np.random.default_rng(e.seed).uniform(0.0, 2.0 * np.pi, np.count_nonzero(chosen))
        amplitude[chosen] = np.sqrt(2.0 * energy / mass) * np.cos(phase) / omega[chosen]
        rate[chosen] = np.sqrt(2.0 * energy / mass) * np.sin(phase)
    return amplitude @ basis, rate @ basis


def overlap_changes(u: np.ndarray, ring: bool) -> np.ndarray:
    """The change of every padded contact's overlap from grain rows ``u`` (…, N): u_{k−1} − u_k inside, −u_0 and
    u_{N−1} at walls, u_{N−1} − u_0 in both end slots of a ring. Shape (…, N + 1)."""
    out = np.concatenate([-u[..., :1], u[..., :-1] - u[..., 1:], u[..., -1:]], axis=-1)
    if ring:
        out[..., 0] = out[..., -1] = u[..., -1] - u[..., 0]
    return out


def start_energy(scene: Scene) -> float:
    """The whole energy of a modal or thermal start: kinetic plus the contact law's excess potential relative to
    the static state (what the record kernels' energy is at t = 0)."""
    u, v = start(scene)
    st = static_state(scene)
    law = law_of(scene.chain)
    d = overlap_changes(u, scene.boundary.surface == "periodic")
    present = st.contact_constant > 0
    if scene.boundary.surface == "periodic":
        present[-1] = False  # the closing contact once
    delta0, a = st.static_overlap[present], st.contact_constant[present]
    excess = law.potential(delta0 + d[present], a) - law.potential(delta0, a) - law.force(delta0, a) * d[present]
    return float(0.5 * np.sum(st.mass * v * v) + np.sum(excess))


def injected_energy(scene: Scene) -> float:
    """The energy a scene starts with: a modal or thermal start's (:func:`start_energy`), else the impact's."""
    if scene.excitation.modes or scene.excitation.thermal:
        return start_energy(scene)
    return scene.injected_energy


def mode_energies(scene: Scene, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """E_k of displacements and velocities ``u``, ``v`` (…, N): shape (…, K), in :func:`normal_modes`' order."""
    _, basis, omega = normal_modes(scene)
    amplitude, rate = np.asarray(u) @ basis.T, np.asarray(v) @ basis.T
    return 0.5 * scene.chain.mass * (rate * rate + (omega * amplitude) ** 2)


def spectral_entropy(energies: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """S = −Σ e_k ln e_k over the modes with ω_k > 0 (e_k = E_k / Σ E; 0 ln 0 = 0), over the last axis."""
    e = _shares(energies, omega)
    with np.errstate(divide="ignore", invalid="ignore"):
        return -np.sum(np.where(e > 0, e * np.log(e), 0.0), axis=-1)


def participation(energies: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """1 / Σ e_k² over the modes with ω_k > 0, over the last axis: 1 for one mode, their count at equipartition."""
    e = _shares(energies, omega)
    return 1.0 / np.sum(e * e, axis=-1)


def _shares(energies: np.ndarray, omega: np.ndarray) -> np.ndarray:
    oscillating = np.asarray(energies)[..., omega > 0]
    return oscillating / np.sum(oscillating, axis=-1, keepdims=True)
