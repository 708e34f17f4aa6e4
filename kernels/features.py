"""The key that selects a kernel variant: only what some chain in the launch needs is compiled."""

from __future__ import annotations

import os
from dataclasses import dataclass
from types import SimpleNamespace

GEAR_VALUES = {"gear4": 4, "gear5": 5, "gear6": 6, "verlet": 3, "yoshida4": 3, "yoshida6": 3}
"""Values of the scaled Nordsieck vector per method (Verlet and its compositions keep u, dt·v, dt²/2·a)."""

_CUBE_ROOT_2 = 2.0 ** (1.0 / 3.0)
YOSHIDA4_OUTER = 1.0 / (2.0 - _CUBE_ROOT_2)
"""w1 = 1/(2 − 2^(1/3)) ≈ 1.3512: the first and last substep of yoshida4, as a fraction of dt."""
YOSHIDA4_INNER = 1.0 - 2.0 * YOSHIDA4_OUTER
"""w0 = −2^(1/3)/(2 − 2^(1/3)) ≈ −1.7024: the middle (backward) substep of yoshida4, computed as 1 − 2·w1 so
that the three substeps add up to exactly one step in float64 (w1 + w0 + w1 == 1.0)."""

YOSHIDA6_OUTER = (0.784513610477560, 0.235573213359357, -1.17767998417887)
"""w3, w2, w1 of yoshida6 (Yoshida 1990, solution A; Hairer, Lubich & Wanner, Geometric Numerical Integration,
§V.3.2): its first three substeps, as fractions of dt; the last three mirror them."""
YOSHIDA6_MIDDLE = 1.0 - 2.0 * sum(YOSHIDA6_OUTER)
"""w0 = 1 − 2(w1 + w2 + w3) ≈ 1.3152: the middle substep, so that the seven add up to one step."""

SUBSTEP_WEIGHTS = {
    "yoshida4": (YOSHIDA4_OUTER, YOSHIDA4_INNER, YOSHIDA4_OUTER),
    "yoshida6": (*YOSHIDA6_OUTER, YOSHIDA6_MIDDLE, *YOSHIDA6_OUTER[::-1]),
}
"""Composed methods: one step is velocity-Verlet substeps of w_k·dt in this order (Yoshida 1990,
Forest & Ruth 1990: the symmetric triple composition of a second-order method is fourth order; Yoshida's
seven-substep composition is sixth order). Each is symmetric, its middle weight 1 − 2·(the others of one half).
Methods not listed take one substep of their own kind per step."""

# Allen & Tildesley corrector coefficients for a second-order ODE, as exact fractions
# (numerator, denominator) so float64 kernels see correctly rounded constants.
GEAR_CORRECTOR = {
    "gear4": ((1, 6), (5, 6), (1, 1), (1, 3)),
    "gear5": ((19, 120), (3, 4), (1, 1), (1, 2), (1, 12)),
    "gear6": ((3, 20), (251, 360), (1, 1), (11, 18), (1, 6), (1, 60)),
}

POTENTIALS = ("hertz", "fput", "toda", "morse", "lj", "harmonic")
"""The contact laws (``chain.potential``; docs/lattices.md). hertz is the power law of the paper; the others are
nearest-neighbour lattice laws that carry tension."""
LATTICE_LAWS = POTENTIALS[1:]

EVENT_WINDOW = 1e-2
"""Default event window [time] (kernels/events.py): a fixed time, so that the treatment keeps the
method's order as dt shrinks; about 1/20 of a contact time at v_imp = 1e-2 (program units)."""

CPU_COMPILER_FLAGS = "-march=native -ffp-contract=off"
"""Clang flags of every CPU build: Warp's default target (the host's instruction set) with no contraction of
``a·b + c`` into fused multiply-adds, so every CPU kernel rounds each operation as written and kernels that do the
same arithmetic agree bit for bit, whatever the optimiser makes of their surroundings."""
KERNEL_OPTIONS = {
    "fuse_fp": os.environ.get("HERTZIAN_FUSE_FP", "1") != "0",
    "cpu_compiler_flags": CPU_COMPILER_FLAGS,
}
"""Warp module options of every kernel factory. On the CPU nothing is contracted (``CPU_COMPILER_FLAGS``). On CUDA
``HERTZIAN_FUSE_FP=0`` forbids the compiler to contract ``a·b + c`` into fused multiply-adds: CUDA then rounds every
operation as written, the same in every kernel (the per-step and fused kernels agree bit for bit, as on the CPU), at
some cost in speed. By default each CUDA kernel's contractions are the compiler's choice, so there kernels agree to
rounding, not bitwise."""

