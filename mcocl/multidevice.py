"""One job on several OpenCL devices at once.

The work is the sequence of a job's blocks.  A :class:`ChunkQueue` hands out
chunks of consecutive blocks; one feeder thread per device takes chunks,
enqueues them on its device and collects them, keeping **two launches in
flight** so the device works on the next chunk while Python collects the last
one.  The main thread folds the partial results into the
:class:`~mcocl.accumulate.Accumulator`, which adds blocks strictly in block
order: the totals are bit-identical to a one-device run of the same job,
whichever device computed which block (on devices that build the same kernel).

Chunk sizes follow each device's measured throughput (blocks per second of
busy time, smoothed): a chunk is about ``chunk_seconds`` of work *for the
device that takes it*, so a fast GPU takes big chunks and a slow CPU small
ones and both come back at the same pace.  Near the end of a bounded job a
device takes at most half of its share of the remaining blocks (guided
self-scheduling, Polychronopoulos & Kuck 1987), so all devices finish within
a fraction of a chunk of each other.

A device that fails (its build, a launch, a copy: out of memory, a lost
device, a compiler that rejects the kernel on this device only) is reported
by name with a :class:`~mcocl.schedule.DeviceFailureWarning`; its chunks go
back to the queue, ahead of any new block, and the remaining devices compute
them.  With no device left the run stops with a :class:`~mcocl.errors.DeviceError`
(after saving the checkpoint, if one was asked for): nothing computed is lost.
"""

from __future__ import annotations

import heapq
import math
import queue
import threading
import time
import warnings
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .accumulate import Accumulator
from .errors import DeviceError, MCOCLError
from .runtime import DeviceContext
from .schedule import (
    BlockJob,
    BlockRunner,
    DeviceFailureWarning,
    DeviceStats,
    Halting,
    Progress,
    RunReport,
    _Interrupt,
)

MAX_CHUNK_BLOCKS = 1 << 20
# A chunk's statistics (float64, one array per block) stay under this size: a
# render's block is a whole film, and a chunk of them must not fill the memory.
MAX_CHUNK_BYTES = 256 << 20


