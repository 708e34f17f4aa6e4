"""Harmonic normal-mode energies, spectral entropy and participation number of every chain (docs/lattices.md).

``mode_energy_kernel``: one thread per (chain, mode) projects the state on the mode's basis row,
Q_k = Σ_n S_kn u_n and P_k = Σ_n S_kn v_n, and writes E_k = ½ m (P_k² + ω_k² Q_k²) into the record's row (float64,
whatever the state's precision; compensated float32 reads hi + lo). ``spectral_summary``: one thread per chain
reduces the E_k of the modes with ω_k > 0 to the spectral entropy −Σ e_k ln e_k and the participation number
1/Σ e_k² (e_k = E_k / Σ E). O(N) work per mode, O(N²) per chain and record.
"""

import functools

import warp as wp
from hertzian.kernels.features import KERNEL_OPTIONS


@functools.cache
def mode_energy_kernel(precision: str, compensated_rows: int):
    """The projection kernel for one precision; ``compensated_rows``: the row of u's low part (compensated float32,
    kernels/gear.py; dt·v's is the next), 0 for none."""
    real = wp.float64 if precision == "float64" else wp.float32
    LO_U = compensated_rows

    @wp.func
    def value(x: wp.array3d(dtype=real), row: int, c: int, n: int) -> wp.float64:
        out = wp.float64(x[row, c, n])
        if wp.static(LO_U > 0):
            out += wp.float64(x[row + wp.static(LO_U), c, n])
        return out

    @wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
    def mode_energies(
        x: wp.array3d(dtype=real),
        basis: wp.array2d(dtype=wp.float64),
        omega: wp.array(dtype=wp.float64),
        mass: wp.float64,
        dt: wp.float64,
        record: int,
        energy: wp.array3d(dtype=wp.float64),
    ):
        c, k = wp.tid()
        amplitude = wp.float64(0.0)
        rate = wp.float64(0.0)
        for n in range(basis.shape[1]):
            amplitude += basis[k, n] * value(x, 0, c, n)
            rate += basis[k, n] * value(x, 1, c, n)
        speed = rate / dt
        energy[record, c, k] = wp.float64(0.5) * mass * (speed * speed + omega[k] * omega[k] * amplitude * amplitude)

    return mode_energies


@wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
def spectral_summary(
    energy: wp.array3d(dtype=wp.float64),
    omega: wp.array(dtype=wp.float64),
    record: int,
    entropy: wp.array2d(dtype=wp.float64),
    participation: wp.array2d(dtype=wp.float64),
):
    c = wp.tid()
    total = wp.float64(0.0)
    for k in range(omega.shape[0]):
        if omega[k] > wp.float64(0.0):
            total += energy[record, c, k]
    s = wp.float64(0.0)
    squares = wp.float64(0.0)
    for k in range(omega.shape[0]):
        if omega[k] > wp.float64(0.0):
            e = energy[record, c, k] / total
            squares += e * e
            if e > wp.float64(0.0):
                s -= e * wp.log(e)
    entropy[record, c] = s
    participation[record, c] = wp.float64(1.0) / squares
