"""Damping in the fused kernel: the viscous corrector term and the contact dashpot, with each grain's dissipated
energy (the builders kernels/tile.py composes)."""

from typing import Any

import warp as wp
from hertzian.kernels.physics import (
    product_rn,
)
from hertzian.kernels.tile_layout import TileLayout


def loss_functions(t: TileLayout, predicted_rate, column, at_driver):
    """Damping: the viscous loss of one step, the lane's predicted rates, the contact dashpot's forces and its loss
    of one step."""
    G, G1, real, MASKED, FREE_END, DRIVEN, SURFACE_WALL = (
        t.G,
        t.G1,
        t.real,
        t.MASKED,
        t.FREE_END,
        t.DRIVEN,
        t.SURFACE_WALL,
    )
    state_t, grain_vec, contact_vec, loss_vec = t.state_t, t.grain_vec, t.contact_vec, t.loss_vec
    nordsieck, dashpot = t.nordsieck, t.dashpot
    lane_t = t.lane_t

    @wp.func
    def dissipation(
        s: state_t, lost: loss_vec, inv_m: grain_vec, move_bits: int, k0: int, gamma: real, h: real, dt: wp.float64
    ) -> loss_vec:
        # kernels/step.py's viscous loss of one step for every integrated grain of the lane (not a held bottom
        # grain, not the driver, not padding): the trapezoid of γ m (dt·v)²/h² at t_n and at the predicted t_n+1
        out = lost
        for k in range(G):
            if (move_bits & (1 << k)) != 0 and not at_driver(k, k0):
                own_rate = predicted_rate(column(s, k))
                own_rate_old = s[1, k]
                m_i = real(1) / inv_m[k]
                loss_old = gamma * m_i * own_rate_old * own_rate_old / (h * h)
                loss_new = gamma * m_i * own_rate * own_rate / (h * h)
                out[k] = out[k] + dt * wp.float64(0.5) * (wp.float64(loss_old) + wp.float64(loss_new))
        return out

    @wp.func
    def lane_rates(
        s: state_t, k0: int, amplitude: wp.float64, omega: wp.float64, phase_new: wp.vec2d, dt: wp.float64
    ) -> grain_vec:
        # dt·v of the lane's grains predicted at t_n+1 (the contact dashpot); the driver's is its own at t_n+1
        rates = grain_vec()
        for k in range(G):
            rates[k] = predicted_rate(column(s, k))
        if wp.static(DRIVEN):
            if k0 >= 0:
                for k in range(G):
                    if at_driver(k, k0):
                        rates[k] = real(dt * amplitude * omega * phase_new[1])
        return rates

    @wp.func
    def dashpot_forces(
        up: grain_vec,
        rates: grain_vec,
        u_left: real,
        rate_left: real,
        u_right: real,
        rate_right: real,
        delta0: contact_vec,
        contact_bits: int,
        gamma: real,
        h: real,
    ) -> contact_vec:
        # kernels/step.py's dashpot γ·δ̇ of each of the lane's G + 1 contacts at the predicted t_n+1 (a contact the
        # chain lacks, at a free end, has none): upper minus lower grain, as both of its grains compute it there
        out = contact_vec()
        for j in range(G1):
            upper_u = u_left
            upper_rate = rate_left
            if j > 0:
                upper_u = up[wp.max(j - 1, 0)]
                upper_rate = rates[wp.max(j - 1, 0)]
            lower_u = u_right
            lower_rate = rate_right
            if j < G:
                lower_u = up[wp.min(j, G - 1)]
                lower_rate = rates[wp.min(j, G - 1)]
            exists = True
            if wp.static(MASKED and FREE_END):
                exists = (contact_bits & (1 << j)) != 0
            if exists:
                out[j] = dashpot(delta0[j], upper_u - lower_u, upper_rate - lower_rate, gamma, h)
        return out

    @wp.func
    def dashpot_losses(
        s: state_t,
        lost: loss_vec,
        edges: Any,
        ln: lane_t,
        phase_old: wp.vec2d,
        phase_new: wp.vec2d,
    ) -> loss_vec:
        # kernels/step.py's dissipated energy of one step (contact dashpot) from the state at t_n and this step's
        # edge tile (read before the next step's barrier): per integrated grain the trapezoid of the power of the
        # dashpot below it, and of the one above it where no integrated grain is above (wall, driver)
        up = grain_vec()
        for k in range(G):
            up[k] = nordsieck.predict_position(column(s, k))
        if wp.static(DRIVEN):
            if ln.k0 >= 0:
                for k in range(G):
                    if at_driver(k, ln.k0):
                        up[k] = real(product_rn(ln.amplitude, phase_new[0]))
        rates = lane_rates(s, ln.k0, ln.amplitude, ln.omega, phase_new, ln.dt)
        u_left = real(0)
        rate_left = real(0)
        u_right = real(0)
        rate_right = real(0)
        u_right_old = real(0)
        rate_right_old = real(0)
        if ln.has_left:
            u_left = wp.tile_extract(edges, ln.lane - 1, 1)
            rate_left = wp.tile_extract(edges, ln.lane - 1, 3)
        if ln.has_right:
            u_right = wp.tile_extract(edges, ln.lane + 1, 0)
            rate_right = wp.tile_extract(edges, ln.lane + 1, 2)
            u_right_old = wp.tile_extract(edges, ln.lane + 1, 4)
            rate_right_old = wp.tile_extract(edges, ln.lane + 1, 5)
        damp = dashpot_forces(
            up, rates, u_left, rate_left, u_right, rate_right, ln.delta0, ln.contact_bits, ln.gamma, ln.h
        )
        out = lost
        for k in range(G):
            if (ln.move_bits & (1 << k)) != 0 and not at_driver(k, ln.k0):
                own_rate = rates[k]
                own_rate_old = s[1, k]
                loss_old = real(0)
                loss_new = real(0)
                below = True
                if wp.static(MASKED and FREE_END):
                    below = (ln.contact_bits & (1 << (k + 1))) != 0
                if below:
                    below_rate = rate_right
                    below_rate_old = rate_right_old
                    below_u_old = u_right_old
                    if k < G - 1:
                        below_rate = rates[wp.min(k + 1, G - 1)]
                        below_rate_old = s[1, wp.min(k + 1, G - 1)]
                        below_u_old = s[0, wp.min(k + 1, G - 1)]
                    loss_new += damp[k + 1] * (own_rate - below_rate) / ln.h
                    f_old = dashpot(
                        ln.delta0[k + 1], s[0, k] - below_u_old, own_rate_old - below_rate_old, ln.gamma, ln.h
                    )
                    loss_old += f_old * (own_rate_old - below_rate_old) / ln.h
                outer = False
                above_rate = real(0)
                above_rate_old = real(0)
                above_u_old = real(0)
                if wp.static(SURFACE_WALL):
                    outer = ln.base + k == 0
                if wp.static(DRIVEN):
                    if ln.k0 >= 0 and at_driver(k - 1, ln.k0):
                        outer = True
                        above_rate = real(ln.dt * ln.amplitude * ln.omega * phase_new[1])
                        above_u_old = real(product_rn(ln.amplitude, phase_old[0]))
                        above_rate_old = real(ln.dt * ln.amplitude * ln.omega * phase_old[1])
                if outer:
                    loss_new += damp[k] * (above_rate - own_rate) / ln.h
                    f_old = dashpot(ln.delta0[k], above_u_old - s[0, k], above_rate_old - own_rate_old, ln.gamma, ln.h)
                    loss_old += f_old * (above_rate_old - own_rate_old) / ln.h
                out[k] = out[k] + ln.dt * wp.float64(0.5) * (wp.float64(loss_old) + wp.float64(loss_new))
        return out

    return dissipation, lane_rates, dashpot_forces, dashpot_losses
