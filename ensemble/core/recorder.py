"""Recorder: per-chain checks on the device between records, and the records themselves on the host.

``check(state, step)`` launches the record kernel (energy, driver's work, largest overlap and the
status flags, which a non-finite chain's later steps read to freeze it) and folds the result into
running extremes; it never synchronises. ``record(state, r)`` does a check and then copies what the
scenes keep (snapshots, energy, work, the trace ring) into one of ``depth`` host staging buffers (page-
locked on CUDA, so the copies are asynchronous and ordered before the next launches on the same
stream), used in turn; a buffer is unpacked into the host arrays only when it is reused ``depth`` records
later, or by ``finish()``, so a record never waits for the device, and the host may run up to ``depth``
records ahead of it (2 buffers, or up to 8 while they fit in STAGING_BYTES: a host held up for a few
milliseconds, by another thread or the store's writes, then leaves the device idle less often).
"""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import warp as wp
from hertzian.core.model import Model, State
from hertzian.core.response import ResponseAccumulator
from hertzian.core.spectrum import SpectrumRecorder
from hertzian.kernels.records import (
    PART_SUMS,
    STAGED_GRAINS,
    launch_parts_of_grains,
    launch_record,
    load_record_kernels,
    record_kernels,
    record_part_count,
    record_parts_block_dim,
    traced_start_kernel,
    track_extremes,
)


class StagingPool:
    """Host staging buffers kept between runs, so a sweep's batches reuse them instead of allocating
    (page-locked on CUDA, where allocating and freeing them costs milliseconds per megabyte).

    Buffers are keyed by device and layout; only the most recent layout is kept (a sweep's batches
    share one), so the pool holds at most the buffers of one run beyond the runs in flight.
    """

    def __init__(self):
        self._lock = threading.Lock()
        self._key = None
        self._free: list[dict[str, wp.array]] = []

    def take(self, key, make) -> dict[str, wp.array]:
        """A free buffer of layout ``key``, or ``make()``'s."""
        with self._lock:
            if key == self._key and self._free:
                return self._free.pop()
        return make()

    def give(self, key, buffers: list[dict[str, wp.array]]) -> None:
        """Return buffers of layout ``key`` for the next run (drops those of an older layout)."""
        with self._lock:
            if key != self._key:
                self._key, self._free = key, []
            self._free.extend(buffers)
            del self._free[MAX_STAGING_DEPTH:]


MAP_BLOCKS = 64
"""Blocks along the record (sample) axis in which PageMapping maps the host arrays, first to last."""


