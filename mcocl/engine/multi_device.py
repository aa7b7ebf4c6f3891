"""The multi-device back end: one job on several OpenCL devices (or sub-devices) at once.

A :class:`~mcocl.engine.chunking.ChunkQueue` hands out chunks of consecutive
blocks; one feeder thread per device takes chunks, enqueues them on its
device and collects them, keeping **two launches in flight** so the device
works on the next chunk while Python collects the last one.  Each chunk is
sized for the device that takes it (:class:`~mcocl.engine.chunking.Sizer`).
The calling thread runs the fold loop of :mod:`mcocl.engine.fold` over what
the feeders deliver; the accumulator adds blocks strictly in block order, so
the totals are bit-identical to a one-device run of the same job, whichever
device computed which block (on devices that build the same kernel).

A device that fails (its build, a launch, a copy: out of memory, a lost
device, a compiler that rejects the kernel on this device only) is reported
by name with a :class:`~mcocl.engine.contract.DeviceFailureWarning`; its
chunks go back to the queue, ahead of any new block, and the remaining
devices compute them.  With no device left the run stops with a
:class:`~mcocl.errors.DeviceError` (after saving the checkpoint, if one was
asked for): nothing computed is lost.
"""

from __future__ import annotations

import queue
import threading
import time
import warnings
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..accumulate import Accumulator, RowRanges
from ..errors import DeviceError, MCOCLError
from ..runtime import DeviceContext
from .chunking import ChunkPolicy, ChunkQueue, Sizer
from .contract import (
    BlockJob,
    BlockRunner,
    DeviceFailureWarning,
    DeviceStats,
    Halting,
    InterruptFlag,
    Progress,
    RunReport,
)
from .fold import FinishedChunk, fold_chunks

IN_FLIGHT = 2  # chunks enqueued per device at once: one computing, one waiting behind it


@dataclass
class _Done:
    device: int
    first: int
    stats: np.ndarray | RowRanges


@dataclass
class _Failed:
    device: int
    error: BaseException


class _Feeder(threading.Thread):
    """Keeps one device busy: builds the runner, then enqueue/collect with two chunks in flight."""

    def __init__(self, k: int, ctx: DeviceContext, job: BlockJob, runner: BlockRunner | None, chunks: ChunkQueue,
                 sizer: Sizer, stats: DeviceStats, results: queue.Queue, go: threading.Event) -> None:
        super().__init__(name=f"mcocl-feeder-{k}", daemon=True)
        self.built = threading.Event()  # set once the build succeeded or failed
        self.go = go  # set by the scheduler once every device is built: the clock starts
        self.k = k
        self.ctx = ctx
        self.job = job
        self.runner = runner
        self.chunks = chunks
        self.sizer = sizer
        self.stats = stats
        self.results = results

    def run(self) -> None:
        inflight: deque[tuple[int, int, Any, float]] = deque()
        taken: tuple[int, int] | None = None
        try:
            runner = self.runner
            try:
                if runner is None:
                    t = time.perf_counter()
                    runner = self.job.runner(self.ctx)
                    self.stats.build_seconds = float(getattr(runner, "build_seconds", time.perf_counter() - t))
            finally:
                self.built.set()
            self.go.wait()
            while True:
                while len(inflight) < IN_FLIGHT:
                    size, allow_new = self.sizer.size(self.k, sum(c[1] for c in inflight))
                    taken = self.chunks.take(size, allow_new, wait=not inflight)
                    if taken is None:
                        break
                    handle = runner.enqueue(*taken)
                    inflight.append((taken[0], taken[1], handle, time.perf_counter()))
                    taken = None
                if not inflight:
                    return  # the run is finished
                first, n, handle, enqueued = inflight[0]
                stats = runner.collect(handle)
                inflight.popleft()
                busy = self.sizer.busy_seconds(self.k, enqueued, time.perf_counter())
                self.stats.busy_seconds += busy
                self.stats.blocks += n
                self.stats.chunks += 1
                self.sizer.measure(self.k, n, busy)
                self.results.put(_Done(self.k, first, stats))
        except Exception as e:  # any failure of this device: hand its work back
            if taken is not None:
                self.chunks.give_back(*taken)
            for first, n, _, _ in inflight:
                self.chunks.give_back(first, n)
            self.sizer.drop(self.k)
            self.results.put(_Failed(self.k, e))


def _describe(e: BaseException) -> str:
    text = str(e).strip().splitlines()
    first = text[0] if text else ""
    return f"{type(e).__name__}: {first[:300]}"


