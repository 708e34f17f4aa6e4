"""Response windows of a driven chain, accumulated on the device (no host stops).

Launched at the steps where some chain samples, after the solver has advanced to that step, with
whatever solver ran: it reads only the state, the step included (the state's clock, so a CUDA graph of
many advance-and-sample pieces replays without the host). Chain c samples every ``stride[c]`` steps from the
windows' start (its own ``Scene.response_stride``, so a chain's sums do not depend on the other chains
of its ensemble). ``phases`` (one thread per chain) evaluates cos(kωt) and sin(kωt), k = 0 … H, once per
sampling chain and step; ``accumulate`` (chain, grain) adds, for the window w that holds the step, per
grain v·cos(kωt) and −v·sin(kωt) (the sums of the rectangle rule for ∫ v e^{−ikωt} dt), ½ m v², and
(grain 1's thread) one count when the contact between the driven grain and grain 1 is open. The host
divides by the window's sample count. Each thread owns its own sums and adds them in time order:
bitwise reproducible, no atomics.
"""

import functools

import warp as wp
from hertzian.kernels.features import KERNEL_OPTIONS, Features
from hertzian.kernels.physics import contact_parameters


@wp.func
def sample_window(offset: wp.int64, stride: wp.int64, window_steps: wp.int64, windows: int) -> int:
    """The window a chain adds a sample to at ``offset`` steps from the windows' start, or −1."""
    if offset < wp.int64(0):
        return -1
    if offset % stride != wp.int64(0):
        return -1
    w = int(offset / window_steps)
    if w >= windows:
        return -1
    return w


@wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
def response_phases(
    drive: wp.array2d(dtype=wp.float64),
    window_steps: wp.array(dtype=wp.int64),
    stride: wp.array(dtype=wp.int64),
    start_step: wp.int64,
    clock: wp.array(dtype=wp.int32),
    windows: int,
    harmonics: int,
    dt: wp.float64,
    phases: wp.array3d(dtype=wp.float64),
):
    # cos(kωt) and sin(kωt) of chain c at this step, k = 0 … H (only where the chain samples)
    c = wp.tid()
    step = wp.int64(clock[0])
    if sample_window(step - start_step, stride[c], window_steps[c], windows) < 0:
        return
    omega_t = drive[c, 1] * (wp.float64(step) * dt)
    for k in range(harmonics + 1):
        phase = wp.float64(k) * omega_t
        phases[c, k, 0] = wp.cos(phase)
        phases[c, k, 1] = wp.sin(phase)


@functools.cache
def response_kernel(features: Features):
    """The accumulator for one feature set (precision, static overlaps, masses)."""
    f = features
    real = wp.float64 if f.precision == "float64" else wp.float32
    HETERO = f.heterogeneous
    params = contact_parameters(f.precision, f.static, f.heterogeneous, f.hertz)

    @wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
    def accumulate(
        x: wp.array3d(dtype=real),
        inverse_mass: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        static_overlap: wp.array2d(dtype=real),
        law_parameters: wp.array(dtype=real),
        window_steps: wp.array(dtype=wp.int64),
        stride: wp.array(dtype=wp.int64),
        start_step: wp.int64,
        clock: wp.array(dtype=wp.int32),
        windows: int,
        harmonics: int,
        dt: wp.float64,
        phases: wp.array3d(dtype=wp.float64),
        response_re: wp.array4d(dtype=wp.float64),
        response_im: wp.array4d(dtype=wp.float64),
        kinetic: wp.array3d(dtype=wp.float64),
        open_count: wp.array2d(dtype=wp.float64),
    ):
        c, i = wp.tid()
        step = wp.int64(clock[0])
        w = sample_window(step - start_step, stride[c], window_steps[c], windows)
        if w < 0:
            return
        v = wp.float64(x[1, c, i]) / dt
        for k in range(harmonics + 1):
            response_re[c, w, k, i] = response_re[c, w, k, i] + v * phases[c, k, 0]
            response_im[c, w, k, i] = response_im[c, w, k, i] - v * phases[c, k, 1]
        inv_m = wp.float64(0.0)
        if wp.static(HETERO):
            inv_m = wp.float64(inverse_mass[c, i])
        else:
            inv_m = wp.float64(inverse_mass[c, 0])
        kinetic[c, w, i] = kinetic[c, w, i] + wp.float64(0.5) * v * v / inv_m
        if i == 1:
            delta0 = params(static_overlap, contact_constant, law_parameters, c, 1)[0]
            if delta0 + (x[0, c, 0] - x[0, c, 1]) <= real(0):
                open_count[c, w] = open_count[c, w] + wp.float64(1.0)

    return accumulate
