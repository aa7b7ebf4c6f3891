"""The Dask back end: one job on a Dask cluster, its chunks of blocks as Dask tasks.

The client (this process) hands out chunks of consecutive blocks from a
:class:`~mcocl.engine.chunking.ChunkQueue`, sized by the shared
:class:`~mcocl.engine.chunking.Sizer` (the workers counted as alike), submits
each as a task running :func:`compute_chunk` on a worker, and runs the fold
loop of :mod:`mcocl.engine.fold` over the finished tasks: the totals are
bit-identical to a local run of the same job (on workers whose devices build
the same kernel).

On a worker, :func:`compute_chunk` builds the job's OpenCL context and program
once and caches them, keyed by the job's fingerprint (a hash of its pickled
form) and the device spec; later chunks of the same job only launch.

Failures:

- a worker process that dies mid-job: Dask reruns its unfinished tasks on the
  other workers (or on the worker its nanny restarts); since a block's random
  numbers depend only on (seed, block), the rerun returns the same numbers
  and nothing is lost;
- a worker whose device fails (build, launch, out of memory): the task
  returns the error instead of raising it, so the client knows *which*
  worker failed; that worker gets no more chunks of this job, and its chunk
  goes to the others.  With no usable worker left the run stops with a
  :class:`~mcocl.errors.DeviceError`.

Tasks carry the job by value (its pickled bytes, made once): workers that
join or restart mid-job can always build it, with no scattered data to lose.

Dask is optional: ``pip install "mcocl[dask]"``.
"""

from __future__ import annotations

import hashlib
import pickle
import threading
import time
import uuid
import warnings
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..accumulate import Accumulator, RowRanges
from ..errors import DeviceError, InputError, MCOCLError
from ..runtime import device_context
from .chunking import ChunkPolicy, ChunkQueue, Sizer
from .contract import (
    BlockJob,
    DeviceFailureWarning,
    DeviceStats,
    Halting,
    InterruptFlag,
    Placement,
    Progress,
    RunReport,
)
from .fold import FinishedChunk, fold_chunks

# A chunk that failed for a reason other than its worker's device (the task
# raised, or its workers kept dying) is retried this many times at most.
MAX_CHUNK_RETRIES = 3
# Jobs a worker keeps built; an old job's program and buffers are released.
WORKER_CACHE_JOBS = 4


def job_fingerprint(payload: bytes) -> str:
    """The cache key of a pickled job: its SHA-256."""
    return hashlib.sha256(payload).hexdigest()


# -- worker side -------------------------------------------------------------


@dataclass
class ChunkResult:
    """What :func:`compute_chunk` returns to the client.

    ``error`` is set (and ``stats`` is None) when the worker's device failed;
    ``exception`` then holds the engine's own error (picklable) if it was one.
    """

    first: int
    nblocks: int
    stats: np.ndarray | RowRanges | None
    seconds: float
    worker: str
    device: str
    build_seconds: float = 0.0
    error: str | None = None
    exception: MCOCLError | None = None


class _Built:
    def __init__(self, runner: Any, name: str, build_seconds: float) -> None:
        self.runner = runner
        self.name = name
        self.build_seconds = build_seconds
        self.lock = threading.Lock()
        self.reported = False


_worker_cache: OrderedDict[tuple[str, str], _Built] = OrderedDict()
_worker_cache_lock = threading.Lock()


def _worker_address() -> str:
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):  # not on a Dask worker (a direct call)
        return "local"


def _built(payload: bytes, fingerprint: str, device: Any) -> _Built:
    key = (fingerprint, repr(device))
    with _worker_cache_lock:
        got = _worker_cache.get(key)
        if got is not None:
            _worker_cache.move_to_end(key)
            return got
        # Build under the lock: a worker with several threads builds once.
        t0 = time.perf_counter()
        job = pickle.loads(payload)
        ctx = device_context(device)
        runner = job.runner(ctx)
        got = _Built(runner, ctx.name, float(getattr(runner, "build_seconds", time.perf_counter() - t0)))
        _worker_cache[key] = got
        while len(_worker_cache) > WORKER_CACHE_JOBS:
            _worker_cache.popitem(last=False)
        return got


