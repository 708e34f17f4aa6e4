"""Running a sweep's batches: in this process, or on Dask distributed workers (one device each).

Each batch runs as one ensemble (``build_model`` with its launch group's kernel variant, then
``Runner``) and writes its own block of the store, then its completion record. Workers share
nothing but the store path, so a batch can run on any worker, on any host that sees the store,
and a batch whose worker dies is run again elsewhere (it rewrites the same shards with the same bits).

``--workers N`` starts N worker processes the way dask-cuda's ``LocalCUDACluster`` does, without it
(:func:`worker_specs`): one ``Nanny`` per GPU, named 0 … N-1, one thread each, the host's memory
split evenly between them, except that worker i sees only GPU i (``CUDA_VISIBLE_DEVICES``), as
its ``cuda:0``. A worker imports the package and initialises Warp when it starts (:func:`dask_setup`,
its preload), while the host plans and creates the store.

Device of a worker: ``cpu`` or an explicit ``cuda:N`` when one is named; otherwise (``cuda`` or
none) ``cuda:0`` where ``CUDA_VISIBLE_DEVICES`` is set in the worker (a worker of :func:`start_cluster`,
of dask-cuda, or one started by hand with ``CUDA_VISIBLE_DEVICES=i dask worker --nworkers 1 …``),
``cuda:i`` for the worker named i of a plain ``LocalCluster``, or the CPU when it has no GPU.
"""

from __future__ import annotations

import logging
import os
import sys
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hertzian.core.chains import ChainSet
from hertzian.kernels.features import Features
from hertzian.sweeping.planner import Batch, Plan, plan_sweep
from hertzian.sweeping.spec import SweepPoints, expand, load_sweep


@dataclass(frozen=True)
class BatchJob:
    """Everything a worker needs to run one batch and write it."""

    store: str
    batch: Batch
    chains: ChainSet
    """The batch's chains (a template scene and per-chain parameter arrays), in the order of
    ``batch.points``."""
    features: Features
    """Kernel variant of the batch's launch group."""
    grain_steps: int
    kernel: str = "auto"
    """Which solver steps the batch (``--kernel``: auto | step | tile | window | sweep)."""


def jobs_for(
    store: str | Path, plan: Plan, points: SweepPoints, batches: Iterable[Batch], *, kernel: str = "auto"
) -> list[BatchJob]:
    """One job per batch (``points``: the sweep expanded by ``hertzian.sweeping.spec.expand``)."""
    return [
        BatchJob(
            store=str(store),
            batch=b,
            chains=points.chains(b.points),
            features=plan.groups[b.group].features,
            grain_steps=plan.batch_grain_steps(b),
            kernel=kernel,
        )
        for b in batches
    ]


def _quiet_warp():
    import warp as wp

    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    return wp


def warm_kernels(features: Iterable[Features], device: str, *, runs: Iterable[tuple] | None = None) -> None:
    """Build and load every kernel variant on ``device`` once, so workers find them in Warp's cache.

    ``runs``: (features, grains, chains, steps) of the batches this process will run (a serial sweep); then the
    stepping kernel warmed is the one each will use (hertzian.core.solvers.compile.prepare_kernels); without them,
    the record kernels of each feature set (and on a CPU its chain kernel)."""
    from hertzian.core.solvers.prepare import Need, prepare_kernels

    _quiet_warp()
    prepare_kernels(list(features) if runs is None else [Need(*run) for run in set(runs)], device)


def runs_of(plan, points, batches) -> list[tuple]:
    """(features, grains, chains, steps) of each distinct launch group and batch size among ``batches``
    (:func:`warm_kernels`' ``runs``)."""
    out, seen = [], set()
    for batch in batches:
        if (batch.group, batch.size) in seen:
            continue
        seen.add((batch.group, batch.size))
        scene = points.scene(int(batch.points[0])) if hasattr(points, "scene") else points[int(batch.points[0])]
        out.append((plan.groups[batch.group].features, scene.chain.grains, batch.size, scene.step_count))
    return out