class _DevicesStream:
    """The feeders' finished chunks for the fold loop; handles device failures."""

    def __init__(self, job: BlockJob, acc: Accumulator, halting: Halting, contexts: Sequence[DeviceContext],
                 runners: dict[int, BlockRunner], policy: ChunkPolicy) -> None:
        self.acc = acc
        self.halting = halting
        self.chunks = ChunkQueue(acc.blocks_done, halting.max_blocks)
        self.sizer = Sizer(self.chunks, halting, policy, job.stat_shape, takers=len(contexts))
        self.stats = [DeviceStats(c.name) for c in contexts]
        self.results: queue.Queue = queue.Queue()
        self.go = threading.Event()
        self.feeders = [_Feeder(k, c, job, runners.get(k), self.chunks, self.sizer, self.stats[k], self.results,
                                self.go) for k, c in enumerate(contexts)]
        self.alive = len(self.feeders)
        self.errors: list[BaseException] = []
        self.failures: list[str] = []
        self.idle = False  # the last wait for a result timed out

    @property
    def exhausted(self) -> bool:
        return self.chunks.exhausted

    def start(self, interrupt: InterruptFlag) -> float:
        for f in self.feeders:
            f.start()
        # Builds run in parallel, one per feeder; the run's clock (and the
        # time budget) starts when every device is built or has failed.
        for f in self.feeders:
            while not f.built.wait(0.1) and not interrupt.requested:
                pass
        t0 = time.perf_counter()
        self.sizer.start_clock(t0)
        self.go.set()
        return t0

    def next(self, interrupt: InterruptFlag) -> FinishedChunk | None:
        try:
            msg = self.results.get(timeout=0.05)
        except queue.Empty:
            msg = None
        self.idle = msg is None
        if isinstance(msg, _Done):
            return FinishedChunk(msg.first, msg.stats)
        if isinstance(msg, _Failed):
            self.alive -= 1
            st = self.stats[msg.device]
            st.error = _describe(msg.error)
            self.errors.append(msg.error)
            self.failures.append(f"{st.name}: {st.error}")
            warnings.warn(
                f"device {st.name} failed ({st.error}); "
                f"{'its chunks go to the remaining devices' if self.alive else 'no device is left'}",
                DeviceFailureWarning, stacklevel=2,
            )
        return None

    def stop(self) -> None:
        self.chunks.close()

    def done(self) -> bool:
        if self.chunks.drained() and self.acc.blocks_done >= self.chunks.next_block:
            return True  # everything handed out has been folded
        if self.idle and self.chunks.waiting == self.alive > 0 and self.results.empty() and not self.chunks.has_work():
            # Every live feeder waits for work, none is coming back, yet
            # blocks handed out are missing: a scheduler bug, never a hang.
            raise RuntimeError(f"blocks {self.acc.blocks_done}..{self.chunks.next_block - 1} were lost by the scheduler")
        if self.alive == 0:
            self.halting.save_checkpoint(self.acc)
            raise self._no_device_left()
        return False

    def _no_device_left(self) -> MCOCLError:
        # The same engine error on every device (e.g. a kernel every device
        # rejects) is the user's problem, not the devices': raise it as it is.
        errors = self.errors
        if errors and all(isinstance(e, MCOCLError) and not isinstance(e, DeviceError) for e in errors) \
                and len({type(e) for e in errors}) == 1:
            return errors[0]  # type: ignore[return-value]
        checkpoint = self.halting.checkpoint
        where = f"; the {self.acc.blocks_done} blocks folded so far are saved in {checkpoint}" if checkpoint else ""
        lines = "; ".join(f"{s.name}: {s.error}" for s in self.stats)
        return DeviceError(f"no device left to run on (every device failed{where}): {lines}")

    def device_rates(self, elapsed: float) -> tuple[tuple[str, float], ...]:
        return tuple((s.name, s.blocks / elapsed if elapsed > 0 else 0.0) for s in self.stats)

    def close(self, failed: bool) -> None:
        self.chunks.finish()
        self.go.set()
        if not failed:  # on a failure, a feeder may sit in a long collect: do not wait for it
            for f in self.feeders:
                f.join(timeout=5.0)


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
        halting: the stopping rules.
        contexts: the devices (sub-devices count as devices).
        progress: called after every fold; its ``device_rates`` give each
            device's blocks per second.
        runners: runners already built, by index into ``contexts``.
        chunk_seconds: the work one chunk should be for the device taking it.
        first_chunk: blocks in a device's first chunk (its rate is unknown).
        max_chunk: the largest chunk in blocks (tests use it to force many chunks);
            chunks also hold at most ``MAX_CHUNK_BYTES`` of statistics.

    Returns:
        a :class:`~mcocl.engine.contract.RunReport` with ``per_device``
        statistics and ``failures`` naming every device that dropped out.

    Raises:
        DeviceError: every device failed before the job was done.
    """
    if not contexts:
        raise DeviceError("no device to run on")
    notes = []
    kinds = {(c.device.name.strip(), c.device.platform.version.strip(), c.lanes) for c in contexts}
    if len(kinds) > 1:
        # Different compilers or lane widths round differently: each block's
        # statistics still come from one device, but which device computed a
        # block depends on timing, so the sums' last bits may vary run to run.
        notes.append("devices of different kinds: the sums agree statistically with a one-device run, "
                     "but their last bits depend on which device computed which block")
    policy = ChunkPolicy(chunk_seconds=chunk_seconds, first_chunk=first_chunk, max_chunk=max_chunk)
    stream = _DevicesStream(job, acc, halting, contexts, runners or {}, policy)
    out = fold_chunks(stream, acc, halting, progress)
    return RunReport(
        seconds=out.seconds,
        blocks=acc.blocks_done,
        stopped_by=out.stopped_by,
        devices=[c.name for c in contexts],
        chunks=sum(s.chunks for s in stream.stats),
        per_device=stream.stats,
        failures=stream.failures,
        notes=notes,
    )


__all__ = ["run_devices"]
