"""A driven surface in the fused kernel: the driver's functions, its sin/cos table filled on the device before the
launches, and the trace samples written inside the launch."""

import warp as wp
from hertzian.kernels.features import KERNEL_OPTIONS
from hertzian.kernels.physics import (
    product_rn,
)
from hertzian.kernels.tile_layout import TileLayout


def driver_functions(t: TileLayout):
    """A driven surface's per-step log entry, its power at t_n from that entry, one trapezoid step of its work, and
    its (u_0, dt·v_0) from its phases."""
    G, real, DRIVER_SLOT, DASHPOT, state_t, vec2 = t.G, t.real, t.DRIVER_SLOT, t.DASHPOT, t.state_t, t.vec2
    shape_t = t.shape_t
    one_force, one_vec, dashpot = t.one_force, t.one_vec, t.dashpot

    @wp.func
    def driver_log_entry(s: state_t, k0: int, u_driver: real) -> wp.vec2d:
        # what the driver's power at t_n needs of the state besides cos(ω t_n) (kernels/step.py: P = ΔF_01 · v_0):
        # grain 0's overlap change d = u_0 − u_1 and, with the contact dashpot, grain 1's dt·v, as float64 (exact for
        # float32). Grains k0, k0 + 1 picked by selects over the static positions: an index known only at run time
        # would put the lane's whole register matrix in local memory, for every lane, every step
        d_old = real(0)
        below_rate_old = real(0)
        if wp.static(DRIVER_SLOT >= 0):
            # a fixed slot: no select, every lane computes the entry (the others' go to their scratch rows)
            d_old = u_driver - s[0, wp.static(min(DRIVER_SLOT + 1, G - 1))]
            if wp.static(DASHPOT):
                below_rate_old = s[1, wp.static(min(DRIVER_SLOT + 1, G - 1))]
        else:
            for k in range(G):  # range(G), not range(G - 1): Warp unrolls only a bound it reads as a constant
                if k == k0:
                    d_old = u_driver - s[0, wp.min(k + 1, G - 1)]
                    if wp.static(DASHPOT):
                        below_rate_old = s[1, wp.min(k + 1, G - 1)]
        return wp.vec2d(wp.float64(d_old), wp.float64(below_rate_old))

    @wp.func
    def driver_power(
        entry: wp.vec2d,
        cos_old: wp.float64,
        below0: real,
        below_ac: real,
        below_f0: real,
        n: shape_t,
        amplitude: wp.float64,
        omega: wp.float64,
        dt: wp.float64,
        gamma: real,
    ) -> wp.float64:
        # kernels/step.py: the driver's power at t_n from its driver_log_entry and cos(ω t_n), with the lane's
        # contact law (branchless where the lane's is: the same bits as contact_force)
        d_old = real(entry[0])
        force_old = wp.float64(one_force(one_vec(below0 + d_old), one_vec(below_ac), one_vec(below_f0), n)[0])
        if wp.static(DASHPOT):
            # the driver also pushes through the dashpot of its contact (kernels/step.py: the work includes it)
            rate_old = real(dt * amplitude * omega * cos_old) - real(entry[1])
            force_old += wp.float64(dashpot(below0, d_old, rate_old, gamma, real(dt)))
        return force_old * amplitude * omega * cos_old

    @wp.func
    def work_step(work_power: wp.vec2d, power: wp.float64, step_old: int, dt: wp.float64) -> wp.vec2d:
        # kernels/step.py: the driver's work W and power P after the step from step_old, whose power at t_n is power
        if wp.static(DASHPOT):
            if step_old == 0:
                return wp.vec2d(work_power[0], power)  # W(0) = 0: the dashpot's power at t = 0 is not zero
        return wp.vec2d(work_power[0] + dt * wp.float64(0.5) * (work_power[1] + power), power)

    @wp.func
    def driver_values(amplitude: wp.float64, omega: wp.float64, phase: wp.vec2d, dt: wp.float64) -> vec2:
        # the prescribed surface grain's u_0 and dt·v_0 where (sin ωt, cos ωt) = phase, as kernels/step.py stores
        # them. The fused kernels never store them in the driver's register column during the launch: every step
        # reads the driver from its phases (its predicted position, its overlap change in driver_log_entry, an
        # event step's neighbour: driver_values_at), so its column is left to its own corrector (no select per
        # step), and traces and the write-back take these values
        return vec2(real(product_rn(amplitude, phase[0])), real(dt * amplitude * omega * phase[1]))

    return driver_log_entry, driver_power, work_step, driver_values