def _map_block(arrays: list[np.ndarray], block: int) -> None:
    # block ``block`` of MAP_BLOCKS along axis 1 of every array, written once (numpy releases the GIL while it fills)
    for array in arrays:
        length = array.shape[1]
        array[:, block * length // MAP_BLOCKS : (block + 1) * length // MAP_BLOCKS].fill(0)


_MAPPER = ThreadPoolExecutor(max_workers=1, thread_name_prefix="hertzian-map")
"""Maps the pages of new host result arrays in the background (Recorder)."""


class PageMapping:
    """The pages of a run's new host arrays (records along axis 1: fields (chains, records, grains), traces
    (chains, samples, traced)) mapped by a background thread in MAP_BLOCKS blocks along axis 1, first to last, so
    that an unpack waits only for the blocks it writes into, not for every page (mapped at once, the first record's
    unpack waited for all of a large field's pages while the device ran out of work)."""

    def __init__(self, arrays: list[np.ndarray]):
        self.arrays = arrays
        self.blocks_done = 0
        self._ended = False  # the mapping thread has returned or raised
        self._ready = threading.Condition()
        self._future = _MAPPER.submit(self._map)

    def _map(self) -> None:
        try:
            for block in range(MAP_BLOCKS):
                _map_block(self.arrays, block)
                with self._ready:
                    self.blocks_done = block + 1
                    self._ready.notify_all()
        finally:
            with self._ready:
                self._ended = True
                self._ready.notify_all()

    def wait_for(self, counts: list[int]) -> bool:
        """Wait until the first ``counts[i]`` entries along axis 1 of array i are mapped; True once all are. An error
        of the mapping thread is raised here."""
        need = max(
            (-(-count * MAP_BLOCKS // array.shape[1]) for count, array in zip(counts, self.arrays) if array.shape[1]),
            default=0,
        )
        with self._ready:
            self._ready.wait_for(lambda: self.blocks_done >= need or self._ended)
        if self._ended:
            self._future.result()  # the mapping's error, if any (waits for its future to settle)
        return self.blocks_done == MAP_BLOCKS


STAGING_BYTES = 64 * 2**20
"""Page-locked host memory a run's staging buffers may take beyond two (Recorder.depth)."""
MAX_STAGING_DEPTH = 8

STAGING = StagingPool()
"""The process's staging buffers (hertzian.core.runner returns a run's after its last record)."""


class Recorder:
    """The device reductions and host arrays of one run of ``model``."""

    def __init__(
        self,
        model: Model,
        *,
        trace_values: tuple[str, ...] = ("u", "v"),
        on_unpacked=None,
        map_in_background: bool | None = None,
        traces_on_device: bool = False,
    ):
        if not trace_values or not set(trace_values) <= {"u", "v"}:
            raise ValueError(f"trace_values = {trace_values!r}: one or both of 'u', 'v'")
        self.model = model
        self.on_unpacked = on_unpacked
        """Called as ``on_unpacked(recorder, r)`` once record r is in the host arrays (records come in order;
        a sweep writes them into its store while the run goes on: hertzian.sweeping.sweep_store.RowWriter)."""
        self.trace_values = tuple(name for name in ("u", "v") if name in trace_values)
        """What the traces keep: displacement u, velocity v or both (a detection library keeps v only)."""
        m, scene = model, model.scenes[0]
        c, dev = m.chain_count, m.device
        self.kernels = record_kernels(m.features)
        self.staged = m.grain_count >= STAGED_GRAINS
        """Long chains: each grain's terms in its own thread first (kernels/records.py)."""
        self.grain_terms = wp.empty((c, m.grain_count) if self.staged else (0, 0), dtype=wp.vec4d, device=dev)
        self.parts = wp.zeros((c, record_part_count(m.grain_count), PART_SUMS), dtype=wp.float64, device=dev)
        """Per chain and run of grains: the partial sums of kernels/records.py (device scratch)."""
        self.energy_now = wp.zeros(c, dtype=wp.float64, device=dev)
        self.work_now = wp.zeros(c, dtype=wp.float64, device=dev)
        self.max_overlap_now = wp.zeros(c, dtype=wp.float64, device=dev)
        self.initial_energy = wp.zeros(c, dtype=wp.float64, device=dev)
        self.energy_deviation = wp.zeros(c, dtype=wp.float64, device=dev)
        """Running max over checks of |E − E(0) [− W]| (device)."""
        self.largest_overlap = wp.full(c, -1.0e300, dtype=wp.float64, device=dev)
        """Running max over checks of the largest overlap (device)."""
        damped = m.features.damping != "none"
        self.dissipated_now = wp.zeros(c if damped else 0, dtype=wp.float64, device=dev)
        """Energy dissipated by damping up to the last check, per chain (device; size 0 without damping)."""

        self.real_np = np.float64 if m.features.precision == "float64" else np.float32
        records, n = scene.record_count, m.grain_count
        self.fields = {name: np.zeros((c, records, n), dtype=self.real_np) for name in scene.record.fields}
        self.traced = list(scene.record.traces)
        self.capacity = m.trace_capacity
        self.record_steps = scene.record_steps
        self.stride = scene.trace_stride
        sample_count = scene.trace_sample_count
        self.traces_on_device = traces_on_device and bool(self.traced)
        """The traces stay in the device's ring (with ``traced_start``, their t = 0 values): nothing is copied,
        ``traces`` is empty (a detection library assembles its echoes on the device: kernels/library.py)."""
        self.traces = (
            {name: np.zeros((c, sample_count, len(self.traced)), dtype=self.real_np) for name in self.trace_values}
            if self.traced and not self.traces_on_device
            else {}
        )
        self.trace_t = (np.arange(sample_count) * scene.trace_stride * m.dt) if self.traced else None
        if self.traced and not self.fields:
            self.traced_index = wp.array(np.asarray(self.traced, dtype=np.int32), dtype=wp.int32, device=dev)
            self.traced_start = wp.empty((2, c, len(self.traced)), dtype=m.real, device=dev)
            """The traced grains' u and dt·v at t = 0 (device; copied instead of the whole state)."""
        self.energy = np.zeros((c, records))
        self.work = np.zeros((c, records)) if m.features.surface == "driven" else None
        self.dissipated = np.zeros((c, records)) if damped else None
        self.response = ResponseAccumulator(m) if scene.has_response else None
        self.spectrum = SpectrumRecorder(m) if scene.record.modes else None
        """The mode energies, spectral entropy and participation number (``record.modes``), or None."""

        self.snapshot_values = tuple(
            name for name in ("u", "v") if name in self.fields or (self.fields and name in self.traces)
        )
        """The state rows each record copies: the snapshots' (and, traced, the trace values' at t = 0)."""
        self.staging_key = self._staging_key()
        self.depth = self._staging_depth()
        """Staging buffers, used in turn: how many records the host may run ahead of the device."""
        self.staging = [STAGING.take(self.staging_key, self._staging_buffer) for _ in range(self.depth)]
        self.pending: list[tuple[int, object] | None] = [None] * self.depth
        """Per staging buffer: (record index, CUDA event after its copies) not yet unpacked, or None."""
        self._mapping = None
        if (m.device.is_cuda if map_in_background is None else map_in_background) and (self.fields or self.traces):
            # the host arrays' pages are mapped (written once) by a background thread while the first records run
            # (or, for a detection library's one record after t = 0, while the whole run does): mapping fresh zeroed
            # pages on first write is slow, and with many short chains the first
            # unpack writes into every page (a record is one row of every chain), so it stalled the device between
            # records. They are mapped in blocks along the record axis; an unpack waits for the blocks it writes
            self._mapping = PageMapping([*self.fields.values(), *self.traces.values()])

    def _staging_key(self) -> tuple:
        m = self.model
        return (
            str(m.device),
            m.chain_count,
            m.grain_count,
            m.features.precision,
            self.work is not None,
            self.dissipated is not None,
            self.snapshot_values,
            len(self.traced),
            self.capacity,
            self.trace_values,
        )

    def _staging_depth(self) -> int:
        m = self.model
        item = np.dtype(self.real_np).itemsize
        size = 8 * m.chain_count * (1 + (self.work is not None) + (self.dissipated is not None))
        size += len(self.snapshot_values) * m.chain_count * m.grain_count * item
        if self.traced and not self.traces_on_device:
            size += len(self.trace_values) * m.chain_count * self.capacity * len(self.traced) * item
        return int(min(MAX_STAGING_DEPTH, max(2, 2 + (STAGING_BYTES - 2 * size) // max(size, 1))))

    def release(self) -> None:
        """Hand the staging buffers back to the pool (after :meth:`finish`; the recorder keeps no copy)."""
        if any(p is not None for p in self.pending):
            raise RuntimeError("release() before finish(): records still queued in the staging buffers")
        STAGING.give(self.staging_key, self.staging)
        self.staging = []

    def _staging_buffer(self) -> dict[str, wp.array]:
        m = self.model
        pinned = m.device.is_cuda
        c, n = m.chain_count, m.grain_count

        def host(shape, dtype):
            return wp.empty(shape, dtype=dtype, device="cpu", pinned=pinned)

        buf = {"energy": host(c, wp.float64)}
        if self.work is not None:
            buf["work"] = host(c, wp.float64)
        if self.dissipated is not None:
            buf["dissipated"] = host(c, wp.float64)
        for name in self.snapshot_values:
            buf[name] = host((c, n), m.real)
        if self.traced and not self.fields:  # the traced grains at t = 0 (record 0), gathered on the device
            buf["start"] = host((2, c, len(self.traced)), m.real)
        # the trace ring's copy ("ring", the largest) is allocated at its first use, a record r > 0: a run with
        # one record after t = 0 (a detection library: every chain's whole trace) needs it in one buffer only
        return buf

    def _ring_buffer(self) -> wp.array:
        # page-locked on CUDA: allocated at the first record after t = 0, when the launches before it are queued,
        # so the (slow) allocation overlaps them (allocated in a background thread from the start instead, it held
        # up the first launches by as long: CUDA calls wait for it); a pageable copy of a detection library's traces
        # is many times slower than a page-locked one
        m = self.model
        shape = (len(self.trace_values), m.chain_count, self.capacity, len(self.traced))
        return wp.empty(shape, dtype=m.real, device="cpu", pinned=m.device.is_cuda)

    def _ring_source(self, state: State) -> wp.array:
        """The device ring's halves the traces keep (u is [0], dt·v is [1])."""
        if len(self.trace_values) == 2:
            return state.traces
        index = ("u", "v").index(self.trace_values[0])
        return state.traces[index : index + 1]

    def load(self) -> None:
        """Compile and load the reduction kernels (before a clock starts)."""
        load_record_kernels(self.kernels, long_chains=self.staged, device=self.model.device)
        wp.load_module(track_extremes.module, device=self.model.device)
        if self.traced and not self.fields:
            wp.load_module(traced_start_kernel(self.model.features.precision).module, device=self.model.device)
        if self.response is not None:
            self.response.load()
        if self.spectrum is not None:
            self.spectrum.load()

    def check(self, state: State, step: int) -> None:
        """Energy, work, largest overlap and status of every chain at ``step`` (device only, no sync)."""
        m = self.model
        # what every grain's terms need (record_grains and record_parts)
        terms = [
            state.x,
            m.inverse_mass,
            m.contact_constant,
            m.static_overlap,
            m.law_parameters,
            m.validity_scale,
            m.dt,
        ]
        if self.staged:
            wp.launch(
                self.kernels.grains,
                dim=self.grain_terms.shape,
                inputs=terms,
                outputs=[self.grain_terms],
                device=m.device,
            )
            launch_parts_of_grains(self.kernels, self.grain_terms, state.dissipated, self.parts, m.device)
        else:
            wp.launch(
                self.kernels.parts,
                dim=self.parts.shape[:2],
                block_dim=record_parts_block_dim(m.device),
                inputs=[*terms, state.dissipated],
                outputs=[self.parts],
                device=m.device,
            )
        launch_record(
            self.kernels,
            long_chains=self.staged,
            chains=m.chain_count,
            inputs=[
                state.x,
                m.contact_constant,
                m.static_overlap,
                m.law_parameters,
                m.drive,
                state.work,
                state.power,
                step,
                m.dt,
                m.validity_overlap,
                m.validity_scale,
                self.parts,
            ],
            outputs=[
                self.energy_now,
                self.work_now,
                self.max_overlap_now,
                state.status,
                m.damping,
                self.dissipated_now,
            ],
            device=m.device,
        )
        if step == 0:
            wp.copy(self.initial_energy, self.energy_now)
        wp.launch(
            track_extremes,
            dim=m.chain_count,
            inputs=[
                self.energy_now,
                self.work_now,
                self.initial_energy,
                int(m.features.surface == "driven"),
                self.max_overlap_now,
            ],
            outputs=[self.energy_deviation, self.largest_overlap, self.dissipated_now],
            device=m.device,
        )

    def record(self, state: State, r: int, step: int) -> None:
        """Check at ``step`` and keep record ``r`` (snapshots, energy, work, the traces since record r − 1).

        The device → host copies are queued into staging buffer r % depth (asynchronous on CUDA); the host
        arrays hold record r after ``finish()`` (or once the buffer is reused at record r + depth)."""
        self.check(state, step)
        if self.spectrum is not None:
            self.spectrum.sample(state, r)
        slot = r % self.depth
        if self.pending[slot] is not None:
            self._unpack(slot)
        buf = self.staging[slot]
        wp.copy(buf["energy"], self.energy_now)
        if "work" in buf:
            wp.copy(buf["work"], self.work_now)
        if "dissipated" in buf:
            wp.copy(buf["dissipated"], self.dissipated_now)
        for row, name in enumerate(("u", "v")):
            if name in buf:
                wp.copy(buf[name], state.x[row])
        if r == 0 and "start" in buf:
            wp.launch(
                traced_start_kernel(self.model.features.precision),
                dim=self.traced_start.shape,
                inputs=[state.x, self.traced_index],
                outputs=[self.traced_start],
                device=self.model.device,
            )
            wp.copy(buf["start"], self.traced_start)
        if self.traced and r > 0 and not self.traces_on_device:
            if "ring" not in buf:
                buf["ring"] = self._ring_buffer()
            wp.copy(buf["ring"], self._ring_source(state))
        event = wp.get_stream(self.model.device).record_event() if self.model.device.is_cuda else None
        self.pending[slot] = (r, event)

    def finish(self) -> None:
        """Unpack every queued record into the host arrays (waits for their copies)."""
        for slot in sorted(
            (s for s in range(self.depth) if self.pending[s] is not None), key=lambda s: self.pending[s][0]
        ):
            self._unpack(slot)

    def _unpack(self, slot: int) -> None:
        r, event = self.pending[slot]
        if self._mapping is not None:
            # the rows this unpack writes: record r of the fields; the trace samples up to record r's step
            samples = int(self.record_steps[r]) // self.stride + 1 if self.traced else 0
            counts = [r + 1] * len(self.fields) + [samples] * len(self.traces)
            if self._mapping.wait_for(counts):
                self._mapping = None
        if event is not None:
            wp.synchronize_event(event)
        buf = self.staging[slot]
        dt = self.real_np(self.model.dt)
        if "u" in self.fields:
            self.fields["u"][:, r] = buf["u"].numpy()
        if "v" in self.fields:
            np.divide(buf["v"].numpy(), dt, out=self.fields["v"][:, r])  # in place: no temporary of every grain
        self.energy[:, r] = buf["energy"].numpy()
        if self.work is not None:
            self.work[:, r] = buf["work"].numpy()
        if self.dissipated is not None:
            self.dissipated[:, r] = buf["dissipated"].numpy()
        if self.traced and not self.traces_on_device:
            if r == 0:
                start = buf["start"].numpy() if "start" in buf else None
                if "u" in self.traces:
                    self.traces["u"][:, 0] = start[0] if start is not None else buf["u"].numpy()[:, self.traced]
                if "v" in self.traces:
                    self.traces["v"][:, 0] = (start[1] if start is not None else buf["v"].numpy()[:, self.traced]) / dt
            else:
                # sample k (taken at step k·stride) sits in ring slot k % capacity
                rows = slice(
                    int(self.record_steps[r - 1]) // self.stride + 1, int(self.record_steps[r]) // self.stride + 1
                )
                # the samples sit in consecutive slots from rows.start % capacity, wrapping at most once (a gap
                # holds at most ``capacity`` samples): copied from the ring as one or two views, never gathered
                # (a gathered temporary of a detection library's whole traces is slow to build)
                ring = buf["ring"].numpy()
                first, count = rows.start % self.capacity, rows.stop - rows.start
                head = min(count, self.capacity - first)
                pieces = [(rows.start, ring[:, :, first : first + head])]
                if head < count:
                    pieces.append((rows.start + head, ring[:, :, : count - head]))
                for start, piece in pieces:
                    dest = slice(start, start + piece.shape[2])
                    for half, name in zip(piece, self.trace_values):
                        if name == "u":
                            self.traces["u"][:, dest] = half
                        else:
                            np.divide(half, dt, out=self.traces["v"][:, dest])
        self.pending[slot] = None
        if self.on_unpacked is not None:
            self.on_unpacked(self, r)