# Per-chain status codes, defined here only (kernels write them; hertzian.core.status.Status names them).
STATUS_OK = 0
STATUS_NON_FINITE = 1
"""The state became NaN/inf (record kernel); the step kernels then freeze the chain."""
STATUS_OVERLAP_BEYOND_VALIDITY = 2
"""An overlap exceeded the Hertz law's validity (record kernel)."""
STATUS_ENERGY_DRIFT = 3
"""Energy error above the tolerance (set on the host after a run)."""


@dataclass(frozen=True)
class Features:
    """What a launch needs; each field off means that code and memory are absent."""

    method: str = "gear4"
    precision: str = "float64"
    surface: str = "wall"
    """wall: a surface-wall contact; driven: grain 0 prescribed; load/free: nothing above grain 0
    (a constant load is balanced by the static state and needs no code)."""
    bottom: str = "wall"
    """wall: a bottom-wall contact; fixed: grain N-1 held; free: nothing below."""
    static: str = "none"
    """none: no static overlap anywhere; uniform: one δ0 per chain; profile: one per contact."""
    heterogeneous: bool = False
    """Per-grain masses and per-contact constants (impurities); else one of each per chain."""
    hertz: bool = True
    """Exponent 5/2 (sqrt, no pow); else a per-chain exponent."""
    traces: bool = False
    event_window: float = 0.0
    """Event-aware Gear steps (kernels/events.py): a contact within this time [time] of opening or
    closing is stepped without the kink; 0: off (no event code is generated)."""
    damping: str = "none"
    """none | viscous (−γ m v on every integrated grain) | contact (dashpot −γ δ̇ on closed contacts):
    per-chain γ, the dissipated energy accumulated per grain (every kernel; the fused ones not the dashpot in
    compensated float32)."""
    compensated: bool = True
    """float32 only: u and dt·v carried as hi + lo float32 pairs, updated by TwoSum (kernels/gear.py), two
    more state rows; False: the plain float32 update (kept for comparison). Ignored in float64."""
    potential: str = "hertz"
    """The contact law (POTENTIALS): hertz, the power law V = a·max(δ, 0)^n without tension (``hertz`` then says
    whether n = 5/2); or a lattice law with tension, fput | toda | morse | lj | harmonic (kernels/physics.py)."""

    @property
    def substeps(self) -> int:
        """Substeps per step: 3 for yoshida4, 7 for yoshida6 (SUBSTEP_WEIGHTS), else 1."""
        return len(SUBSTEP_WEIGHTS.get(self.method, (1.0,)))

    @property
    def compensation(self) -> bool:
        """True when the kernels carry the low parts of u and dt·v (float32 with ``compensated``)."""
        return self.precision == "float32" and self.compensated

    @property
    def nordsieck_values(self) -> int:
        """Length of the Nordsieck vector (3 for Verlet: u, dt·v, dt²/2·a)."""
        return GEAR_VALUES[self.method]

    @property
    def values(self) -> int:
        """Values per grain in the state: the Nordsieck vector, then (compensated float32) the low parts
        of u and dt·v (rows Q and Q + 1)."""
        return GEAR_VALUES[self.method] + (2 if self.compensation else 0)


def take(layout: SimpleNamespace, names: str) -> list:
    """The values of a kernel factory's ``layout`` named in ``names`` (space-separated), in order: how a builder
    unpacks the compile-time constants and device functions it uses."""
    return [getattr(layout, name) for name in names.split()]


def device_of(device):
    """The Warp device named ``device``, or ``device`` itself when it is one or stands for one (an object with
    ``is_cpu``, ``is_cuda``, ``arch`` and ``sm_count``: a GPU whose kernels are planned on another machine,
    hertzian.core.solvers.shape_rule.PlannedGPU)."""
    if hasattr(device, "is_cpu"):
        return device
    import warp as wp

    return wp.get_device(device)
