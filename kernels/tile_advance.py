"""One fused step of a lane's grains: its registers, the event-aware steps, the predictor-corrector over the lane's
contacts, and the step that chains them (the builders kernels/tile.py composes)."""

from typing import Any

import warp as wp
from hertzian.kernels.physics import (
    product_rn,
)
from hertzian.kernels.tile_layout import TileLayout, block_any


def register_functions(t: TileLayout):
    """A lane's register helpers: a grain's predicted dt·v, a grain's column of the lane's state (registers, or the
    block's shared tile of states), and whether grain k of the lane is the driven grain 0."""
    Q, real, ORDER, DRIVER_SLOT, state_t, value_vec = t.Q, t.real, t.ORDER, t.DRIVER_SLOT, t.state_t, t.value_vec

    @wp.func
    def predicted_rate(v: value_vec) -> real:
        # kernels/physics.py damping_functions' predicted_rate on a register column: dt·v at t_n+1, Σ_q q·x_q
        rate = v[1] + real(2) * v[2]
        if wp.static(ORDER >= 4):
            rate += real(3) * v[3]
        if wp.static(ORDER >= 5):
            rate += real(4) * v[4]
        if wp.static(ORDER >= 6):
            rate += real(5) * v[5]
        return rate

    @wp.func
    def column(s: state_t, k: int) -> value_vec:
        v = value_vec()
        for q in range(Q):
            v[q] = s[q, k]
        return v

    @wp.func
    def shared_column(states: Any, lane: int, k: int) -> value_vec:
        # grain k's Nordsieck vector in lane ``lane``'s state of the shared tile (a run-time k: shared memory)
        v = value_vec()
        for q in range(Q):
            v[q] = wp.tile_extract(states, lane, q, k)
        return v

    @wp.func
    def at_driver(k: int, k0: int) -> bool:
        # grain k of the lane is the driven grain 0 (k0: its index in this lane, or -1). With a fixed slot the test of
        # k is settled when compiled (k is a constant in every unrolled loop), only k0 >= 0 is left to run
        if wp.static(DRIVER_SLOT >= 0):
            return k == wp.static(DRIVER_SLOT) and k0 >= 0
        return k == k0 and k0 >= 0

    return predicted_rate, column, shared_column, at_driver