def compute_chunk(payload: bytes, fingerprint: str, device: Any, first: int, nblocks: int) -> ChunkResult:
    """Compute blocks ``first .. first + nblocks - 1`` of a pickled job (runs on a worker).

    Args:
        payload: the job, pickled (unpickled only when not cached).
        fingerprint: :func:`job_fingerprint` of ``payload``.
        device: the device spec on the worker (None: the worker's default).
        first, nblocks: the chunk.

    Returns:
        a :class:`ChunkResult`; a failure of the device is returned, not
        raised, so that the client learns which worker failed.
    """
    worker = _worker_address()
    try:
        built = _built(payload, fingerprint, device)
        with built.lock:  # a kernel object carries its arguments: one launch at a time
            t0 = time.perf_counter()
            stats = built.runner.collect(built.runner.enqueue(first, nblocks))
            seconds = time.perf_counter() - t0
            build = 0.0 if built.reported else built.build_seconds
            built.reported = True
        stats = stats if isinstance(stats, RowRanges) else np.asarray(stats)  # a sparse film stays sparse
        return ChunkResult(first, nblocks, stats, seconds, worker, built.name, build)
    except Exception as e:
        text = str(e).strip().splitlines()
        msg = f"{type(e).__name__}: {text[0][:300] if text else ''}"
        own = e if isinstance(e, MCOCLError) else None
        return ChunkResult(first, nblocks, None, 0.0, worker, _device_name(device), error=msg, exception=own)


def _device_name(device: Any) -> str:
    try:
        return device_context(device).name
    except Exception:  # the device itself is what failed
        return f"device {device!r}"


# -- client side -------------------------------------------------------------


def _distributed() -> Any:
    try:
        import distributed
    except ImportError:
        raise InputError(
            "client= / --dask needs the Dask extra: pip install \"mcocl[dask]\" (dask[distributed])"
        ) from None
    return distributed


def connect(client: Any) -> tuple[Any, bool]:
    """A ``distributed.Client`` for ``client`` (a client, or a scheduler address).

    Returns:
        ``(client, owned)``; ``owned`` is True when it was made here and
        must be closed by the caller.

    Raises:
        DeviceError: the scheduler cannot be reached.
    """
    distributed = _distributed()
    if isinstance(client, distributed.Client):
        return client, False
    if not isinstance(client, str) or not client.strip():
        raise InputError(f"client must be a dask.distributed.Client or a scheduler address, got {client!r}")
    try:
        return distributed.Client(client.strip(), timeout="15s"), True
    except (OSError, TimeoutError) as e:
        raise DeviceError(f"cannot reach the Dask scheduler at {client.strip()!r}: {e}") from None


def _pickle_job(job: BlockJob) -> bytes:
    # cloudpickle (a dependency of distributed) also ships classes defined in
    # a script or registered for pickling by value; its output loads with
    # plain pickle on the worker.
    try:
        import cloudpickle
    except ImportError:
        return pickle.dumps(job, protocol=pickle.HIGHEST_PROTOCOL)
    return cloudpickle.dumps(job, protocol=pickle.HIGHEST_PROTOCOL)


