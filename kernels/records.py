"""Per-chain reductions at record times: energy, driver's work, largest overlap, status.

Two launches, no atomics, so results are bitwise reproducible: ``record_parts`` gives each run of
``RECORD_PART`` consecutive grains of a chain one thread, which sums them in order; ``record`` (one
thread per chain) adds the parts in order and closes the chain's sums (walls, driver, status). A
chain of up to RECORD_PART grains is one part: the same bits as one thread summing the whole chain.
Parts keep a record of a long chain from being one thread's serial loop (on a GPU, a 10 000-grain
chain's energy took one thread ~20 ms per record). Chains of STAGED_GRAINS grains or more take a third launch
first: ``record_grains`` evaluates each grain's terms in its own thread and ``record_parts_of_grains`` sums them
per part in the same order; for them ``record_long`` replaces ``record``. Both are tiled launches (a block per part,
a block per chain) whose threads copy the values to shared memory together, so the one thread that adds them in
order reads shared memory (:func:`launch_parts_of_grains`, :func:`launch_record`). Sums are float64 whatever the
state precision.
"""

import functools
from types import SimpleNamespace
from typing import Any, NamedTuple

import warp as wp
from hertzian.kernels.features import (
    KERNEL_OPTIONS,
    STATUS_NON_FINITE,
    STATUS_OK,
    STATUS_OVERLAP_BEYOND_VALIDITY,
    Features,
    device_of,
    take,
)
from hertzian.kernels.physics import (
    contact_functions,
    contact_parameters,
    excess_potential,
    lattice_excess_potential,
    shape_function,
)
from hertzian.kernels.tile import block_sync

RECORD_PART = 128
"""Grains per thread of ``record_parts`` (fixed, so the sums' order does not depend on the device)."""
STAGED_GRAINS = 2048
"""Chains of at least this many grains are reduced in two stages: each grain's terms by one thread
(``record_grains``), then summed per part in the same order (``record_parts_of_grains``). A 10 000-grain column's
parts are 79 threads that each evaluate 128 excess potentials in turn (a series with a division per term), a slow
record on a GPU. The choice depends on the grain count only, so a chain alone and in an ensemble
take the same path."""
RECORD_BLOCK_DIM = 32
"""Threads per block of ``record_parts`` (a thread per part): few threads in all for long chains, so small blocks
spread them over the GPU's SMs instead of leaving them to one (Warp's default block holds 256). Its module is made
for it."""
PART_TILE = 32
"""Parts' sums ``record_long`` copies to shared memory at a time."""
PART_TILE_THREADS = 32
"""Threads of a ``record_parts_of_grains`` block (one block per part; launched with :func:`launch_parts_of_grains`).
A thread per part summing its terms from device memory waits for each of its loads in turn, which made a
10 000-grain column's record slow (ncu)."""
PART_SUMS = 5
"""Per part: kinetic energy, excess potential, largest overlap, finite (1.0 or 0.0), dissipated energy."""