def event_steps_function(t: TileLayout, shared_column):
    """Event-aware steps: the event steps of a chain's flagged grains, shared among its lanes (None without events)."""
    if not t.EVENTS:
        return None
    G, L, real, DRIVEN, HETERO, MASKED, FIXED = t.G, t.L, t.real, t.DRIVEN, t.HETERO, t.MASKED, t.FIXED
    value_vec, vec3, params, event_step = t.value_vec, t.vec3, t.params, t.event_step
    driver_values_at = t.nordsieck.driver_values_at
    lane_t, arrays_t = t.lane_t, t.arrays_t
    LO_CONTACT = 0 if t.SURFACE_WALL else 1  # padded contacts c with LO_CONTACT <= c <= n_grains - HI_OFFSET exist
    HI_OFFSET = 0 if t.BOTTOM_WALL else 1

    @wp.func
    def shared_event_steps(
        states: Any,
        flags: Any,
        results: Any,
        ln: lane_t,
        ar: arrays_t,
        phase_old: wp.vec2d,
    ):
        # The event steps of a chain's flagged grains, shared among the chain's L lanes: in round m lane j takes
        # the chain's grain j + m·L (neighbouring flagged grains, which sit in one lane, go to neighbouring
        # lanes). A worker reads everything from t_n's shared state and the parameter arrays, nothing from its
        # own lane's registers, and writes the new Nordsieck vector to the grain's slot of ``results``; rounds
        # no lane needs are skipped by one vote.
        m = int(0)
        while m < G:  # (a loop: one copy of the event step)
            chain_grain = ln.lane_c + m * L
            owner_c = chain_grain / G
            k = chain_grain - owner_c * G
            owner = ln.segment * L + owner_c
            mine = (wp.tile_extract(flags, owner) >> k) & 1
            if block_any(mine) != 0:
                new = value_vec()
                if mine != 0:
                    g = ln.first + owner_c * G + k
                    own = shared_column(states, owner, k)
                    above = value_vec()
                    if k > 0:
                        above = shared_column(states, owner, k - 1)
                    elif owner_c > 0:
                        above = shared_column(states, owner - 1, G - 1)
                    below = value_vec()
                    if k < G - 1:
                        below = shared_column(states, owner, k + 1)
                    elif owner_c < L - 1:
                        below = shared_column(states, owner + 1, 0)
                    if wp.static(DRIVEN):
                        if g == 1:  # grain 1 sees the driver's vector at t_n above it
                            above = driver_values_at(ln.amplitude, ln.omega, phase_old[0], phase_old[1], ln.dt)
                    has_above = g >= LO_CONTACT and g <= ln.n_grains - HI_OFFSET
                    has_below = g + 1 >= LO_CONTACT and g + 1 <= ln.n_grains - HI_OFFSET
                    p_above = params(
                        ar.static_overlap,
                        ar.contact_constant,
                        ar.law_parameters,
                        ln.cc,
                        wp.min(wp.max(g, 0), ln.n_grains),
                    )
                    p_below = params(
                        ar.static_overlap,
                        ar.contact_constant,
                        ar.law_parameters,
                        ln.cc,
                        wp.min(wp.max(g + 1, 0), ln.n_grains),
                    )
                    inside = g >= 0 and g < ln.n_grains
                    inv_m_event = real(0)
                    if wp.static(HETERO):
                        inv_m_event = ar.inverse_mass[ln.cc, wp.min(wp.max(g, 0), ln.n_grains - 1)]
                    else:
                        inv_m_event = ar.inverse_mass[ln.cc, 0]
                    if wp.static(MASKED):
                        if not inside:
                            inv_m_event = real(0)
                    new = event_step(
                        own,
                        above,
                        below,
                        has_above,
                        has_below,
                        vec3(p_above[0], p_above[1], ln.n),
                        vec3(p_below[0], p_below[1], ln.n),
                        inv_m_event,
                        ln.h,
                    )
                    if wp.static(FIXED):
                        if not inside or g == ln.n_grains - 1:  # a held bottom grain (or padding) stays
                            new = own
                wp.tile_scatter_masked(results, owner * G + k, new, mine != 0)
            m += 1

    return shared_event_steps