def run_job(
    job: BatchJob, device: str, progress: Callable[[int, int], None] | None = None, *, worker: str = ""
) -> dict[str, Any]:
    """Run one batch on ``device`` and write it into the store; return its completion record."""
    return write_job(job, *integrate_job(job, device, progress), worker=worker)


def prepare_job(job: BatchJob):
    """The host half of a batch's build (``hertzian.core.model.prepare_model``): numpy only, so a
    background thread can compute the next batch's while the current one runs."""
    from hertzian.core.model import prepare_model

    if not isinstance(job.chains, ChainSet):
        return None  # a batch spanning templates runs as one scene per point: nothing to prepare
    return prepare_model(job.chains, features=job.features)


def integrate_job(
    job: BatchJob, device: str, progress: Callable[[int, int], None] | None = None, *, prepared=None, on_unpacked=None
):
    """Build and run one batch on ``device``; returns (RunResult, build seconds). Writes nothing itself.

    ``prepared``: :func:`prepare_job` of this job, computed earlier (the build seconds are then what
    remained: uploads, state buffers, solver and recorder). ``on_unpacked``: the recorder's hook (a
    ``RowWriter.submit``, which writes records while the batch runs)."""
    from hertzian.core.model import build_model
    from hertzian.core.runner import Runner

    _quiet_warp()
    start = time.perf_counter()
    runner = Runner(
        build_model(job.chains, device, features=job.features, prepared=prepared),
        kernel=job.kernel,
        on_unpacked=on_unpacked,
    )
    build = time.perf_counter() - start
    return runner.run(progress), build


def overlap_default(device: str) -> bool:
    """Whether a serial sweep prepares batch b + 1 on the host while batch b runs: on CUDA (the host is
    otherwise idle while the GPU integrates), not on a CPU (whose kernels use every core)."""
    wp = _quiet_warp()
    return wp.get_device(device).is_cuda


def write_job(job: BatchJob, result, build: float, *, worker: str = "", rows=None) -> dict[str, Any]:
    """Write a finished batch into the store (its completion flag last); returns its completion record.
    ``rows``: the batch's RowWriter (what it wrote while the batch ran is not written again)."""
    from hertzian.sweeping.sweep_store import write_batch

    return write_batch(
        job.store, job.batch, result, grain_steps=job.grain_steps, worker=worker, build_seconds=build, rows=rows
    )


def worker_device(requested: str | None, worker_name: Any = None) -> str:
    """The device a (Dask worker) process should use; see the module docstring."""
    wp = _quiet_warp()
    if requested and requested != "cuda":
        return requested
    if not wp.is_cuda_available():
        return "cpu"
    if os.environ.get("CUDA_VISIBLE_DEVICES"):
        return "cuda:0"  # its own GPU, alone or first (LocalCUDACluster's convention)
    try:
        index = int(worker_name)
    except (ValueError, TypeError):
        index = 0
    return f"cuda:{index % wp.get_cuda_device_count()}"


def dask_setup(worker=None) -> None:
    """A worker's preload (``Nanny(preload=["hertzian.sweeping.distributed"])``): the package's imports and
    Warp's initialisation (the CUDA driver) are paid when the worker starts, not in its first batch."""
    from hertzian.core import runner  # noqa: F401
    from hertzian.sweeping import sweep_store  # noqa: F401

    _quiet_warp()


def dask_teardown(worker=None) -> None:
    """The preload's last step in a worker process a nanny started, as the worker closes: the process ends here,
    without the rest of Dask's close and the interpreter's teardown of every module and of Warp's runtime, so
    closing a cluster does not wait for them. Every batch is written before its task returns; a worker closed
    mid-batch ends as a killed one does, which the store survives (the batch runs again). A worker in the client's
    own process is left to close as usual."""
    import multiprocessing

    if worker is None or not getattr(worker, "nanny", None) or multiprocessing.parent_process() is None:
        return
    for stream in (sys.stdout, sys.stderr):
        stream.flush()
    os._exit(0)