def record_part_count(grains: int) -> int:
    """Parts of a chain of ``grains`` grains (the second dimension of the parts array)."""
    return -(-grains // RECORD_PART)


class RecordKernels(NamedTuple):
    """The record reductions of one feature set (see the module docstring)."""

    parts: Any
    """record_parts: one thread per run of RECORD_PART grains."""
    record: Any
    """record: one thread per chain, closing its sums."""
    grains: Any
    """record_grains: long chains, each grain's terms (one thread per grain)."""
    parts_of_grains: Any
    """record_parts_of_grains: long chains, record_parts' sums of record_grains' terms (the same bits where the
    compiler contracts alike)."""
    record_long: Any
    """record_long: long chains, ``record`` with a block per chain (launched by :func:`launch_record`)."""


@functools.cache
def record_kernels(features: Features) -> RecordKernels:
    """The record kernels for one feature set: energy (relative to the static state), work, max overlap and
    status, as described in the module docstring."""
    layout = _record_layout(features)
    functions = _record_functions(layout)
    (real,) = take(layout, "real")
    store_part, grain_terms_of, add_terms = take(functions, "store_part grain_terms_of add_terms")
    (close_record,) = take(functions, "close_record")

    @wp.kernel(module="unique", module_options=dict(KERNEL_OPTIONS, block_dim=RECORD_BLOCK_DIM), enable_backward=False)
    def record_parts(
        x: wp.array3d(dtype=real),
        inverse_mass: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        static_overlap: wp.array2d(dtype=real),
        law_parameters: wp.array(dtype=real),
        validity_scale: wp.array2d(dtype=wp.float64),
        dt: wp.float64,
        dissipated_grain: wp.array2d(dtype=wp.float64),
        parts: wp.array3d(dtype=wp.float64),
    ):
        # grains [part·RECORD_PART, (part + 1)·RECORD_PART) of chain c, in order
        c, part = wp.tid()
        n_grains = x.shape[2]
        start = part * wp.static(RECORD_PART)
        end = wp.min(start + wp.static(RECORD_PART), n_grains)
        sums = wp.vec4d(wp.float64(0.0), wp.float64(0.0), wp.float64(-1.0e300), wp.float64(1.0))
        for i in range(start, end):
            sums = add_terms(
                sums,
                grain_terms_of(
                    x, inverse_mass, contact_constant, static_overlap, law_parameters, validity_scale, dt, c, i
                ),
            )
        store_part(parts, c, part, sums, dissipated_grain, start, end)

    @wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
    def record_grains(
        x: wp.array3d(dtype=real),
        inverse_mass: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        static_overlap: wp.array2d(dtype=real),
        law_parameters: wp.array(dtype=real),
        validity_scale: wp.array2d(dtype=wp.float64),
        dt: wp.float64,
        terms_out: wp.array2d(dtype=wp.vec4d),
    ):
        # long chains, first stage: grain i's terms of record_parts' sums, one thread per grain
        c, i = wp.tid()
        terms_out[c, i] = grain_terms_of(
            x, inverse_mass, contact_constant, static_overlap, law_parameters, validity_scale, dt, c, i
        )

    part_block = wp.types.matrix(shape=(4, 5), dtype=wp.float64)  # four parts' sums, loaded together

    @wp.kernel(module="unique", module_options=dict(KERNEL_OPTIONS, block_dim=PART_TILE_THREADS), enable_backward=False)
    def record_parts_of_grains(
        grain_terms: wp.array2d(dtype=wp.vec4d),
        dissipated_grain: wp.array2d(dtype=wp.float64),
        parts: wp.array3d(dtype=wp.float64),
    ):
        # long chains, second stage (a block per part, launch_tiled): record_parts' sums over grains
        # [part·RECORD_PART, (part + 1)·RECORD_PART) of chain c, in the same order, from record_grains' terms. The
        # block copies the part's terms to shared memory together, then one thread adds them in order: its serial
        # loop reads shared memory, where a thread loading its own terms from device memory waited on every load
        c, part, lane = wp.tid()
        n_grains = grain_terms.shape[1]
        start = part * wp.static(RECORD_PART)
        end = wp.min(start + wp.static(RECORD_PART), n_grains)
        terms = wp.tile_load(grain_terms, shape=(1, RECORD_PART), offset=(c, start), storage="shared")
        if lane == 0:
            sums = wp.vec4d(wp.float64(0.0), wp.float64(0.0), wp.float64(-1.0e300), wp.float64(1.0))
            for i in range(end - start):
                sums = add_terms(sums, terms[0, i])
            store_part(parts, c, part, sums, dissipated_grain, start, end)

    @wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
    def record(
        x: wp.array3d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        static_overlap: wp.array2d(dtype=real),
        law_parameters: wp.array(dtype=real),
        drive: wp.array2d(dtype=wp.float64),
        work_in: wp.array(dtype=wp.float64),
        power_in: wp.array(dtype=wp.float64),
        step: int,
        dt: wp.float64,
        validity_overlap: wp.array(dtype=wp.float64),
        validity_scale: wp.array2d(dtype=wp.float64),
        parts: wp.array3d(dtype=wp.float64),
        energy: wp.array(dtype=wp.float64),
        work: wp.array(dtype=wp.float64),
        max_overlap: wp.array(dtype=wp.float64),
        status: wp.array(dtype=wp.int32),
        damping: wp.array(dtype=real),
        dissipated: wp.array(dtype=wp.float64),
    ):
        # the parts of chain c in order, then the walls, the driver's work and the status
        c = wp.tid()
        sums = wp.vec4d(wp.float64(0.0), wp.float64(0.0), wp.float64(-1.0e300), wp.float64(1.0))
        lost = wp.float64(0.0)
        part_count = parts.shape[1]
        part = int(0)
        while part < part_count:  # four parts' loads in flight, then added in order (a long chain has many parts)
            loaded = part_block()
            for q in range(4):
                for k in range(5):
                    loaded[q, k] = parts[c, wp.min(part + q, part_count - 1), k]
            for q in range(4):
                if part + q < part_count:
                    sums = add_terms(sums, wp.vec4d(loaded[q, 0], loaded[q, 1], loaded[q, 2], loaded[q, 3]))
                    lost += loaded[q, 4]
            part += 4
        close_record(
            x,
            contact_constant,
            static_overlap,
            law_parameters,
            drive,
            work_in,
            power_in,
            step,
            dt,
            validity_overlap,
            validity_scale,
            energy,
            work,
            max_overlap,
            status,
            damping,
            dissipated,
            c,
            sums,
            lost,
        )

    @wp.kernel(module="unique", module_options=dict(KERNEL_OPTIONS, block_dim=PART_TILE_THREADS), enable_backward=False)
    def record_long(
        x: wp.array3d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        static_overlap: wp.array2d(dtype=real),
        law_parameters: wp.array(dtype=real),
        drive: wp.array2d(dtype=wp.float64),
        work_in: wp.array(dtype=wp.float64),
        power_in: wp.array(dtype=wp.float64),
        step: int,
        dt: wp.float64,
        validity_overlap: wp.array(dtype=wp.float64),
        validity_scale: wp.array2d(dtype=wp.float64),
        parts: wp.array3d(dtype=wp.float64),
        energy: wp.array(dtype=wp.float64),
        work: wp.array(dtype=wp.float64),
        max_overlap: wp.array(dtype=wp.float64),
        status: wp.array(dtype=wp.int32),
        damping: wp.array(dtype=real),
        dissipated: wp.array(dtype=wp.float64),
    ):
        # ``record`` for long chains (a block per chain, launch_tiled): the block copies PART_TILE parts' sums at a
        # time to shared memory together, one thread adds them in order (the same sums), then closes the record
        c, lane = wp.tid()
        sums = wp.vec4d(wp.float64(0.0), wp.float64(0.0), wp.float64(-1.0e300), wp.float64(1.0))
        lost = wp.float64(0.0)
        part_count = parts.shape[1]
        first = int(0)
        while first < part_count:
            loaded = wp.tile_load(parts, shape=(1, PART_TILE, PART_SUMS), offset=(c, first, 0), storage="shared")
            if lane == 0:
                for q in range(wp.min(part_count - first, PART_TILE)):
                    sums = add_terms(sums, wp.vec4d(loaded[0, q, 0], loaded[0, q, 1], loaded[0, q, 2], loaded[0, q, 3]))
                    lost += loaded[0, q, 4]
            block_sync(0)  # the tile is read before the next part's copy overwrites it
            first += PART_TILE
        if lane == 0:
            close_record(
                x,
                contact_constant,
                static_overlap,
                law_parameters,
                drive,
                work_in,
                power_in,
                step,
                dt,
                validity_overlap,
                validity_scale,
                energy,
                work,
                max_overlap,
                status,
                damping,
                dissipated,
                c,
                sums,
                lost,
            )

    return RecordKernels(record_parts, record, record_grains, record_parts_of_grains, record_long)


def _record_layout(features: Features) -> SimpleNamespace:
    """The record kernels' compile-time constants and the contact law's device functions, for one feature set."""
    f = features
    f = features
    real = wp.float64 if f.precision == "float64" else wp.float32
    SURFACE_WALL = f.surface == "wall"
    DRIVEN = f.surface == "driven"
    BOTTOM_WALL = f.bottom == "wall"
    RING = f.surface == "periodic"  # the closing contact (grains N − 1 and 0), padded contact 0
    HETERO = f.heterogeneous
    DAMPED = f.damping != "none"
    DASHPOT = f.damping == "contact"
    contact_force, excess_force = contact_functions(f.precision, f.hertz, f.potential)
    params = contact_parameters(f.precision, f.static, f.heterogeneous, f.hertz, f.potential)
    shape = shape_function(f.precision, f.potential)
    LATTICE = f.potential != "hertz"
    lattice_excess = lattice_excess_potential(f.potential) if LATTICE else None
    VALIDITY = not LATTICE  # the Hertz law's overlap limit; a lattice law has none
    COMP = f.compensation
    LO_U = f.nordsieck_values  # compensated float32: rows of the low parts of u and dt·v (kernels/gear.py)
    LO_RATE = LO_U + 1
    return SimpleNamespace(**{name: value for name, value in locals().items() if name != "features"})


def _record_functions(layout: SimpleNamespace) -> SimpleNamespace:
    """The record kernels' device functions: a grain's position and rate in float64, a contact's excess potential
    and overlap, a grain's terms, a part's sums stored, and a chain's record closed."""
    real, SURFACE_WALL, DRIVEN, BOTTOM_WALL, RING = take(layout, "real SURFACE_WALL DRIVEN BOTTOM_WALL RING")
    HETERO, DAMPED, DASHPOT, contact_force = take(layout, "HETERO DAMPED DASHPOT contact_force")
    excess_force, params, shape, LATTICE = take(layout, "excess_force params shape LATTICE")
    lattice_excess, VALIDITY, COMP, LO_U, LO_RATE = take(layout, "lattice_excess VALIDITY COMP LO_U LO_RATE")

    @wp.func
    def position(x: wp.array3d(dtype=real), c: int, i: int) -> wp.float64:
        # u of grain i in float64 (compensated: hi + lo)
        if wp.static(COMP):
            return wp.float64(x[0, c, i]) + wp.float64(x[wp.static(LO_U), c, i])
        return wp.float64(x[0, c, i])

    @wp.func
    def rate(x: wp.array3d(dtype=real), c: int, i: int) -> wp.float64:
        # dt·v of grain i in float64 (compensated: hi + lo)
        if wp.static(COMP):
            return wp.float64(x[1, c, i]) + wp.float64(x[wp.static(LO_RATE), c, i])
        return wp.float64(x[1, c, i])

    @wp.func
    def contact_terms(
        static_overlap: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        law_parameters: wp.array(dtype=real),
        c: int,
        k: int,
        d: wp.float64,
    ) -> wp.vec2d:
        # (excess potential, absolute overlap) of padded contact k at relative displacement d
        p = params(static_overlap, contact_constant, law_parameters, c, k)
        delta0 = wp.float64(p[0])
        if wp.static(LATTICE):
            shape64 = wp.vec2d(wp.float64(p[2]), wp.float64(p[3]))
            return wp.vec2d(lattice_excess(delta0, d, wp.float64(p[1]), shape64), delta0 + d)
        else:
            return wp.vec2d(excess_potential(delta0, d, wp.float64(p[1]), wp.float64(p[2])), delta0 + d)

    @wp.func
    def store_part(
        parts: wp.array3d(dtype=wp.float64),
        c: int,
        part: int,
        sums: wp.vec4d,
        dissipated_grain: wp.array2d(dtype=wp.float64),
        start: int,
        end: int,
    ):
        # a part's (kinetic, potential, largest overlap, finite) and, damped, its grains' dissipated energy in order
        lost = wp.float64(0.0)
        if wp.static(DAMPED):
            for i in range(start, end):
                lost += dissipated_grain[c, i]
        for q in range(4):
            parts[c, part, q] = sums[q]
        parts[c, part, 4] = lost

    @wp.func
    def grain_terms_of(
        x: wp.array3d(dtype=real),
        inverse_mass: wp.array2d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        static_overlap: wp.array2d(dtype=real),
        law_parameters: wp.array(dtype=real),
        validity_scale: wp.array2d(dtype=wp.float64),
        dt: wp.float64,
        c: int,
        i: int,
    ) -> wp.vec4d:
        # grain i's terms of a chain's sums: kinetic energy (0 for the driven grain, whose motion is prescribed),
        # excess potential and overlap of the contact above it (0 and -1e300 for grain 0; heterogeneous: times the
        # contact's validity scale R0/min(R_i, R_j)), finite (1.0 or 0.0)
        u = position(x, c, i)
        v = rate(x, c, i) / dt
        finite = wp.float64(1.0)
        if not (wp.isfinite(u) and wp.isfinite(v)):
            finite = wp.float64(0.0)
        first = int(0)
        if wp.static(DRIVEN):
            first = 1
        kinetic = wp.float64(0.0)
        if i >= first:
            inv_m = wp.float64(0.0)
            if wp.static(HETERO):
                inv_m = wp.float64(inverse_mass[c, i])
            else:
                inv_m = wp.float64(inverse_mass[c, 0])
            kinetic = wp.float64(0.5) * v * v / inv_m
        potential = wp.float64(0.0)
        overlap = wp.float64(-1.0e300)
        if i > 0:
            terms = contact_terms(static_overlap, contact_constant, law_parameters, c, i, position(x, c, i - 1) - u)
            potential = terms[0]
            overlap = terms[1]
            if wp.static(HETERO):
                overlap = overlap * validity_scale[c, i]
        return wp.vec4d(kinetic, potential, overlap, finite)

    @wp.func
    def add_terms(sums: wp.vec4d, terms: wp.vec4d) -> wp.vec4d:
        # a part's running sums (kinetic, potential), largest overlap and finite flag, one grain further
        return wp.vec4d(sums[0] + terms[0], sums[1] + terms[1], wp.max(sums[2], terms[2]), wp.min(sums[3], terms[3]))

    @wp.func
    def close_record(
        x: wp.array3d(dtype=real),
        contact_constant: wp.array2d(dtype=real),
        static_overlap: wp.array2d(dtype=real),
        law_parameters: wp.array(dtype=real),
        drive: wp.array2d(dtype=wp.float64),
        work_in: wp.array(dtype=wp.float64),
        power_in: wp.array(dtype=wp.float64),
        step: int,
        dt: wp.float64,
        validity_overlap: wp.array(dtype=wp.float64),
        validity_scale: wp.array2d(dtype=wp.float64),
        energy: wp.array(dtype=wp.float64),
        work: wp.array(dtype=wp.float64),
        max_overlap: wp.array(dtype=wp.float64),
        status: wp.array(dtype=wp.int32),
        damping: wp.array(dtype=real),
        dissipated: wp.array(dtype=wp.float64),
        c: int,
        sums: wp.vec4d,
        lost: wp.float64,
    ):
        # chain c's record from the sums of its parts: the walls, the driver's work and the status
        n_grains = x.shape[2]
        kinetic = sums[0]
        potential = sums[1]
        largest = sums[2]
        finite = sums[3]
        if wp.static(SURFACE_WALL):
            terms = contact_terms(static_overlap, contact_constant, law_parameters, c, 0, -position(x, c, 0))
            potential += terms[0]
            if wp.static(HETERO):
                largest = wp.max(largest, terms[1] * validity_scale[c, 0])
            else:
                largest = wp.max(largest, terms[1])
        if wp.static(RING):
            closing = position(x, c, n_grains - 1) - position(x, c, 0)
            terms = contact_terms(static_overlap, contact_constant, law_parameters, c, 0, closing)
            potential += terms[0]
            largest = wp.max(largest, terms[1])
        if wp.static(BOTTOM_WALL):
            terms = contact_terms(
                static_overlap, contact_constant, law_parameters, c, n_grains, position(x, c, n_grains - 1)
            )
            potential += terms[0]
            if wp.static(HETERO):
                largest = wp.max(largest, terms[1] * validity_scale[c, n_grains])
            else:
                largest = wp.max(largest, terms[1])
        energy[c] = kinetic + potential
        max_overlap[c] = largest

        if wp.static(DRIVEN):
            # close the trapezoid of the driver's power up to this record's time
            amplitude = drive[c, 0]
            omega = drive[c, 1]
            d = x[0, c, 0] - x[0, c, 1]
            p = params(static_overlap, contact_constant, law_parameters, c, 1)
            delta0 = p[0]
            a_c = p[1]
            n = shape(p)
            force = wp.float64(excess_force(delta0, d, a_c, n))
            if wp.static(DASHPOT):
                # the dashpot of the driver's contact (as in the step kernel's work)
                if delta0 + d > real(0):
                    force += wp.float64(damping[c]) * (wp.float64(x[1, c, 0]) - wp.float64(x[1, c, 1])) / dt
            power = force * amplitude * omega * wp.cos(omega * wp.float64(step) * dt)
            # The step kernel integrates the excess force's power; the static force of contact 0–1
            # does work F0_1·u_0(t) exactly. Adding it to work and energy makes both docs/model.md's (the
            # energy up to a constant): E − W is unchanged.
            static_work = wp.float64(contact_force(delta0, a_c, n)) * wp.float64(x[0, c, 0])
            closing = dt * wp.float64(0.5) * (power_in[c] + power)
            if wp.static(DASHPOT):
                if step == 0:
                    closing = wp.float64(0.0)  # W(0) = 0 (the dashpot's power at t = 0 is not zero)
            work[c] = work_in[c] + closing + static_work
            energy[c] = energy[c] + static_work

        if wp.static(DAMPED):
            dissipated[c] = lost

        if finite == wp.float64(0.0):
            status[c] = wp.static(STATUS_NON_FINITE)
        elif wp.static(VALIDITY):
            if status[c] == wp.static(STATUS_OK) and largest > validity_overlap[c]:
                status[c] = wp.static(STATUS_OVERLAP_BEYOND_VALIDITY)

    return SimpleNamespace(
        position=position,
        rate=rate,
        contact_terms=contact_terms,
        store_part=store_part,
        grain_terms_of=grain_terms_of,
        add_terms=add_terms,
        close_record=close_record,
    )


@wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
def track_extremes(
    energy: wp.array(dtype=wp.float64),
    work: wp.array(dtype=wp.float64),
    initial_energy: wp.array(dtype=wp.float64),
    driven: int,
    overlap: wp.array(dtype=wp.float64),
    energy_deviation: wp.array(dtype=wp.float64),
    largest_overlap: wp.array(dtype=wp.float64),
    dissipated: wp.array(dtype=wp.float64),
):
    # running max of |E − E(0) [− W] [+ D]| and of the largest overlap, between records too
    c = wp.tid()
    change = energy[c] - initial_energy[c]
    if driven != 0:
        change = change - work[c]
    if dissipated.shape[0] > 0:
        change = change + dissipated[c]
    energy_deviation[c] = wp.max(energy_deviation[c], wp.abs(change))
    largest_overlap[c] = wp.max(largest_overlap[c], overlap[c])


@functools.cache
def traced_start_kernel(precision: str):
    """Gathers the traced grains' u and dt·v (rows 0 and 1 of the state) into ``out`` (2, chains, traced): a run
    that keeps traces but no snapshots copies these at t = 0 instead of every grain."""
    real = wp.float64 if precision == "float64" else wp.float32

    @wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
    def traced_start(x: wp.array3d(dtype=real), traced: wp.array(dtype=wp.int32), out: wp.array3d(dtype=real)):
        row, c, j = wp.tid()
        out[row, c, j] = x[row, c, traced[j]]

    return traced_start


def parts_of_grains_block_dim(device) -> int:
    """Threads of a ``record_parts_of_grains`` block on ``device``: one on a CPU (which runs a block's threads in
    turn), PART_TILE_THREADS on a GPU."""
    return 1 if device_of(device).is_cpu else PART_TILE_THREADS


def record_parts_block_dim(device) -> int | None:
    """Threads of a ``record_parts`` block on ``device``: Warp's default (one) on a CPU, RECORD_BLOCK_DIM on a GPU.
    The launch and :func:`record_modules` both take it, so a CPU run loads the variant prepare named even after a tile
    kernel has turned Warp's CPU blocks on in the process."""
    return None if device_of(device).is_cpu else RECORD_BLOCK_DIM


def record_modules(kernels: RecordKernels, *, long_chains: bool, device) -> list[tuple]:
    """(Warp module, block_dim) of the reductions a record takes on ``device``, each at the block size its launch
    uses (None: Warp's launch default): for ``long_chains`` (STAGED_GRAINS grains or more) the grain terms, the
    per-part sums and ``record_long`` (tiled), else ``record_parts`` (RECORD_BLOCK_DIM threads on a GPU) and
    ``record``."""
    if long_chains:
        tiled = parts_of_grains_block_dim(device)
        return [
            (kernels.grains.module, None),
            (kernels.parts_of_grains.module, tiled),
            (kernels.record_long.module, tiled),
        ]
    return [(kernels.parts.module, record_parts_block_dim(device)), (kernels.record.module, None)]


def load_record_kernels(kernels: RecordKernels, *, long_chains: bool, device) -> None:
    """Load the reductions a record takes on ``device`` (:func:`record_modules`)."""
    for module, block_dim in record_modules(kernels, long_chains=long_chains, device=device):
        wp.load_module(module, device=device, block_dim=block_dim)


def launch_parts_of_grains(kernels: RecordKernels, grain_terms, dissipated_grain, parts, device) -> None:
    """``record_parts_of_grains`` over every (chain, part) of ``parts`` (chains, parts, PART_SUMS): a block each."""
    wp.launch_tiled(
        kernels.parts_of_grains,
        dim=list(parts.shape[:2]),
        inputs=[grain_terms, dissipated_grain],
        outputs=[parts],
        block_dim=parts_of_grains_block_dim(device),
        device=device,
    )


def launch_record(
    kernels: RecordKernels, *, long_chains: bool, inputs: list, outputs: list, chains: int, device
) -> None:
    """``record`` (a thread per chain) or, for ``long_chains`` (the two-stage reductions), ``record_long`` (a block
    per chain): the same arguments and the same sums."""
    if long_chains:
        wp.launch_tiled(
            kernels.record_long,
            dim=[chains],
            inputs=inputs,
            outputs=outputs,
            block_dim=parts_of_grains_block_dim(device),
            device=device,
        )
    else:
        wp.launch(kernels.record, dim=chains, inputs=inputs, outputs=outputs, device=device)
