"""Time-window sums and velocity snapshots of a chain ensemble, taken on the device (no host stops).

Launched after the solver has advanced to a step where something is read: ``add_window_sample``
adds one sample of each grain's kinetic energy ½ m v² and velocity v to window ``w``'s running sums;
``velocity_snapshot`` copies v into row ``row`` of a history; ``keep_chain_values`` copies a per-chain
value (energy, work) into row ``row`` of a history. One thread per (chain, grain) or per chain, each
adding its own samples in time order: bitwise reproducible, no atomics. v = x[1] / dt (the state
holds dt·v), as the host computes it.
"""

import functools

import warp as wp
from hertzian.kernels.features import KERNEL_OPTIONS


@functools.cache
def window_kernels(precision: str):
    """``(add_window_sample, velocity_snapshot64, velocity_snapshot32)`` for states of ``precision``."""
    real = wp.float64 if precision == "float64" else wp.float32

    @wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
    def add_window_sample(
        x: wp.array3d(dtype=real),
        inverse_mass: wp.array2d(dtype=real),
        heterogeneous: int,
        dt: wp.float64,
        w: int,
        ke_sum: wp.array3d(dtype=wp.float64),
        v_sum: wp.array3d(dtype=wp.float64),
    ):
        c, i = wp.tid()
        v = wp.float64(x[1, c, i]) / dt
        j = 0
        if heterogeneous != 0:
            j = i
        mass = wp.float64(1.0) / wp.float64(inverse_mass[c, j])
        ke_sum[c, w, i] = ke_sum[c, w, i] + wp.float64(0.5) * mass * (v * v)
        v_sum[c, w, i] = v_sum[c, w, i] + v

    @wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
    def velocity_snapshot64(x: wp.array3d(dtype=real), dt: wp.float64, row: int, out: wp.array3d(dtype=wp.float64)):
        c, i = wp.tid()
        out[c, row, i] = wp.float64(x[1, c, i]) / dt

    @wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
    def velocity_snapshot32(x: wp.array3d(dtype=real), dt: wp.float64, row: int, out: wp.array3d(dtype=wp.float32)):
        c, i = wp.tid()
        out[c, row, i] = wp.float32(wp.float64(x[1, c, i]) / dt)

    return add_window_sample, velocity_snapshot64, velocity_snapshot32


@wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
def keep_chain_values(values: wp.array(dtype=wp.float64), row: int, history: wp.array2d(dtype=wp.float64)):
    c = wp.tid()
    history[row, c] = values[c]
