"""A detection library assembled on the device (ensemble/studies/detection/library.py): the candidates' surface echoes and their Gram
matrices, from the trace ring the library's run leaves on the device.

``library_echoes`` (one thread per chain and sample) reads sample k of a chain's traced grain 0 (velocity: the
ring holds dt·v; sample 0 is the t = 0 value gathered by kernels/records.py ``traced_start``, sample k ≥ 1 sits in
ring slot k % capacity), divides by dt in the state's precision and writes, in float64, the clean chain's trace and
each candidate's echo v − v_clean (−v_clean for a candidate that did not run OK) — the same operations, in the same
order, as the host path (Recorder unpacking, then ``assemble_library``), so the echoes are the same bits.
``library_grams`` (one thread per depth and pair of ratios) sums e_i·e_j over all samples and over each depth's
first-echo window in sample order (the host's BLAS sums in another order: the Gram matrices agree to rounding).
"""

import functools

import warp as wp
from hertzian.kernels.features import KERNEL_OPTIONS


@functools.cache
def library_kernels(precision: str):
    """``(library_echoes, library_grams)`` for a state of ``precision``."""
    real = wp.float64 if precision == "float64" else wp.float32

    @wp.func
    def velocity(
        ring: wp.array4d(dtype=real), start: wp.array3d(dtype=real), chain: int, k: int, capacity: int, dt: real
    ) -> real:
        rate = start[1, chain, 0]
        if k > 0:
            rate = ring[1, chain, k % capacity, 0]
        return rate / dt

    @wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
    def library_echoes(
        ring: wp.array4d(dtype=real),
        start: wp.array3d(dtype=real),
        candidate: wp.array(dtype=wp.int32),
        clean_chain: int,
        ok: wp.array(dtype=wp.int32),
        capacity: int,
        dt: real,
        clean: wp.array(dtype=wp.float64),
        echoes: wp.array2d(dtype=wp.float64),
    ):
        chain, k = wp.tid()
        v_clean = wp.float64(velocity(ring, start, clean_chain, k, capacity, dt))
        c = candidate[chain]
        if c == 0:
            clean[k] = v_clean
        else:
            v = wp.float64(0.0)
            if ok[c] != 0:
                v = wp.float64(velocity(ring, start, chain, k, capacity, dt))
            echoes[c - 1, k] = v - v_clean

    @wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
    def library_grams(
        echoes: wp.array3d(dtype=wp.float64),
        first_echo_ends: wp.array(dtype=wp.int32),
        gram: wp.array3d(dtype=wp.float64),
        first_echo_gram: wp.array3d(dtype=wp.float64),
    ):
        d, i, j = wp.tid()
        end = first_echo_ends[d]
        total = wp.float64(0.0)
        head = wp.float64(0.0)
        for s in range(echoes.shape[2]):
            if s == end:
                head = total
            total = total + echoes[d, i, s] * echoes[d, j, s]
        if end >= echoes.shape[2]:
            head = total
        gram[d, i, j] = total
        first_echo_gram[d, i, j] = head

    return library_echoes, library_grams