class _TaskStream:
    """Finished Dask tasks for the fold loop; keeps tasks submitted and handles failed workers."""

    def __init__(self, distributed: Any, client: Any, job: BlockJob, acc: Accumulator, halting: Halting,
                 device: Any, policy: ChunkPolicy, tasks_per_worker: int) -> None:
        self.client = client
        self.acc = acc
        self.halting = halting
        self.device = device
        self.tasks_per_worker = tasks_per_worker
        self.payload = _pickle_job(job)
        self.fingerprint = job_fingerprint(self.payload)
        self.tag = uuid.uuid4().hex[:8]
        self.chunks = ChunkQueue(acc.blocks_done, halting.max_blocks)
        # The workers are taken as alike: one pooled rate, its share split among them.
        self.sizer = Sizer(self.chunks, halting, policy, job.stat_shape, takers=1)
        self.stats: dict[str, DeviceStats] = {}
        self.bad: dict[str, str] = {}  # worker address -> why it gets no more chunks
        self.failures: list[str] = []
        self.errors: list[MCOCLError] = []
        self.retries: dict[int, int] = {}
        self.futures: dict[Any, tuple[int, int]] = {}
        self.completed = distributed.as_completed()
        self.workers_seen = 0.0
        self.good: list[str] = []
        self.finished = False

    @property
    def exhausted(self) -> bool:
        return self.chunks.exhausted

    def _refresh_workers(self, force: bool = False) -> None:
        now = time.perf_counter()
        if force or now - self.workers_seen > 2.0:
            try:
                info = self.client.scheduler_info(n_workers=-1)  # some versions list 5 workers by default
            except TypeError:
                info = self.client.scheduler_info()
            self.good = [w for w in info["workers"] if w not in self.bad]
            self.workers_seen = now

    def _submit_more(self) -> None:
        self._refresh_workers()
        while len(self.futures) < self.tasks_per_worker * max(len(self.good), 1):
            size, allow_new = self.sizer.size(0, alike=len(self.good))
            chunk = self.chunks.take(size, allow_new, wait=False)
            if chunk is None:
                return
            first, n = chunk
            fut = self.client.submit(
                compute_chunk, self.payload, self.fingerprint, self.device, first, n,
                key=f"mcocl-chunk-{self.tag}-{first}-{n}-{uuid.uuid4().hex[:6]}", pure=False,
                workers=self.good if self.bad else None, allow_other_workers=False,
            )
            self.futures[fut] = chunk
            self.completed.add(fut)

    def _no_worker_left(self) -> MCOCLError:
        self.halting.save_checkpoint(self.acc)
        errors = self.errors
        if errors and len({type(e) for e in errors}) == 1 and not isinstance(errors[0], DeviceError) \
                and len(errors) == len(self.failures):
            return errors[0]
        checkpoint = self.halting.checkpoint
        where = f"; the {self.acc.blocks_done} blocks folded so far are saved in {checkpoint}" if checkpoint else ""
        return DeviceError(f"no Dask worker left to run on{where}: " + "; ".join(self.failures))

    def start(self, interrupt: InterruptFlag) -> float:
        t0 = time.perf_counter()
        self.sizer.start_clock(t0)
        self._refresh_workers(force=True)
        if not self.good:
            raise DeviceError("the Dask cluster has no workers")
        return t0

    def next(self, interrupt: InterruptFlag) -> FinishedChunk | None:
        self._submit_more()
        if not self.futures:
            self.finished = True
            return None
        fut = next(self.completed)
        first, n = self.futures.pop(fut)
        try:
            res: ChunkResult = fut.result()
        except Exception as e:  # the task itself failed: its workers died repeatedly, or it was lost
            self.retries[first] = self.retries.get(first, 0) + 1
            msg = f"chunk of blocks {first}..{first + n - 1}: {type(e).__name__}: {e}"
            warnings.warn(f"Dask task failed ({msg}); retrying", DeviceFailureWarning, stacklevel=2)
            if self.retries[first] > MAX_CHUNK_RETRIES:
                self.failures.append(msg)
                raise self._no_worker_left() from e
            self.chunks.give_back(first, n)
            return None
        if res.error is not None:
            self._worker_failed(res, first, n)
            return None
        self.sizer.measure(0, res.nblocks, res.seconds)
        st = self.stats.setdefault(res.worker, DeviceStats(f"{res.worker} ({res.device})"))
        st.blocks += res.nblocks
        st.chunks += 1
        st.busy_seconds += res.seconds
        st.build_seconds += res.build_seconds
        return FinishedChunk(res.first, res.stats)

    def _worker_failed(self, res: ChunkResult, first: int, n: int) -> None:
        self.chunks.give_back(first, n)
        if res.worker in self.bad:
            return  # more tasks of a worker already known to have failed
        label = f"{res.worker} ({res.device})"
        self.bad[res.worker] = res.error or ""
        self.failures.append(f"{label}: {res.error}")
        if res.exception is not None:
            self.errors.append(res.exception)
        st = self.stats.setdefault(res.worker, DeviceStats(label))
        st.error = res.error
        self._refresh_workers(force=True)
        warnings.warn(
            f"Dask worker {label} failed ({res.error}); "
            f"{'its chunks go to the remaining workers' if self.good else 'no worker is left'}",
            DeviceFailureWarning, stacklevel=2,
        )
        if not self.good:
            raise self._no_worker_left()

    def stop(self) -> None:
        self.chunks.close()

    def done(self) -> bool:
        return self.finished

    def device_rates(self, elapsed: float) -> tuple[tuple[str, float], ...]:
        return tuple((s.name, s.blocks / elapsed if elapsed > 0 else 0.0) for s in self.stats.values())

    def close(self, failed: bool) -> None:
        if failed:
            self.client.cancel(list(self.futures))
        self.chunks.finish()


