"""Fused window kernels: many steps per launch with each chain (or a window of it) on-chip.

A block of ``lanes_per_chain × chains_per_block`` threads holds whole chains (or, for long chains,
*windows* of them) in registers: lane ``l`` of a chain keeps the Nordsieck values of ``G`` consecutive
grains ``base … base + G − 1`` as one small matrix (values × G). One step is

1. predict every grain of the lane (registers only);
2. publish the lane's first and last predicted position to a shared tile (one barrier); read the
   neighbour lanes' edge positions from it (double-buffered by step parity, so one barrier a step);
3. sweep the lane's G + 1 contacts once each (the edge contacts are also computed by the
   neighbour lane: (G + 1)/G contact evaluations per grain), correct each grain.

The arithmetic is the per-step kernel's (``kernels/step.py``) expression for expression, so on
the same device the results agree to the last bit wherever the compiler contracts alike.

Grains outside the chain (padding of the last lane, or of a window past an end) hold value 0 and are
never moved, so a padding grain next to a wall *is* the wall (SPEC §1: a wall is a grain at rest at
its static position). Free ends mask the one contact they lack.

Long chains (more grains than a block holds) are cut into windows of ``interior`` grains plus
``ghost`` grains of each neighbour on both sides. Information moves one grain per step, so after
``steps ≤ ghost`` steps a window's interior is exact; only the interior is written back. Windows read
``x_in`` and write ``x_out`` (never the same buffer), so no window sees another's partial update.

Features not fused: drive (``surface = "driven"``) and traces; they stay on the per-step kernel.
"""


import functools
from dataclasses import dataclass

import warp as wp

from .features import GEAR_CORRECTOR, STATUS_NON_FINITE, Features
from .physics import contact_functions


def fusable(features: Features) -> bool:
    """True when the fused kernels implement every feature of this set (no drive, no traces)."""
    return features.surface != "driven" and not features.traces


@dataclass(frozen=True)
class TileShape:
    """Launch shape of a fused kernel: compile-time part (lanes, grains per lane, chains per block)."""

    grains_per_lane: int
    """G: consecutive grains held in registers by one thread."""
    lanes_per_chain: int
    """Threads per chain (or per window)."""
    chains_per_block: int = 1
    """Chains sharing one block (1 for windowed chains)."""
    windowed: bool = False
    """Long-chain mode: several blocks per chain with ghost zones."""
    masked: bool = True
    """Compile the padding/free-end masks (off only when every lane is full and both ends are walls)."""

    @property
    def block_dim(self) -> int:
        return self.lanes_per_chain * self.chains_per_block

    @property
    def window(self) -> int:
        """Grains one chain (or window) holds on-chip."""
        return self.lanes_per_chain * self.grains_per_lane