def chunk_block_limit(stat_shape: tuple[int, ...], max_chunk: int | None = None) -> int:
    """The most blocks one chunk may hold: ``max_chunk``, and at most ``MAX_CHUNK_BYTES`` of statistics."""
    per_block = 8 * max(int(np.prod(stat_shape)), 1)
    return max(1, min(max_chunk or MAX_CHUNK_BLOCKS, MAX_CHUNK_BLOCKS, MAX_CHUNK_BYTES // per_block))


class ChunkQueue:
    """Chunks of consecutive blocks, handed out in block order (thread-safe).

    Blocks given back by a failed device are handed out first, split to the
    taker's chunk size, so the gap they leave in the accumulator closes as
    soon as possible.

    Args:
        start: the first block to hand out.
        max_blocks: one past the last block (``None``: unbounded).
    """

    def __init__(self, start: int, max_blocks: int | None) -> None:
        self.next_block = int(start)
        self.max_blocks = max_blocks
        self._returned: list[tuple[int, int]] = []
        self._cond = threading.Condition()
        self._closed = False
        self._finished = False
        self.waiting = 0  # takers blocked in take(wait=True)

    @property
    def exhausted(self) -> bool:
        """True when every block of a bounded job has been handed out."""
        return self.max_blocks is not None and self.next_block >= self.max_blocks

    def drained(self) -> bool:
        """True when no block will be handed out any more (unless a device fails)."""
        with self._cond:
            return not self._returned and (self._closed or self.exhausted)

    def has_work(self) -> bool:
        """True when a waiting taker would get something (given-back or new blocks)."""
        with self._cond:
            return bool(self._returned) or not (self._closed or self.exhausted)

    def take(self, size: int, allow_new: bool, wait: bool) -> tuple[int, int] | None:
        """The next chunk ``(first_block, nblocks)`` of at most ``size`` blocks.

        Args:
            size: the taker's chunk size (at least 1 is used).
            allow_new: whether new blocks may be handed out (False near the
                end of a time budget: only given-back blocks then).
            wait: block until a chunk is available or the run is finished;
                otherwise return None at once when there is none.

        Returns:
            a chunk, or None (nothing now, or the run is finished).
        """
        size = max(int(size), 1)
        with self._cond:
            while True:
                if self._finished:
                    return None
                if self._returned:
                    first, n = heapq.heappop(self._returned)
                    if n > size:
                        heapq.heappush(self._returned, (first + size, n - size))
                        n = size
                    return first, n
                if allow_new and not self._closed and not self.exhausted:
                    n = size if self.max_blocks is None else min(size, self.max_blocks - self.next_block)
                    first = self.next_block
                    self.next_block += n
                    return first, n
                if not wait:
                    return None
                self.waiting += 1
                try:
                    self._cond.wait()
                finally:
                    self.waiting -= 1

    def give_back(self, first: int, nblocks: int) -> None:
        """Return a chunk that a failed device will not deliver."""
        with self._cond:
            heapq.heappush(self._returned, (int(first), int(nblocks)))
            self._cond.notify_all()

    def close(self) -> None:
        """Hand out no new blocks (given-back blocks still go out)."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()

    def finish(self) -> None:
        """End the run: every waiting taker gets None."""
        with self._cond:
            self._finished = True
            self._cond.notify_all()


@dataclass
class _Done:
    device: int
    first: int
    stats: np.ndarray


@dataclass
class _Failed:
    device: int
    error: BaseException


class _DeviceState:
    """What the scheduler knows of one device; written by its feeder thread."""

    def __init__(self, name: str, first_chunk: int) -> None:
        self.stats = DeviceStats(name)
        self.rate = 0.0  # blocks per busy second, smoothed
        self.start_size = max(int(first_chunk), 1)
        self.last_done = 0.0
        self.alive = True


class _Sizer:
    """Chunk sizes from the measured throughput of each device."""

    def __init__(self, states: list[_DeviceState], chunks: ChunkQueue, halting: Halting,
                 chunk_seconds: float, max_chunk: int | None, t0: float) -> None:
        self.states = states
        self.chunks = chunks
        self.halting = halting
        self.chunk_seconds = chunk_seconds
        self.max_chunk = max_chunk or MAX_CHUNK_BLOCKS
        self.t0 = t0

    def size(self, k: int, inflight: int) -> tuple[int, bool]:
        """(chunk size, whether new blocks may be taken) for device ``k`` with ``inflight`` blocks in flight."""
        st = self.states[k]
        if st.rate <= 0:
            # Throughput not measured yet: small chunks, doubling, as in schedule.run.
            n = st.start_size
            st.start_size = min(st.start_size * 2, MAX_CHUNK_BLOCKS)
        else:
            n = max(1, int(st.rate * self.chunk_seconds))
            total = sum(s.rate for s in self.states if s.alive and s.rate > 0)
            if self.chunks.max_blocks is not None and total > 0:
                remaining = self.chunks.max_blocks - self.chunks.next_block
                # Guided self-scheduling: half of this device's share of what is
                # left, but no chunk under 1/8 of the normal one (tiny chunks at
                # the end cost launches and gain nothing).
                floor = max(1, n // 8)
                n = min(n, max(floor, math.ceil(remaining * st.rate / total / 2)))
        allow_new = True
        budget = self.halting.time_budget
        if budget is not None:
            left = budget - (time.perf_counter() - self.t0)
            allow_new = left > 0
            if st.rate > 0:
                left -= inflight / st.rate  # the blocks already in flight take this long
                n = max(1, min(n, int(st.rate * max(left, 0.0)) + 1))
        return min(n, self.max_chunk), allow_new


class _Feeder(threading.Thread):
    """Keeps one device busy: builds the runner, then enqueue/collect with two chunks in flight."""

    def __init__(self, k: int, ctx: DeviceContext, job: BlockJob, runner: BlockRunner | None,
                 chunks: ChunkQueue, sizer: _Sizer, results: queue.Queue, go: threading.Event) -> None:
        super().__init__(name=f"mcocl-feeder-{k}", daemon=True)
        self.built = threading.Event()  # set once the build succeeded or failed
        self.go = go  # set by the scheduler once every device is built: the clock starts
        self.k = k
        self.ctx = ctx
        self.job = job
        self.runner = runner
        self.chunks = chunks
        self.sizer = sizer
        self.results = results
        self.state = sizer.states[k]

    def run(self) -> None:
        inflight: deque[tuple[int, int, Any, float]] = deque()
        taken: tuple[int, int] | None = None
        try:
            runner = self.runner
            try:
                if runner is None:
                    t = time.perf_counter()
                    runner = self.job.runner(self.ctx)
                    self.state.stats.build_seconds = float(getattr(runner, "build_seconds", time.perf_counter() - t))
            finally:
                self.built.set()
            self.go.wait()
            while True:
                while len(inflight) < 2:
                    size, allow_new = self.sizer.size(self.k, sum(c[1] for c in inflight))
                    taken = self.chunks.take(size, allow_new, wait=not inflight)
                    if taken is None:
                        break
                    handle = runner.enqueue(*taken)
                    inflight.append((taken[0], taken[1], handle, time.perf_counter()))
                    taken = None
                if not inflight:
                    return  # the run is finished
                first, n, handle, t_enq = inflight[0]
                stats = runner.collect(handle)
                inflight.popleft()
                self._measure(n, t_enq)
                self.results.put(_Done(self.k, first, stats))
        except Exception as e:  # any failure of this device: hand its work back
            if taken is not None:
                self.chunks.give_back(*taken)
            for first, n, _, _ in inflight:
                self.chunks.give_back(first, n)
            self.state.alive = False
            self.results.put(_Failed(self.k, e))

    def _measure(self, n: int, t_enq: float) -> None:
        st = self.state
        now = time.perf_counter()
        # The device started this chunk when it was enqueued or when the one
        # before it finished, whichever was later (in-order queue).
        busy = now - max(t_enq, st.last_done)
        st.last_done = now
        st.stats.busy_seconds += busy
        st.stats.blocks += n
        st.stats.chunks += 1
        if busy > 0:
            sample = n / busy
            st.rate = sample if st.rate <= 0 else 0.5 * st.rate + 0.5 * sample


def _describe(e: BaseException) -> str:
    text = str(e).strip().splitlines()
    first = text[0] if text else ""
    return f"{type(e).__name__}: {first[:300]}"


def _no_device_left(states: list[_DeviceState], errors: list[BaseException], acc: Accumulator,
                    checkpoint: str | None) -> MCOCLError:
    # The same engine error on every device (e.g. a kernel every device
    # rejects) is the user's problem, not the devices': raise it as it is.
    if errors and all(isinstance(e, MCOCLError) and not isinstance(e, DeviceError) for e in errors) \
            and len({type(e) for e in errors}) == 1:
        return errors[0]  # type: ignore[return-value]
    where = f"; the {acc.blocks_done} blocks folded so far are saved in {checkpoint}" if checkpoint else ""
    lines = "; ".join(f"{s.stats.name}: {s.stats.error}" for s in states)
    return DeviceError(f"no device left to run on (every device failed{where}): {lines}")


def run_devices(
    job: BlockJob,
    acc: Accumulator,
    halting: Halting,
    contexts: Sequence[DeviceContext],
    progress: Callable[[Progress], None] | None = None,
    runners: dict[int, BlockRunner] | None = None,
    chunk_seconds: float = 0.15,
    first_chunk: int = 1,
    max_chunk: int | None = None,
) -> RunReport:
    """Compute blocks from ``acc.blocks_done`` on, on every device of ``contexts``.

    Args:
        job: the job; a runner is built for each device in its feeder thread.
        acc: the accumulator (may hold a resumed state); folded in the
            calling thread only.
        halting: the stopping rules, as for :func:`mcocl.schedule.run`.
        contexts: the devices (sub-devices count as devices).
        progress: called after every fold; its ``device_rates`` give each
            device's blocks per second.
        runners: runners already built, by index into ``contexts``.
        chunk_seconds: the work one chunk should be for the device taking it.
        first_chunk: blocks in a device's first chunk (its rate is unknown).
        max_chunk: the largest chunk in blocks (tests use it to force many chunks);
            chunks also hold at most ``MAX_CHUNK_BYTES`` of statistics.

    Returns:
        a :class:`~mcocl.schedule.RunReport` with ``per_device`` statistics
        and ``failures`` naming every device that dropped out.

    Raises:
        DeviceError: every device failed before the job was done.
    """
    if not contexts:
        raise DeviceError("no device to run on")
    runners = runners or {}
    notes = []
    kinds = {(c.device.name.strip(), c.device.platform.version.strip(), c.lanes) for c in contexts}
    if len(kinds) > 1:
        # Different compilers or lane widths round differently: each block's
        # statistics still come from one device, but which device computed a
        # block depends on timing, so the sums' last bits may vary run to run.
        notes.append("devices of different kinds: the sums agree statistically with a one-device run, "
                     "but their last bits depend on which device computed which block")
    start_blocks = acc.blocks_done
    chunks = ChunkQueue(start_blocks, halting.max_blocks)
    states = [_DeviceState(c.name, first_chunk) for c in contexts]
    sizer = _Sizer(states, chunks, halting, chunk_seconds, chunk_block_limit(job.stat_shape, max_chunk),
                   time.perf_counter())
    results: queue.Queue = queue.Queue()
    go = threading.Event()
    feeders = [_Feeder(k, c, job, runners.get(k), chunks, sizer, results, go) for k, c in enumerate(contexts)]
    alive = len(feeders)
    errors: list[BaseException] = []
    failures: list[str] = []
    stopped_by = ""
    t0 = time.perf_counter()
    last_ckpt = -math.inf  # as schedule.run: the first fold is saved at once, then every checkpoint_every s
    with _Interrupt() as intr:
        try:
            for f in feeders:
                f.start()
            # Builds run in parallel, one per feeder; the run's clock (and the
            # time budget) starts when every device is built or has failed.
            for f in feeders:
                while not f.built.wait(0.1) and not intr.flag:
                    pass
            t0 = sizer.t0 = time.perf_counter()
            go.set()
            while True:
                try:
                    msg = results.get(timeout=0.05)
                except queue.Empty:
                    msg = None
                now = time.perf_counter()
                el = now - t0
                if isinstance(msg, _Done):
                    acc.add(msg.first, msg.stats)
                    if progress is not None:
                        rate = (acc.blocks_done - start_blocks) / el if el > 0 else 0.0
                        rates = tuple((s.stats.name, s.stats.blocks / el if el > 0 else 0.0) for s in states)
                        progress(Progress(acc.blocks_done, halting.max_blocks, el, rate, halting.time_budget, rates))
                    if halting.checkpoint and now - last_ckpt >= halting.checkpoint_every:
                        acc.save(halting.checkpoint)
                        last_ckpt = now
                elif isinstance(msg, _Failed):
                    alive -= 1
                    st = states[msg.device]
                    st.stats.error = _describe(msg.error)
                    errors.append(msg.error)
                    failures.append(f"{st.stats.name}: {st.stats.error}")
                    warnings.warn(
                        f"device {st.stats.name} failed ({st.stats.error}); "
                        f"{'its chunks go to the remaining devices' if alive else 'no device is left'}",
                        DeviceFailureWarning, stacklevel=2,
                    )
                if not stopped_by:
                    stopped_by = halting.reason(acc, el, intr.flag, folded=isinstance(msg, _Done))
                if stopped_by:
                    chunks.close()
                if chunks.drained() and acc.blocks_done >= chunks.next_block:
                    break  # everything handed out has been folded
                if msg is None and chunks.waiting == alive > 0 and results.empty() and not chunks.has_work():
                    # Every live feeder waits for work, none is coming back, yet
                    # blocks handed out are missing: a scheduler bug, never a hang.
                    raise RuntimeError(f"blocks {acc.blocks_done}..{chunks.next_block - 1} were lost by the scheduler")
                if alive == 0:
                    if halting.checkpoint:
                        acc.save(halting.checkpoint)
                    raise _no_device_left(states, errors, acc, halting.checkpoint)
        finally:
            chunks.finish()
            go.set()
    for f in feeders:
        f.join(timeout=5.0)
    stopped_by = halting.conclude(acc, stopped_by, intr.flag, chunks.exhausted)
    return RunReport(
        seconds=time.perf_counter() - t0,
        blocks=acc.blocks_done,
        stopped_by=stopped_by,
        devices=[c.name for c in contexts],
        chunks=sum(s.stats.chunks for s in states),
        per_device=[s.stats for s in states],
        failures=failures,
        notes=notes,
    )


__all__ = ["ChunkQueue", "run_devices"]