def run_job_on_worker(job: BatchJob, requested_device: str | None) -> dict[str, Any]:
    """Dask task: run one batch on this worker's device (its first batch loads the kernels, from Warp's cache)."""
    from distributed import get_worker

    worker = get_worker()
    try:
        return run_job(job, worker_device(requested_device, worker.name), worker=str(worker.name))
    except Exception as err:  # the client learns which batch failed where, in one line
        raise BatchFailedError(job.batch.index, str(worker.name), error_line(err)) from None


class BatchFailedError(RuntimeError):
    """A batch that failed on a worker (an error in the batch, or its workers died more often than Dask's
    ``allowed-failures``). ``str()`` is one line: the batch, the worker and the error."""

    def __init__(self, batch: int, worker: str, error: str, hint: str = ""):
        super().__init__(batch, worker, error, hint)
        self.batch, self.worker, self.error, self.hint = batch, worker, error, hint

    def __str__(self) -> str:
        return f"batch {self.batch} failed on worker {self.worker}: {self.error}" + (
            f"; {self.hint}" if self.hint else ""
        )


def error_line(err: BaseException) -> str:
    """``Type: message`` of an exception, on one line."""
    text = " ".join(str(err).split())
    return f"{type(err).__name__}: {text}" if text else type(err).__name__


def take_prepared(ahead, builder, jobs, index: int, timing: dict):
    """The host arrays prepared ahead for ``jobs[index]`` (None when batches are not overlapped) and the future
    now preparing the next job; ``timing`` gains the preparation's seconds ("prepare") and the wait for it
    ("prepare_wait")."""
    if ahead is None:
        return None, None
    clock = time.perf_counter()
    prepared = ahead.result()
    timing["prepare_wait"] += time.perf_counter() - clock
    timing["prepare"] += prepared.seconds if prepared is not None else 0.0
    return prepared, (builder.submit(prepare_job, jobs[index + 1]) if index + 1 < len(jobs) else None)


def run_serial(
    jobs: list[BatchJob],
    device: str,
    *,
    on_record: Callable[[BatchJob, int, int], None] | None = None,
    on_done: Callable[[BatchJob, dict], None] | None = None,
    overlap: bool | None = None,
    rows_while_running: bool | None = None,
    on_result: Callable | None = None,
    create_store: Callable[[], Any] | None = None,
    timing: dict | None = None,
) -> None:
    """Run jobs one after the other in this process; each batch's store write runs in a background thread
    while the next batch integrates (writes stay in batch order; ``on_done`` follows each write).

    ``overlap`` (default :func:`overlap_default`): a second background thread prepares batch b + 1's
    host arrays (:func:`prepare_job`) while batch b runs; same results, bit for bit.
    ``rows_while_running`` (default: as ``overlap``): the store thread also writes each batch's records (and
    trace samples) as they reach the host (sweep_store.RowWriter), so the batch's own end leaves only its last
    records to write; the same store, bit for bit. ``on_result(job, result, build_seconds)`` is called on this
    thread after each batch's integration. ``create_store``: a call that creates the store, run by the store
    thread once the first batch's first records are queued on the device (so it overlaps the integration; every
    write comes after it). ``timing``, if given, gets ``prepare`` (host seconds of those preparations,
    overlapped), ``prepare_wait`` (the part the main thread waited for), ``store`` (seconds of the store
    thread's writes) and, with ``create_store``, ``create_store`` (its seconds, overlapped)."""
    from concurrent.futures import ThreadPoolExecutor

    from hertzian.sweeping.sweep_store import RowWriter

    overlap = overlap_default(device) if overlap is None else overlap
    rows_while_running = overlap if rows_while_running is None else rows_while_running
    timing = {} if timing is None else timing
    for key in ("prepare", "prepare_wait", "store"):
        timing.setdefault(key, 0.0)

    def timed_write(job, result, build, rows):
        clock = time.perf_counter()
        record = write_job(job, result, build, rows=rows)
        timing["store"] += time.perf_counter() - clock + (rows.seconds if rows is not None else 0.0)
        return record

    def timed_create():
        clock = time.perf_counter()
        create_store()
        timing["create_store"] = time.perf_counter() - clock

    with (
        ThreadPoolExecutor(max_workers=1, thread_name_prefix="hertzian-store") as writer,
        ThreadPoolExecutor(max_workers=1, thread_name_prefix="hertzian-build") as builder,
    ):
        pending = None
        creating = [None] if create_store is not None else []
        ahead = builder.submit(prepare_job, jobs[0]) if overlap and jobs else None

        def created() -> None:
            """Queue the store's creation (once), ahead of any write."""
            if creating and creating[0] is None:
                creating[0] = writer.submit(timed_create)

        def settle():
            job, future = pending
            if creating:
                creating[0].result()  # a failed creation raises its own error, not the writes' after it
            record = future.result()
            if on_done:
                on_done(job, record)

        for index, job in enumerate(jobs):
            prepared, ahead = take_prepared(ahead, builder, jobs, index, timing)

            def progress(done, total, job=job):
                if done >= 2:  # record 1 is queued behind the first launches: the device is busy
                    created()
                if on_record:
                    on_record(job, done, total)

            rows = RowWriter(job.store, job.batch, writer) if rows_while_running else None

            def on_unpacked(recorder, r, rows=rows):
                created()
                rows.submit(recorder, r)

            result, build = integrate_job(
                job,
                device,
                progress if (on_record or creating) else None,
                prepared=prepared,
                on_unpacked=on_unpacked if rows is not None else None,
            )
            if on_result is not None:
                on_result(job, result, build)
            created()
            if pending is not None:
                settle()
            pending = (job, writer.submit(timed_write, job, result, build, rows))
        created()
        if pending is not None:
            settle()
        if creating:
            creating[0].result()