def trace_function(t: TileLayout, driver_values):
    """Traces: the trace sample after a step when one is due (written out of line)."""
    G, real, DRIVEN, state_t = t.G, t.real, t.DRIVEN, t.state_t

    @wp.func(inline=False)
    def write_trace_sample(
        s: state_t,
        x_in: wp.array3d(dtype=real),
        frozen: bool,
        live: bool,
        cc: int,
        base: int,
        keep_lo: int,
        keep_hi: int,
        trace_slot: wp.array(dtype=wp.int32),
        trace_stride: int,
        step_new: int,
        trace_x: wp.array4d(dtype=real),
        amplitude: wp.float64,
        omega: wp.float64,
        phase: wp.vec2d,
        dt: wp.float64,
    ) -> int:
        # kernels/step.py's trace sample after step ``step_new`` (a multiple of the stride): (u, dt·v) of the traced
        # grains this lane keeps (a frozen chain: its frozen state; the driven grain 0: its driver_values at
        # ``phase``), ring slot k % length. Out of line: written into the step loop, this code makes every step of the
        # traced window kernel slower on a GPU (measured), though it runs once a stride
        if live:
            sample = (step_new / trace_stride) % trace_x.shape[2]
            for k in range(G):
                g = base + k
                if g >= keep_lo and g < keep_hi:
                    slot = trace_slot[g]
                    if slot >= 0:
                        if frozen:
                            trace_x[0, cc, sample, slot] = x_in[0, cc, g]
                            trace_x[1, cc, sample, slot] = x_in[1, cc, g]
                        else:
                            u = s[0, k]
                            rate = s[1, k]
                            if wp.static(DRIVEN):
                                if g == 0:
                                    driver = driver_values(amplitude, omega, phase, dt)
                                    u = driver[0]
                                    rate = driver[1]
                            trace_x[0, cc, sample, slot] = u
                            trace_x[1, cc, sample, slot] = rate
        return 0

    @wp.func
    def write_traces(
        s: state_t,
        x_in: wp.array3d(dtype=real),
        frozen: bool,
        live: bool,
        cc: int,
        base: int,
        keep_lo: int,
        keep_hi: int,
        trace_slot: wp.array(dtype=wp.int32),
        trace_stride: int,
        step_new: int,
        next_trace: int,
        trace_x: wp.array4d(dtype=real),
        amplitude: wp.float64,
        omega: wp.float64,
        phase: wp.vec2d,
        dt: wp.float64,
    ) -> int:
        # after a step: the trace sample when ``step_new`` reaches ``next_trace``, the first multiple of the stride not
        # yet passed (one comparison a step, not a modulo); returns the next one
        if step_new != next_trace:
            return next_trace
        write_trace_sample(
            s,
            x_in,
            frozen,
            live,
            cc,
            base,
            keep_lo,
            keep_hi,
            trace_slot,
            trace_stride,
            step_new,
            trace_x,
            amplitude,
            omega,
            phase,
            dt,
        )
        return next_trace + trace_stride

    return write_traces


@wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
def drive_table(
    clock: wp.array(dtype=wp.int32),
    drive: wp.array2d(dtype=wp.float64),
    dt: wp.float64,
    phases: wp.array2d(dtype=wp.vec2d),
    phase_first: wp.array(dtype=wp.int32),
):
    # the driver's (sin ωt, cos ωt) of chain c at step clock + row, with the per-step kernel's argument ω·(n·dt)
    # (the same bits); phase_first: the step of row 0
    c, row = wp.tid()
    first = clock[0]
    if c == 0 and row == 0:
        phase_first[0] = first
    omega = drive[c, 1]
    t = wp.float64(first + row) * dt
    phases[c, row] = wp.vec2d(wp.sin(omega * t), wp.cos(omega * t))


def launch_drive_table(*, clock, drive, dt: float, phases, phase_first, device, rows: int | None = None) -> None:
    """Fill the first ``rows`` rows (all by default) of ``phases`` (chains, rows) with the driver's phases at steps
    clock … clock + rows − 1 (the clock read on the device, so a captured graph replays it at any clock); driven
    fused launches of n steps in all from that clock read rows 0 … n + 1 (each loads the next step's row ahead)."""
    rows = phases.shape[1] if rows is None else min(rows, phases.shape[1])
    wp.launch(
        drive_table,
        dim=(phases.shape[0], rows),
        inputs=[clock, drive, dt],
        outputs=[phases, phase_first],
        device=device,
    )