@functools.cache
def tile_kernel(features: Features, shape: TileShape):
    """The fused kernel for one feature set and compile-time launch shape (cached)."""
    f = features
    if not fusable(f):
        raise ValueError(f"fused kernels do not implement surface={f.surface!r} / traces={f.traces}")
    real = wp.float64 if f.precision == "float64" else wp.float32
    Q = f.values
    GEAR = f.method != "verlet"
    C = GEAR_CORRECTOR.get(f.method, ((0, 1),) * 6)
    C = C + ((0, 1),) * (6 - len(C))
    G = shape.grains_per_lane
    L = shape.lanes_per_chain
    CPB = shape.chains_per_block
    B = shape.block_dim
    WINDOWED = shape.windowed
    MASKED = shape.masked
    SURFACE_WALL = f.surface == "wall"
    BOTTOM_WALL = f.bottom == "wall"
    FIXED = f.bottom == "fixed"
    FREE_END = (not SURFACE_WALL) or f.bottom == "free"
    STATIC = f.static != "none"
    PROFILE = f.static == "profile"
    HETERO = f.heterogeneous
    HERTZ = f.hertz
    contact_force, _ = contact_functions(f.precision, f.hertz)

    state_t = wp.types.matrix(shape=(Q, G), dtype=real)
    grain_vec = wp.types.vector(length=G, dtype=real)
    contact_vec = wp.types.vector(length=G + 1, dtype=real)
    edge_t = wp.types.vector(length=2, dtype=real)

    @wp.func
    def advance(s: state_t, edges: Any, lane: int, has_left: bool, has_right: bool,
                delta0: contact_vec, a_c: contact_vec, force0: contact_vec, n: real,
                inv_m: grain_vec, hh: real, contact_bits: int, move_bits: int) -> state_t:
        # 1. predict
        up = grain_vec()
        for k in range(G):
            p = s[0, k] + s[1, k] + s[2, k]
            if wp.static(Q >= 4):
                p += s[3, k]
            if wp.static(Q >= 5):
                p += s[4, k]
            if wp.static(Q >= 6):
                p += s[5, k]
            up[k] = p
        # 2. exchange the lane's edge positions with its neighbours (virtual grains outside sit at 0)
        wp.tile_assign(edges, wp.tile(edge_t(up[0], up[G - 1]), preserve_type=True))
        u_left = real(0)
        u_right = real(0)
        if has_left:
            u_left = wp.tile_extract(edges, lane - 1, 1)
        if has_right:
            u_right = wp.tile_extract(edges, lane + 1, 0)
        # 3. contacts (once each) and corrector
        out = s
        force_above = contact_force(delta0[0] + (u_left - up[0]), a_c[0], n) - force0[0]
        if wp.static(MASKED and FREE_END):
            if (contact_bits & 1) == 0:
                force_above = real(0)
        for k in range(G):
            u_below = u_right
            if wp.static(k < G - 1):
                u_below = up[k + 1]
            force_below = contact_force(delta0[k + 1] + (up[k] - u_below), a_c[k + 1], n) - force0[k + 1]
            if wp.static(MASKED and FREE_END):
                if (contact_bits & wp.static(1 << (k + 1))) == 0:
                    force_below = real(0)
            half_h2_acc = hh * (force_above - force_below) * inv_m[k]
            force_above = force_below
            if wp.static(GEAR):
                p1 = s[1, k] + real(2) * s[2, k]
                p2 = s[2, k]
                p3 = real(0)
                p4 = real(0)
                p5 = real(0)
                if wp.static(Q >= 4):
                    x3 = s[3, k]
                    p1 += real(3) * x3
                    p2 += real(3) * x3
                    p3 = x3
                if wp.static(Q >= 5):
                    x4 = s[4, k]
                    p1 += real(4) * x4
                    p2 += real(6) * x4
                    p3 += real(4) * x4
                    p4 = x4
                if wp.static(Q >= 6):
                    x5 = s[5, k]
                    p1 += real(5) * x5
                    p2 += real(10) * x5
                    p3 += real(10) * x5
                    p4 += real(5) * x5
                    p5 = x5
                corr = half_h2_acc - p2
                out[0, k] = up[k] + real(wp.static(C[0][0])) / real(wp.static(C[0][1])) * corr
                out[1, k] = p1 + real(wp.static(C[1][0])) / real(wp.static(C[1][1])) * corr
                out[2, k] = half_h2_acc
                if wp.static(Q >= 4):
                    out[3, k] = p3 + real(wp.static(C[3][0])) / real(wp.static(C[3][1])) * corr
                if wp.static(Q >= 5):
                    out[4, k] = p4 + real(wp.static(C[4][0])) / real(wp.static(C[4][1])) * corr
                if wp.static(Q >= 6):
                    out[5, k] = p5 + real(wp.static(C[5][0])) / real(wp.static(C[5][1])) * corr
            else:
                out[0, k] = up[k]
                out[1, k] = s[1, k] + s[2, k] + half_h2_acc
                out[2, k] = half_h2_acc
        if wp.static(MASKED or FIXED):
            # padding grains (and a fixed bottom grain) never move
            for k in range(G):
                if (move_bits & wp.static(1 << k)) == 0:
                    for q in range(Q):
                        out[q, k] = s[q, k]
        return out

    @wp.kernel(module="unique", enable_backward=False)
    def fused(
        x_in: wp.array3d(dtype=real),
        clock_in: wp.array(dtype=wp.int32),
        inverse_mass: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        static_overlap: wp.array2d(dtype=real),
        exponent: wp.array(dtype=real),
        status: wp.array(dtype=wp.int32),
        dt: wp.float64,
        steps: int,
        interior: int,
        ghost: int,
        blocks_per_chain: int,
        x_out: wp.array3d(dtype=real),
        clock_out: wp.array(dtype=wp.int32),
    ):
        block, lane = wp.tid()
        chain_count = x_in.shape[1]
        n_grains = x_in.shape[2]
        segment = lane / L
        lane_c = lane - segment * L
        c = int(0)
        first = int(0)      # first grain of the window
        keep_lo = int(0)    # interior written back: [keep_lo, keep_hi)
        keep_hi = n_grains
        if wp.static(WINDOWED):
            c = block / blocks_per_chain
            piece = block - c * blocks_per_chain
            keep_lo = piece * interior
            keep_hi = wp.min(keep_lo + interior, n_grains)
            first = keep_lo - ghost
        else:
            c = block * CPB + segment
        base = first + lane_c * G
        live = c < chain_count
        cc = wp.min(c, chain_count - 1)
        if c == 0 and lane == 0 and block == 0:
            clock_out[0] = clock_in[0] + steps

        # load the lane's grains (0 outside the chain)
        s = state_t()
        for k in range(G):
            g = base + k
            if live and g >= 0 and g < n_grains:
                for q in range(Q):
                    s[q, k] = x_in[q, cc, g]

        # per-contact and per-grain constants (contact base + k joins grains base + k − 1 and base + k)
        n = real(0)
        if wp.static(not HERTZ):
            n = exponent[cc]
        delta0 = contact_vec()
        a_c = contact_vec()
        force0 = contact_vec()
        inv_m = grain_vec()
        contact_bits = int(0)
        move_bits = int(0)
        lo = int(1)
        if wp.static(SURFACE_WALL):
            lo = 0
        hi = n_grains - 1
        if wp.static(BOTTOM_WALL):
            hi = n_grains
        for k in range(G + 1):
            kk = wp.min(wp.max(base + k, 0), n_grains)
            if base + k >= lo and base + k <= hi:
                contact_bits = contact_bits | wp.static(1 << k)
            d0 = real(0)
            if wp.static(PROFILE):
                d0 = static_overlap[cc, kk]
            elif wp.static(STATIC):
                d0 = static_overlap[cc, 0]
            ac = real(0)
            if wp.static(HETERO):
                ac = contact_constant[cc, kk]
            else:
                ac = contact_constant[cc, 0]
            delta0[k] = d0
            a_c[k] = ac
            force0[k] = contact_force(d0, ac, n)
        for k in range(G):
            g = base + k
            if g >= 0 and g < n_grains:
                move_bits = move_bits | wp.static(1 << k)
                if wp.static(FIXED):
                    if g == n_grains - 1:
                        move_bits = move_bits & wp.static(~(1 << k))
            if wp.static(HETERO):
                inv_m[k] = inverse_mass[cc, wp.min(wp.max(g, 0), n_grains - 1)]
            else:
                inv_m[k] = inverse_mass[cc, 0]

        h = real(dt)
        hh = real(0.5) * h * h
        has_left = lane_c > 0
        has_right = lane_c < L - 1
        edges_even = wp.tile_zeros(shape=B, dtype=edge_t, storage="shared")
        edges_odd = wp.tile_zeros(shape=B, dtype=edge_t, storage="shared")
        for _pair in range(steps / 2):
            s = advance(s, edges_even, lane, has_left, has_right, delta0, a_c, force0, n, inv_m, hh,
                        contact_bits, move_bits)
            s = advance(s, edges_odd, lane, has_left, has_right, delta0, a_c, force0, n, inv_m, hh,
                        contact_bits, move_bits)
        if steps % 2 == 1:
            s = advance(s, edges_even, lane, has_left, has_right, delta0, a_c, force0, n, inv_m, hh,
                        contact_bits, move_bits)

        # write back the interior; a frozen (non-finite) chain keeps its state
        frozen = status[cc] == wp.static(STATUS_NON_FINITE)
        for k in range(G):
            g = base + k
            if live and g >= keep_lo and g < keep_hi:
                for q in range(Q):
                    if frozen:
                        x_out[q, cc, g] = x_in[q, cc, g]
                    else:
                        x_out[q, cc, g] = s[q, k]

    return fused