def advance_function(t: TileLayout, predicted_rate, column, at_driver, lane_rates, dashpot_forces, shared_event_steps):
    """One step of a lane: predict, exchange the edge positions, (event-aware steps: test, vote, step the flagged
    grains), contact forces, correct."""
    Q, G, G1, L, real, EDGE_LO, RING, COMPOSED = t.Q, t.G, t.G1, t.L, t.real, t.EDGE_LO, t.RING, t.COMPOSED
    COMP, DRIVEN, EVENTS, DASHPOT, VISCOUS, MASKED, FREE_END, FIXED = (
        t.COMP,
        t.DRIVEN,
        t.EVENTS,
        t.DASHPOT,
        t.VISCOUS,
        t.MASKED,
        t.FREE_END,
        t.FIXED,
    )
    state_t, grain_vec, contact_vec, edge_t, value_vec, vec2 = (
        t.state_t,
        t.grain_vec,
        t.contact_vec,
        t.edge_t,
        t.value_vec,
        t.vec2,
    )
    nordsieck, forces, near_event = t.nordsieck, t.forces, t.near_event
    lane_t, arrays_t = t.lane_t, t.arrays_t
    driver_values_at = nordsieck.driver_values_at

    @wp.func
    def advance(
        s: state_t,
        edges: Any,
        states: Any,
        flags: Any,
        results: Any,
        ln: lane_t,
        ar: arrays_t,
        phase_old: wp.vec2d,
        phase_new: wp.vec2d,
        w: real,
    ) -> state_t:
        # k0: grain 0's index in this lane, or -1 (undriven, or grain 0 elsewhere); phase_old, phase_new:
        # (sin ωt, cos ωt) of the driver at t_n and t_{n+1}
        # 1. predict
        up = grain_vec()
        up_lo = grain_vec()  # compensated: the low parts (0 otherwise, unused)
        for k in range(G):
            if wp.static(COMP):
                if wp.static(COMPOSED):
                    position = nordsieck.substep_predicted(column(s, k), w)
                else:
                    position = nordsieck.predicted(column(s, k))
                up[k] = position[0]
                up_lo[k] = position[1]
            else:
                if wp.static(COMPOSED):
                    up[k] = nordsieck.substep_predicted(column(s, k), w)
                else:
                    up[k] = nordsieck.predict_position(column(s, k))
        if wp.static(DRIVEN):
            # selects over the static positions, false in every lane but the driver's (k0 = -1): no branch, whose
            # reconvergence every block of the driven kernel paid each step
            if wp.static(COMP):
                driver_position = nordsieck.exact_position(product_rn(ln.amplitude, phase_new[0]))
                for k in range(G):
                    if at_driver(k, ln.k0):
                        up[k] = driver_position[0]
                        up_lo[k] = driver_position[1]
            else:
                driver_u = real(product_rn(ln.amplitude, phase_new[0]))
                for k in range(G):
                    if at_driver(k, ln.k0):
                        up[k] = driver_u
        # 2. exchange the lane's edge positions with its neighbours (virtual grains outside sit at 0)
        if wp.static(EVENTS):
            # the event test also needs the neighbour lanes' edge grains' (u, dt·v) at t_n
            edge = edge_t()
            edge[0] = up[0]
            edge[1] = up[G - 1]
            edge[2] = s[0, 0]
            edge[3] = s[1, 0]
            edge[4] = s[0, G - 1]
            edge[5] = s[1, G - 1]
            if wp.static(COMP):
                edge[wp.static(EDGE_LO)] = up_lo[0]
                edge[wp.static(EDGE_LO + 1)] = up_lo[G - 1]
            wp.tile_assign(edges, wp.tile(edge, preserve_type=True))
        elif wp.static(COMP):
            wp.tile_assign(edges, wp.tile(edge_t(up[0], up[G - 1], up_lo[0], up_lo[G - 1]), preserve_type=True))
        elif wp.static(DASHPOT):
            rates = lane_rates(s, ln.k0, ln.amplitude, ln.omega, phase_new, ln.dt)
            wp.tile_assign(
                edges, wp.tile(edge_t(up[0], up[G - 1], rates[0], rates[G - 1], s[0, 0], s[1, 0]), preserve_type=True)
            )
        else:
            wp.tile_assign(edges, wp.tile(edge_t(up[0], up[G - 1]), preserve_type=True))
        u_left = real(0)
        u_right = real(0)
        u_left_lo = real(0)
        u_right_lo = real(0)
        left = ln.lane - 1
        right = ln.lane + 1
        if wp.static(RING):  # the ring closes over its chain's lanes
            if ln.lane_c == 0:
                left = ln.lane + wp.static(L - 1)
            if ln.lane_c == wp.static(L - 1):
                right = ln.lane - wp.static(L - 1)
        if ln.has_left:
            u_left = wp.tile_extract(edges, left, 1)
            if wp.static(COMP):
                u_left_lo = wp.tile_extract(edges, left, wp.static(EDGE_LO + 1))
        if ln.has_right:
            u_right = wp.tile_extract(edges, right, 0)
            if wp.static(COMP):
                u_right_lo = wp.tile_extract(edges, right, wp.static(EDGE_LO))
        if wp.static(EVENTS):
            left_values = vec2()  # (u, dt·v) at t_n of the grains beyond the lane's edges (0: none)
            right_values = vec2()
            if ln.has_left:
                left_values = vec2(wp.tile_extract(edges, ln.lane - 1, 4), wp.tile_extract(edges, ln.lane - 1, 5))
            if ln.has_right:
                right_values = vec2(wp.tile_extract(edges, ln.lane + 1, 2), wp.tile_extract(edges, ln.lane + 1, 3))
        # 3. every contact of the lane once (the two edge contacts also in the neighbour lane)
        delta = contact_vec()
        if wp.static(COMP):
            # the contacts' relative displacements from (hi, lo) pairs (kernels/gear.py gap)
            delta[0] = ln.delta0[0] + nordsieck.gap(vec2(u_left, u_left_lo), vec2(up[0], up_lo[0]))
            for k in range(G):
                position_below = vec2(u_right, u_right_lo)
                if k < G - 1:
                    position_below = vec2(up[wp.min(k + 1, G - 1)], up_lo[wp.min(k + 1, G - 1)])
                delta[k + 1] = ln.delta0[k + 1] + nordsieck.gap(vec2(up[k], up_lo[k]), position_below)
        else:
            delta[0] = ln.delta0[0] + (u_left - up[0])
            for k in range(G):
                u_below = u_right
                if k < G - 1:
                    u_below = up[wp.min(k + 1, G - 1)]
                delta[k + 1] = ln.delta0[k + 1] + (up[k] - u_below)
        if wp.static(EVENTS):
            # grains touching a contact near an opening or closing (kernels/step.py's event test), from t_n's (u, dt·v)
            # and the predicted positions, before the corrector, so that t_n's state need not outlive it
            driver_above = value_vec()  # the driver's vector at t_n: what grain 1 sees above it
            if wp.static(DRIVEN):
                if ln.k0 >= 0:
                    driver_above = driver_values_at(ln.amplitude, ln.omega, phase_old[0], phase_old[1], ln.dt)
            # each of the lane's G + 1 contacts tested once, without a branch (branches around the tests broke the
            # step into pieces the compiler could not interleave, and the kernel ran several times slower); a grain is
            # flagged when either of its contacts is. Contact c joins grains c - 1 (above) and c of the lane.
            contact_flags = int(0)
            for c in range(G1):
                upper_u = left_values[0]
                upper_hv = left_values[1]
                upper_pred = u_left
                if c > 0:
                    upper_u = s[0, wp.max(c - 1, 0)]
                    upper_hv = s[1, wp.max(c - 1, 0)]
                    upper_pred = up[wp.max(c - 1, 0)]
                lower_u = right_values[0]
                lower_hv = right_values[1]
                lower_pred = u_right
                if c < G:
                    lower_u = s[0, wp.min(c, G - 1)]
                    lower_hv = s[1, wp.min(c, G - 1)]
                    lower_pred = up[wp.min(c, G - 1)]
                if wp.static(DRIVEN):
                    driver_above_here = at_driver(c - 1, ln.k0)
                    upper_u = wp.where(driver_above_here, driver_above[0], upper_u)
                    upper_hv = wp.where(driver_above_here, driver_above[1], upper_hv)
                hit = near_event(
                    ln.delta0[c] + (upper_u - lower_u),
                    ln.delta0[c] + (upper_pred - lower_pred),
                    upper_hv - lower_hv,
                    ln.h,
                )
                contact_flags = contact_flags | ((int(hit) & ((ln.contact_bits >> c) & 1)) << c)
            event_bits = (contact_flags | (contact_flags >> 1)) & ((1 << G) - 1)
            # one vote a step: a block with no flagged grain (most steps) skips the rest; otherwise every lane
            # publishes its t_n state to shared memory, where the event steps read their neighbours
            any_event = block_any(event_bits)
            if any_event != 0:
                wp.tile_assign(states, wp.tile(s, preserve_type=True))
                wp.tile_assign(flags, wp.tile(event_bits))
                shared_event_steps(states, flags, results, ln, ar, phase_old)
                s = wp.tile_extract(states, ln.lane)  # (so that the lane's registers need not hold s meanwhile)
        # the contact forces after the event section (which needs only the overlaps), so that with event-aware steps
        # the forces and the corrector are scheduled together, not split by the section's branch
        force = forces(delta, ln.a_c, ln.force0, ln.n)
        if wp.static(MASKED and FREE_END):
            for k in range(G1):
                if (ln.contact_bits & (1 << k)) == 0:
                    force[k] = real(0)
        if wp.static(DASHPOT):
            # each contact's dashpot at the predicted t_n+1 (kernels/step.py: added to its Hertz force). The lane's
            # rates are recomputed rather than kept from the edge tile above: keeping them across the barrier cost
            # registers (sm_90, ptxas: 255 against 251 on gpu_10k's tile kernel)
            rate_left = real(0)
            rate_right = real(0)
            if ln.has_left:
                rate_left = wp.tile_extract(edges, ln.lane - 1, 3)
            if ln.has_right:
                rate_right = wp.tile_extract(edges, ln.lane + 1, 2)
            damp = dashpot_forces(
                up,
                lane_rates(s, ln.k0, ln.amplitude, ln.omega, phase_new, ln.dt),
                u_left,
                rate_left,
                u_right,
                rate_right,
                ln.delta0,
                ln.contact_bits,
                ln.gamma,
                ln.h,
            )
            for k in range(G1):
                force[k] = force[k] + damp[k]
        # 4. corrector. Padding grains have 1/m = 0: at rest they stay exactly 0. A fixed bottom grain is held.
        out = s
        for k in range(G):
            half_h2_acc = ln.hh * (force[k] - force[k + 1]) * ln.inv_m[k]
            if wp.static(VISCOUS):
                half_h2_acc -= real(0.5) * ln.h * ln.gamma * predicted_rate(column(s, k))  # h²/2 · (−γ v)
            if wp.static(COMPOSED):
                new = nordsieck.substep_corrected(column(s, k), up[k], half_h2_acc, w)
            else:
                new = nordsieck.corrected(column(s, k), up[k], half_h2_acc)
            if wp.static(FIXED):
                moving = (ln.move_bits & (1 << k)) != 0
                for q in range(Q):
                    out[q, k] = wp.where(moving, new[q], s[q, k])
            else:
                for q in range(Q):
                    out[q, k] = new[q]
        if wp.static(EVENTS):
            if any_event != 0:
                for k in range(G):  # the lane's flagged grains take their event steps' results
                    if ((event_bits >> k) & 1) != 0:
                        taken = wp.tile_extract(results, ln.lane * G + k)
                        for q in range(Q):
                            out[q, k] = taken[q]
        # (the driver's own column is left to its corrector: see driver_values)
        return out

    return advance


