"""The one-device back end: a job's blocks through one device, in the calling thread.

Two chunks are kept in flight (double buffering), so the device never waits
for Python to fold, report progress or decide to stop: while the device
computes chunk k+1, the loop of :mod:`mcocl.engine.fold` folds chunk k.
Chunk sizes come from :mod:`mcocl.engine.chunking`.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

import pyopencl as cl

from ..accumulate import Accumulator
from ..runtime import DeviceContext
from .chunking import ChunkPolicy, ChunkQueue, Sizer
from .contract import BlockJob, BlockRunner, DeviceStats, Halting, InterruptFlag, Progress, RunReport
from .fold import FinishedChunk, fold_chunks

IN_FLIGHT = 2  # chunks enqueued at once: one computing, one waiting behind it
# Seconds between looks at the interrupt flag while a launch is in flight.  Waiting in OpenCL's
# clWaitForEvents would hold the main thread in C, where Python runs no signal handler: a Ctrl-C during
# a long launch (a sobol batch of 10^6 spp is tens of seconds: mcocl/render/sobol_film.py) could then
# not even be seen, let alone a second one that abandons the launch (issue 10).  So the main thread
# waits on a threading.Event that the launch's completion callback sets, POLL_SECONDS at a time: it
# wakes as soon as the launch ends (sleeping between looks at the event's status cost a short render
# up to a poll interval per chunk: 1-6 ms of a 45 ms render of caustic.json), and at least every
# POLL_SECONDS to look at the flag.  The next chunk is queued behind the one waited for, so the device
# does not idle meanwhile.
POLL_SECONDS = 0.01
# Launches abandoned by an urgent stop (with their runner), kept until the process ends: pyopencl's
# event of a non-blocking copy waits for the copy when it is released (the host array must outlive
# it), so dropping them would block the stopped run until the launch ends after all.
ABANDONED: list[Any] = []


def wait_unless_urgent(handle: Any, interrupt: InterruptFlag) -> bool:
    """Wait until the OpenCL events of a launch ``handle`` (a runner's tuple) are complete; False within
    :data:`POLL_SECONDS` when ``interrupt`` turns urgent first (the launch is abandoned).  A failed event
    counts as complete: ``collect`` then raises its error."""
    events = [h for h in handle if isinstance(h, cl.Event)] if isinstance(handle, tuple) else []
    if events:
        events[0].command_queue.flush()  # a queued launch that was never flushed would not start
    complete = cl.command_execution_status.COMPLETE
    for ev in events:
        if ev.command_execution_status <= complete:
            continue
        done = threading.Event()
        # called by the OpenCL runtime on its own thread, at once for an event already complete or failed
        ev.set_callback(complete, lambda status, done=done: done.set())
        while not done.wait(POLL_SECONDS):
            if interrupt.urgent:
                return False
    return True


class _DeviceStream:
    """One device's chunks for the fold loop: launched here, collected in order."""

    def __init__(self, runner: BlockRunner, chunks: ChunkQueue, sizer: Sizer) -> None:
        self.runner = runner
        self.chunks = chunks
        self.sizer = sizer
        self.inflight: deque[tuple[int, int, Any, float]] = deque()
        self.inflight_blocks = 0
        self.launched = 0
        self.finished = False

    @property
    def exhausted(self) -> bool:
        return self.chunks.exhausted

    def start(self, interrupt: InterruptFlag) -> float:
        t0 = time.perf_counter()
        self.sizer.start_clock(t0)
        return t0

    def next(self, interrupt: InterruptFlag) -> FinishedChunk | None:
        while len(self.inflight) < IN_FLIGHT and not interrupt.requested:
            size, allow_new = self.sizer.size(0, self.inflight_blocks)
            taken = self.chunks.take(size, allow_new, wait=False)
            if taken is None:
                break
            handle = self.runner.enqueue(*taken)
            self.inflight.append((taken[0], taken[1], handle, time.perf_counter()))
            self.inflight_blocks += taken[1]
            self.launched += 1
        if not self.inflight:
            self.finished = True
            return None
        if not wait_unless_urgent(self.inflight[0][2], interrupt):
            return None  # asked twice to stop: the fold loop keeps what is folded (mcocl/engine/fold.py)
        first, n, handle, enqueued = self.inflight.popleft()
        self.inflight_blocks -= n
        stats = self.runner.collect(handle)
        self.sizer.measure(0, n, self.sizer.busy_seconds(0, enqueued, time.perf_counter()))
        return FinishedChunk(first, stats)

    def stop(self) -> None:
        self.chunks.close()

    def done(self) -> bool:
        return self.finished

    def device_rates(self, elapsed: float) -> tuple[tuple[str, float], ...]:
        return ()  # one device: the overall rate says it all

    def close(self, failed: bool) -> None:
        if failed and self.inflight:
            # the runner too: releasing its program and buffers under a running launch crashes PoCL
            ABANDONED.append((self.runner, tuple(self.inflight)))
            self.inflight.clear()
        self.chunks.finish()


def run_one_device(
    job: BlockJob,
    acc: Accumulator,
    halting: Halting,
    ctx: DeviceContext,
    progress: Callable[[Progress], None] | None = None,
    chunk_seconds: float = 0.15,
    first_chunk: int = 1,
    runner: BlockRunner | None = None,
) -> RunReport:
    """Compute blocks from ``acc.blocks_done`` on, on ``ctx``, until ``halting`` says stop.

    Args:
        job: the job; its runner is built for ``ctx``.
        acc: the accumulator to fold into (may hold a resumed state).
        halting: the stopping rules.
        ctx: the device.
        progress: called after every fold.
        chunk_seconds: wall time one chunk should take once the rate is known.
        first_chunk: blocks in the first chunk (small, to measure the rate).
        runner: an already built runner of ``job`` on ``ctx`` (else built here).

    Returns:
        a :class:`~mcocl.engine.contract.RunReport`; the statistics are in ``acc``.
    """
    if runner is None:
        runner = job.runner(ctx)
    chunks = ChunkQueue(acc.blocks_done, halting.max_blocks)
    sizer = Sizer(chunks, halting, ChunkPolicy(chunk_seconds=chunk_seconds, first_chunk=first_chunk), job.stat_shape)
    stream = _DeviceStream(runner, chunks, sizer)
    out = fold_chunks(stream, acc, halting, progress)
    return RunReport(
        seconds=out.seconds,
        blocks=acc.blocks_done,
        stopped_by=out.stopped_by,
        devices=[ctx.name],
        chunks=stream.launched,
        per_device=[DeviceStats(ctx.name, acc.blocks_done - out.start_blocks, stream.launched, out.seconds,
                                float(getattr(runner, "build_seconds", 0.0)))],
    )


__all__ = ["POLL_SECONDS", "run_one_device", "wait_unless_urgent"]
