"""Trace sampling for the fused solvers: copy the traced grains' (u, dt·v) into the trace ring.

The per-step kernel (kernels/step.py) writes a trace sample from inside the step that reaches a
step k·stride. The fused solvers (tile, window, CPU sweep) instead advance in pieces that end on
those steps and launch this kernel after each such piece: it copies ``x[0]`` and ``x[1]`` of the
traced grains, which are the very values the per-step kernel would have written (the state after
the step), so the ring is bitwise the same. One thread per (chain, traced grain).
"""

import functools

import warp as wp

from .features import KERNEL_OPTIONS


@functools.cache
def trace_sample_kernel(precision: str):
    """The sample kernel for one precision (cached)."""
    real = wp.float64 if precision == "float64" else wp.float32

    @wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
    def sample_traces(
        x: wp.array3d(dtype=real),
        clock: wp.array(dtype=wp.int32),
        traced_grain: wp.array(dtype=wp.int32),
        trace_stride: int,
        trace_x: wp.array4d(dtype=real),
    ):
        c, slot = wp.tid()
        i = traced_grain[slot]
        sample = (clock[0] / trace_stride) % trace_x.shape[2]   # the step kernel's ring slot
        trace_x[0, c, sample, slot] = x[0, c, i]
        trace_x[1, c, sample, slot] = x[1, c, i]

    return sample_traces