def step_function(t: TileLayout, *, advance, dissipation, dashpot_losses, write_traces, driver_log_entry):
    """One step of the fused kernel's loop, inlined at each of its three call sites (CUDA ``__forceinline__``): the
    driver's log entry, the viscous loss, ``advance``, the contact dashpot's loss and the trace sample; returns the
    lane's new state, its grains' dissipated energy and the next trace step."""
    real, DRIVEN, VISCOUS, DASHPOT, TRACES = t.real, t.DRIVEN, t.VISCOUS, t.DASHPOT, t.TRACES
    COMPOSED, SUBSTEPS, substep_weight = t.COMPOSED, t.SUBSTEPS, t.substep_weight
    state_t, loss_vec, lane_t, arrays_t = t.state_t, t.loss_vec, t.lane_t, t.arrays_t

    @wp.func(inline=True)
    def fused_step(
        s: state_t,
        edges: Any,
        edges_next: Any,
        states: Any,
        flags: Any,
        results: Any,
        lost: loss_vec,
        next_trace: int,
        ln: lane_t,
        ar: arrays_t,
        phase_old: wp.vec2d,
        phase_new: wp.vec2d,
        step: int,
    ):
        # ``step``: the launch's step taken from phase_old's t_n to phase_new's t_n+1
        if wp.static(DRIVEN):
            ar.driver_log[ln.log_row, step] = driver_log_entry(s, ln.k0, real(product_rn(ln.amplitude, phase_old[0])))
        if wp.static(VISCOUS):
            lost = dissipation(s, lost, ln.inv_m, ln.move_bits, ln.k0, ln.gamma, ln.h, ln.dt)
        if wp.static(COMPOSED):
            # the step's substeps, each exchanging its lanes' edges through the other buffer than the one before (an
            # odd count: the step ends on ``edges``, and the next step starts on ``edges_next``)
            s_new = advance(s, edges, states, flags, results, ln, ar, phase_old, phase_new, substep_weight(0))
            j = int(1)
            while j < wp.static(SUBSTEPS):
                w = substep_weight(j)
                s_new = advance(s_new, edges_next, states, flags, results, ln, ar, phase_old, phase_new, w)
                w = substep_weight(j + 1)
                s_new = advance(s_new, edges, states, flags, results, ln, ar, phase_old, phase_new, w)
                j += 2
        else:
            s_new = advance(s, edges, states, flags, results, ln, ar, phase_old, phase_new, real(1))
        if wp.static(DASHPOT):
            lost = dashpot_losses(s, lost, edges, ln, phase_old, phase_new)
        if wp.static(TRACES):
            next_trace = write_traces(
                s_new,
                ar.x_in,
                ln.frozen,
                ln.live,
                ln.cc,
                ln.base,
                ln.keep_lo,
                ln.keep_hi,
                ar.trace_slot,
                ln.trace_stride,
                ln.step0 + step + 1,
                next_trace,
                ar.trace_x,
                ln.amplitude,
                ln.omega,
                phase_new,
                ln.dt,
            )
        return s_new, lost, next_trace

    return fused_step