def run_dask(
    job: BlockJob,
    acc: Accumulator,
    halting: Halting,
    placement: Placement,
    progress: Callable[[Progress], None] | None = None,
    chunk_seconds: float = 1.0,
    first_chunk: int = 1,
    max_chunk: int | None = None,
    tasks_per_worker: int = 2,
) -> RunReport:
    """Compute blocks from ``acc.blocks_done`` on as Dask tasks on ``placement.client``.

    Args:
        job: a picklable job (workers import its class: mcocl must be
            installed on them).
        acc: the accumulator, folded here in block order.
        halting: the stopping rules.
        placement: ``client`` (a ``distributed.Client`` or an address) and
            ``device`` (the device spec each worker resolves for itself).
        progress: called after every fold, with per-worker rates.
        chunk_seconds: compute time of one task on one worker (long enough
            that Dask's per-task cost, a few ms, does not matter).
        first_chunk: blocks of the first tasks (the rate is unknown).
        max_chunk: the largest task in blocks (and at most
            ``MAX_CHUNK_BYTES`` of statistics: they travel back).
        tasks_per_worker: tasks kept submitted per worker, so a worker has
            the next task before it finishes the current one.

    Raises:
        InputError: ``devices``/``split`` given with a client, or Dask missing.
        DeviceError: no usable worker is left, or a chunk keeps failing.
    """
    if placement.devices is not None or placement.split:
        raise InputError(
            "with client= (Dask) each worker runs on one device (device= picks it on every worker); "
            "devices= and split= apply to local runs only: start one Dask worker per device instead"
        )
    distributed = _distributed()
    client, owned = connect(placement.client)
    # A task costs a round trip: a longer chunk, no tail chunk under a tenth
    # of the normal one, and a rate smoothed over more tasks than a device's.
    policy = ChunkPolicy(chunk_seconds=chunk_seconds, first_chunk=first_chunk, max_chunk=max_chunk,
                         tail_floor=10, new_weight=0.3)
    try:
        stream = _TaskStream(distributed, client, job, acc, halting, placement.device, policy, tasks_per_worker)
        out = fold_chunks(stream, acc, halting, progress)
    finally:
        if owned:
            client.close()
    stats = list(stream.stats.values())
    return RunReport(
        seconds=out.seconds,
        blocks=acc.blocks_done,
        stopped_by=out.stopped_by,
        devices=[s.name for s in stats],
        chunks=sum(s.chunks for s in stats),
        per_device=stats,
        failures=stream.failures,
    )


__all__ = ["ChunkResult", "compute_chunk", "connect", "job_fingerprint", "run_dask"]
