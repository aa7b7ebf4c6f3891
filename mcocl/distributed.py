"""One job on a Dask cluster: chunks of blocks become Dask tasks.

The client (this process) hands out chunks of consecutive blocks from the
same :class:`~mcocl.multidevice.ChunkQueue` the local multi-device scheduler
uses, submits each as a task running :func:`compute_chunk` on a worker, and
folds the returned per-block statistics into the
:class:`~mcocl.accumulate.Accumulator` in block order: the totals are
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
import math
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

from .accumulate import Accumulator
from .errors import DeviceError, InputError, MCOCLError
from .multidevice import MAX_CHUNK_BLOCKS, ChunkQueue, chunk_block_limit
from .schedule import (
    BlockJob,
    DeviceFailureWarning,
    DeviceStats,
    Halting,
    Placement,
    Progress,
    RunReport,
    _Interrupt,
)

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
    stats: np.ndarray | None
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
    from .runtime import device_context

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
        return ChunkResult(first, nblocks, np.asarray(stats), seconds, worker, built.name, build)
    except Exception as e:
        text = str(e).strip().splitlines()
        msg = f"{type(e).__name__}: {text[0][:300] if text else ''}"
        own = e if isinstance(e, MCOCLError) else None
        return ChunkResult(first, nblocks, None, 0.0, worker, _device_name(device), error=msg, exception=own)


def _device_name(device: Any) -> str:
    from .runtime import device_context

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


class _Sizer:
    """Chunk sizes from the measured per-worker throughput (workers assumed alike)."""

    def __init__(self, chunks: ChunkQueue, halting: Halting, chunk_seconds: float, first_chunk: int,
                 max_chunk: int | None, t0: float) -> None:
        self.chunks = chunks
        self.halting = halting
        self.chunk_seconds = chunk_seconds
        self.start = max(int(first_chunk), 1)
        self.max_chunk = max_chunk or MAX_CHUNK_BLOCKS
        self.rate = 0.0  # blocks per compute-second of one worker, smoothed
        self.t0 = t0

    def measure(self, nblocks: int, seconds: float) -> None:
        if seconds > 0:
            sample = nblocks / seconds
            self.rate = sample if self.rate <= 0 else 0.7 * self.rate + 0.3 * sample

    def size(self, workers: int) -> tuple[int, bool]:
        if self.rate <= 0:
            n = self.start
            self.start = min(self.start * 2, MAX_CHUNK_BLOCKS)
        else:
            n = max(1, int(self.rate * self.chunk_seconds))
            if self.chunks.max_blocks is not None:
                # Guided tail: half a worker's share of what is left, but no task
                # under a tenth of the normal one (a task costs a round trip).
                remaining = self.chunks.max_blocks - self.chunks.next_block
                n = min(n, max(max(1, n // 10), -(-remaining // (2 * max(workers, 1)))))
        allow_new = True
        if self.halting.time_budget is not None:
            left = self.halting.time_budget - (time.perf_counter() - self.t0)
            allow_new = left > 0
            if self.rate > 0:
                n = max(1, min(n, int(self.rate * max(left, 0.0)) + 1))
        return min(n, self.max_chunk), allow_new


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
        halting: the stopping rules, as for :func:`mcocl.schedule.run`.
        placement: ``client`` (a ``distributed.Client`` or an address) and
            ``device`` (the device spec each worker resolves for itself).
        progress: called after every fold, with per-worker rates.
        chunk_seconds: compute time of one task on one worker (long enough
            that Dask's per-task cost, a few ms, does not matter).
        first_chunk: blocks of the first tasks (the rate is unknown).
        max_chunk: the largest task in blocks (and at most
            ``multidevice.MAX_CHUNK_BYTES`` of statistics: they travel back).
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
    try:
        return _run(distributed, client, job, acc, halting, placement.device, progress,
                    chunk_seconds, first_chunk, max_chunk, tasks_per_worker)
    finally:
        if owned:
            client.close()


def _run(distributed: Any, client: Any, job: BlockJob, acc: Accumulator, halting: Halting, device: Any,
         progress: Callable[[Progress], None] | None, chunk_seconds: float, first_chunk: int,
         max_chunk: int | None, tasks_per_worker: int) -> RunReport:
    payload = _pickle_job(job)
    fp = job_fingerprint(payload)
    tag = uuid.uuid4().hex[:8]
    t0 = time.perf_counter()
    start_blocks = acc.blocks_done
    chunks = ChunkQueue(start_blocks, halting.max_blocks)
    sizer = _Sizer(chunks, halting, chunk_seconds, first_chunk, chunk_block_limit(job.stat_shape, max_chunk), t0)
    stats: dict[str, DeviceStats] = {}
    bad: dict[str, str] = {}  # worker address -> why it gets no more chunks
    failures: list[str] = []
    errors: list[MCOCLError] = []
    retries: dict[int, int] = {}
    futures: dict[Any, tuple[int, int]] = {}
    ac = distributed.as_completed()
    stopped_by = ""
    last_ckpt = -math.inf  # as schedule.run: the first fold is saved at once, then every checkpoint_every s
    workers_seen = 0.0
    good: list[str] = []

    def refresh_workers(force: bool = False) -> None:
        nonlocal workers_seen, good
        now = time.perf_counter()
        if force or now - workers_seen > 2.0:
            try:
                info = client.scheduler_info(n_workers=-1)  # some versions list 5 workers by default
            except TypeError:
                info = client.scheduler_info()
            good = [w for w in info["workers"] if w not in bad]
            workers_seen = now

    def submit_more() -> None:
        refresh_workers()
        while len(futures) < tasks_per_worker * max(len(good), 1):
            size, allow_new = sizer.size(len(good))
            chunk = chunks.take(size, allow_new, wait=False)
            if chunk is None:
                return
            first, n = chunk
            fut = client.submit(
                compute_chunk, payload, fp, device, first, n,
                key=f"mcocl-chunk-{tag}-{first}-{n}-{uuid.uuid4().hex[:6]}", pure=False,
                workers=good if bad else None, allow_other_workers=False,
            )
            futures[fut] = chunk
            ac.add(fut)

    def no_worker_left() -> MCOCLError:
        if errors and len({type(e) for e in errors}) == 1 and not isinstance(errors[0], DeviceError) \
                and len(errors) == len(failures):
            return errors[0]
        where = f"; the {acc.blocks_done} blocks folded so far are saved in {halting.checkpoint}" \
            if halting.checkpoint else ""
        return DeviceError(f"no Dask worker left to run on{where}: " + "; ".join(failures))

    with _Interrupt() as intr:
        try:
            refresh_workers(force=True)
            if not good:
                raise DeviceError("the Dask cluster has no workers")
            submit_more()
            for fut in ac:
                first, n = futures.pop(fut)
                now = time.perf_counter()
                el = now - t0
                try:
                    res: ChunkResult = fut.result()
                except Exception as e:  # the task itself failed: its workers died repeatedly, or it was lost
                    retries[first] = retries.get(first, 0) + 1
                    msg = f"chunk of blocks {first}..{first + n - 1}: {type(e).__name__}: {e}"
                    warnings.warn(f"Dask task failed ({msg}); retrying", DeviceFailureWarning, stacklevel=2)
                    if retries[first] > MAX_CHUNK_RETRIES:
                        failures.append(msg)
                        raise no_worker_left() from e
                    chunks.give_back(first, n)
                    res = None  # type: ignore[assignment]
                if res is not None and res.error is not None and res.worker in bad:
                    chunks.give_back(first, n)  # more tasks of a worker already known to have failed
                elif res is not None and res.error is not None:
                    label = f"{res.worker} ({res.device})"
                    bad[res.worker] = res.error
                    failures.append(f"{label}: {res.error}")
                    if res.exception is not None:
                        errors.append(res.exception)
                    st = stats.setdefault(res.worker, DeviceStats(label))
                    st.error = res.error
                    refresh_workers(force=True)
                    warnings.warn(
                        f"Dask worker {label} failed ({res.error}); "
                        f"{'its chunks go to the remaining workers' if good else 'no worker is left'}",
                        DeviceFailureWarning, stacklevel=2,
                    )
                    chunks.give_back(first, n)
                    if not good:
                        if halting.checkpoint:
                            acc.save(halting.checkpoint)
                        raise no_worker_left()
                elif res is not None:
                    acc.add(res.first, res.stats)
                    sizer.measure(res.nblocks, res.seconds)
                    st = stats.setdefault(res.worker, DeviceStats(f"{res.worker} ({res.device})"))
                    st.blocks += res.nblocks
                    st.chunks += 1
                    st.busy_seconds += res.seconds
                    st.build_seconds += res.build_seconds
                    if progress is not None:
                        rate = (acc.blocks_done - start_blocks) / el if el > 0 else 0.0
                        rates = tuple((s.name, s.blocks / el if el > 0 else 0.0) for s in stats.values())
                        progress(Progress(acc.blocks_done, halting.max_blocks, el, rate, halting.time_budget, rates))
                    if halting.checkpoint and now - last_ckpt >= halting.checkpoint_every:
                        acc.save(halting.checkpoint)
                        last_ckpt = now
                if not stopped_by:
                    stopped_by = halting.reason(acc, el, intr.flag, folded=res is not None and res.error is None)
                if stopped_by:
                    chunks.close()
                submit_more()
        except BaseException:
            client.cancel(list(futures))
            raise
        finally:
            chunks.finish()
    stopped_by = halting.conclude(acc, stopped_by, intr.flag, chunks.exhausted)
    return RunReport(
        seconds=time.perf_counter() - t0,
        blocks=acc.blocks_done,
        stopped_by=stopped_by,
        devices=[s.name for s in stats.values()],
        chunks=sum(s.chunks for s in stats.values()),
        per_device=list(stats.values()),
        failures=failures,
    )


__all__ = ["ChunkResult", "compute_chunk", "connect", "job_fingerprint", "run_dask"]