def visible_gpus() -> list[str]:
    """The GPUs this process may hand out to workers: ``CUDA_VISIBLE_DEVICES`` (its entries) when set, else
    every CUDA device Warp sees (by index); none without CUDA."""
    wp = _quiet_warp()
    if not wp.is_cuda_available():
        return []
    listed = os.environ.get("CUDA_VISIBLE_DEVICES")
    if listed:
        return [d.strip() for d in listed.split(",") if d.strip()]
    return [str(i) for i in range(wp.get_cuda_device_count())]


def cuda_visible_devices(index: int, gpus: list[str]) -> str:
    """``CUDA_VISIBLE_DEVICES`` of worker ``index``: its own GPU ``gpus[index % len(gpus)]`` only, its ``cuda:0``.
    (dask-cuda lists every GPU, its own first, for peer access between workers; these workers share nothing on
    the device, and a process that sees one GPU initialises its driver faster than one that sees all.)"""
    return gpus[index % len(gpus)]


LOOPBACK = "127.0.0.1"
"""The only address a local cluster (:func:`local_cluster`) listens on."""


def worker_specs(workers: int, gpus: list[str], *, memory_limit: int | None = None) -> dict[int, dict]:
    """``SpecCluster`` worker specs of ``workers`` Nanny processes named 0 … workers-1: one thread each, host
    memory split evenly (``memory_limit`` bytes each; default: the host's memory / workers), the package
    preloaded (:func:`dask_setup`), and with ``gpus`` each only its own in ``CUDA_VISIBLE_DEVICES``."""
    from distributed import Nanny
    from distributed.system import MEMORY_LIMIT

    limit = memory_limit if memory_limit is not None else MEMORY_LIMIT // workers
    specs = {}
    for index in range(workers):
        options = {
            "nthreads": 1,
            "name": index,
            "host": LOOPBACK,  # the nanny, its worker and the worker's HTTP server: this host only
            "memory_limit": limit,
            "preload": [__name__],
            "silence_logs": logging.ERROR,
        }
        if gpus:
            options["env"] = {"CUDA_VISIBLE_DEVICES": cuda_visible_devices(index, gpus)}
        specs[index] = {"cls": Nanny, "options": options}
    return specs


