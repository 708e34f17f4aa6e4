"""Response windows of a driven chain, accumulated on the device (no host stops).

Launched every ``s`` steps (``Scene.response_stride``) over (chain, grain), after the solver has
advanced to that step, with whatever solver ran: it reads only the state. For the window w that
holds the step it adds, per grain, v·cos(kωt) and −v·sin(kωt) for k = 0 … H (the sums of the
rectangle rule for ∫ v e^{−ikωt} dt), ½ m v², and (grain 1's thread) one count when the contact
between the driven grain and grain 1 is open. The host divides by the window's sample count. Each
thread owns its own sums and adds them in time order: bitwise reproducible, no atomics.
"""

import functools

import warp as wp

from .features import KERNEL_OPTIONS, Features
from .physics import contact_parameters


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
        exponent: wp.array(dtype=real),
        drive: wp.array2d(dtype=wp.float64),
        window_steps: wp.array(dtype=wp.int64),
        start_step: wp.int64,
        step: wp.int64,
        windows: int,
        harmonics: int,
        dt: wp.float64,
        response_re: wp.array4d(dtype=wp.float64),
        response_im: wp.array4d(dtype=wp.float64),
        kinetic: wp.array3d(dtype=wp.float64),
        open_count: wp.array2d(dtype=wp.float64),
    ):
        c, i = wp.tid()
        offset = step - start_step
        if offset < wp.int64(0):
            return
        w = int(offset / window_steps[c])
        if w >= windows:
            return
        v = wp.float64(x[1, c, i]) / dt
        omega_t = drive[c, 1] * (wp.float64(step) * dt)
        for k in range(harmonics + 1):
            phase = wp.float64(k) * omega_t
            response_re[c, w, k, i] = response_re[c, w, k, i] + v * wp.cos(phase)
            response_im[c, w, k, i] = response_im[c, w, k, i] - v * wp.sin(phase)
        inv_m = wp.float64(0.0)
        if wp.static(HETERO):
            inv_m = wp.float64(inverse_mass[c, i])
        else:
            inv_m = wp.float64(inverse_mass[c, 0])
        kinetic[c, w, i] = kinetic[c, w, i] + wp.float64(0.5) * v * v / inv_m
        if i == 1:
            delta0 = params(static_overlap, contact_constant, exponent, c, 1)[0]
            if delta0 + (x[0, c, 0] - x[0, c, 1]) <= real(0):
                open_count[c, w] = open_count[c, w] + wp.float64(1.0)

    return accumulate