def local_cluster(workers: int, gpus: list[str] | None = None):
    """A local cluster of ``workers`` worker processes (:func:`worker_specs`; ``gpus`` as :func:`visible_gpus`
    when None) and its scheduler, no dashboard. Returns once every worker has started."""
    from distributed import Scheduler, SpecCluster

    gpus = visible_gpus() if gpus is None else gpus
    # the scheduler and its HTTP server (which Dask starts even with the dashboard off) on loopback only: a
    # listener on every interface would let any host on the network run code in the workers
    options = {"host": LOOPBACK, "dashboard_address": f"{LOOPBACK}:0", "dashboard": False}
    scheduler = {"cls": Scheduler, "options": options}
    return SpecCluster(
        workers=worker_specs(workers, gpus), scheduler=scheduler, silence_logs=logging.ERROR, name="hertzian"
    )


class ClusterError(ValueError):
    """A cluster that cannot be reached (one line: the address and why)."""


@dataclass(frozen=True)
class TlsFiles:
    """PEM files of a TLS connection to a scheduler (``--tls-ca-file``, ``--tls-cert``, ``--tls-key``): the
    certificate authority that signed the cluster's certificates, and this client's certificate and key."""

    ca_file: str
    cert: str
    key: str | None = None
    """The client's key; None when it is appended to ``cert``."""


def client_security(scheduler: str, tls: TlsFiles | None):
    """The ``distributed.security.Security`` of a client of ``scheduler``: None for ``tcp://`` (refused with
    ``tls``); for ``tls://``, from ``tls`` or else from the Dask config (``distributed.comm.tls.ca-file``,
    ``.client.cert``, ``.client.key``). Raises :class:`ClusterError` (one line) when TLS has no certificates."""
    from distributed.security import Security

    if not scheduler.startswith("tls://"):
        if tls is not None:
            raise ClusterError(f"TLS files were given but {scheduler} is not a tls:// address")
        return None
    if tls is not None:
        for name, value in (("tls_ca_file", tls.ca_file), ("tls_cert", tls.cert), ("tls_key", tls.key)):
            if value is not None and not Path(value).is_file():
                raise ClusterError(f"{name} = {value!r}: no such file")
        return Security(
            tls_ca_file=tls.ca_file, tls_client_cert=tls.cert, tls_client_key=tls.key, require_encryption=True
        )
    security = Security()
    if not (security.tls_ca_file and security.tls_client_cert):
        raise ClusterError(
            "a tls:// scheduler needs certificates: --tls-ca-file and --tls-cert (and --tls-key), or "
            "distributed.comm.tls.ca-file and distributed.comm.tls.client.cert in the Dask config"
        )
    return security


class ClusterStart:
    """The workers of a sweep: a local cluster starting in a background thread (``workers``), or an existing
    one reached at ``scheduler``. ``worker_count`` is known at once; :meth:`client` waits for the start. The
    client is never the process's default Dask scheduler: the sweep submits to it by name, and a computation of
    the caller's (an xarray ``load`` of a store, say) must not be sent to workers that the sweep then closes."""

    def __init__(
        self,
        workers: int | None = None,
        scheduler: str | None = None,
        *,
        gpus: list[str] | None = None,
        tls: TlsFiles | None = None,
    ):
        from concurrent.futures import ThreadPoolExecutor

        self._client = self._cluster = None
        self._starting = None
        if scheduler is not None:
            from distributed import Client

            security = client_security(scheduler, tls)
            try:
                self._client = Client(scheduler, timeout="15s", security=security, set_as_default=False)
            except Exception as err:  # noqa: BLE001 (a peer that is not a Dask scheduler may fail the handshake anyhow)
                raise ClusterError(f"cannot connect ({type(err).__name__}: {err})") from None
            self.worker_count = max(1, len(self._client.scheduler_info(n_workers=-1)["workers"]))
            return
        self.worker_count = int(workers)
        gpus = visible_gpus() if gpus is None else gpus  # here: Warp's initialisation is not thread-safe
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="hertzian-cluster")
        self._starting = self._pool.submit(local_cluster, self.worker_count, gpus)

    def client(self):
        """The Dask client (waits for a local cluster's workers)."""
        if self._client is None:
            from distributed import Client

            self._cluster = self._starting.result()
            self._client = Client(self._cluster, set_as_default=False)
        return self._client

    def close(self) -> None:
        """Close the client, and the local cluster this started (waiting for its start if need be)."""
        if self._client is not None:
            self._client.close()
        if self._starting is not None:
            try:
                cluster = self._starting.result()
            except Exception:  # a failed start has nothing to close
                cluster = None
            if cluster is not None:
                cluster.close()
            self._pool.shutdown()
            self._starting = None


def run_distributed(
    jobs: list[BatchJob],
    client,
    requested_device: str | None,
    *,
    on_done: Callable[[BatchJob, dict], None] | None = None,
    priorities: dict[int, int] | None = None,
) -> None:
    """Run jobs on a Dask client's workers, all submitted at once; each worker writes its batches into the store.

    ``priorities``: batch index → scheduler priority (higher first; default: grid order). A batch whose worker
    dies is run again on another (Dask's ``allowed-failures``, 3 by default); one whose worker died after it was
    written (its completion flag set) counts as done, though Dask reports its result lost. A batch that fails
    anyway does not stop the others: once every batch has ended, the failure of the lowest batch index raises
    :class:`BatchFailedError` (one line, with the count of the others that failed); the store holds every batch
    that completed."""
    from distributed import as_completed

    token = f"{time.time_ns():x}"
    futures = {
        client.submit(
            run_job_on_worker,
            job,
            requested_device,
            pure=False,
            key=f"hertzian-batch-{job.batch.index}-{token}",
            priority=priorities[job.batch.index] if priorities else -job.batch.index,
        ): job
        for job in jobs
    }
    failed = []
    for future in as_completed(futures, loop=client.loop):  # the client is not the default (ClusterStart)
        job = futures[future]
        if future.status == "error":
            err = future.exception()
            if not isinstance(err, BatchFailedError) and written(job):
                # written, then its worker died holding the small result: Dask lost the result, not the batch
                if on_done:
                    on_done(job, {"result_lost_with_worker": True})
                continue
            failed.append(batch_failure(job, err))
            continue
        record = future.result()
        if on_done:
            on_done(job, record)
    if failed:
        first = min(failed, key=lambda f: f.batch)
        more = f" ({len(failed) - 1} more batches failed)" if len(failed) > 1 else ""
        raise BatchFailedError(first.batch, first.worker, first.error + more)


def written(job: BatchJob) -> bool:
    """Whether ``job``'s batch has its completion flag set in the store (the flag is set after every chunk)."""
    from hertzian.sweeping.sweep_store import completed_batches

    return job.batch.index in completed_batches(job.store)


def batch_failure(job: BatchJob, err: BaseException) -> BatchFailedError:
    """The one-line failure of ``job``'s task: its worker's :class:`BatchFailedError`, or Dask's ``KilledWorker``
    (every worker that ran it died) named by the last worker."""
    if isinstance(err, BatchFailedError):
        return err
    last = getattr(err, "last_worker", None)  # KilledWorker: the scheduler's state of the last worker
    if last is None:
        return BatchFailedError(job.batch.index, "?", error_line(err))
    name = getattr(last, "name", None)
    worker = str(name if name is not None else getattr(last, "address", "?"))
    tries = getattr(err, "allowed_failures", 0) + 1
    return BatchFailedError(job.batch.index, worker, f"KilledWorker: its worker died on each of {tries} attempts")


def sweep_needs(path: Path, overrides: dict[str, Any], device: str, kernel: str = "auto") -> list:
    """Every launch group and batch size of the sweep file ``path`` (with ``overrides``) on ``device``."""
    from hertzian.core.solvers.prepare import Need  # Warp and the kernels load only where kernels are prepared

    points = expand(load_sweep(path, overrides))
    plan = plan_sweep(load_sweep(path, overrides), points, device)
    return [Need(*run, kernel) for run in dict.fromkeys(runs_of(plan, points, plan.batches))]
