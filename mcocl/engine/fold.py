"""The one fold loop: finished chunks into the accumulator, progress, checkpoints, halting.

Every back end produces finished chunks in its own way (one device's queue,
feeder threads, Dask futures) and exposes them as a :class:`ChunkStream`;
:func:`fold_chunks` is the loop they all run, in the calling thread:

1. take the next finished chunk from the stream (the stream launches what
   it may first);
2. fold it into the :class:`~mcocl.accumulate.Accumulator`, which adds
   blocks strictly in block order, so the totals are bit-identical whichever
   device computed which block and however the blocks were chunked;
3. report :class:`~mcocl.engine.contract.Progress`;
4. save a checkpoint after the first fold and then every
   ``checkpoint_every`` seconds;
5. ask :class:`~mcocl.engine.contract.Halting` whether to stop; once it says
   so, the stream hands out no new block but every block in flight is still
   folded: nothing computed is dropped;
6. end when the stream has nothing left; save the final checkpoint.

Ctrl-C and SIGTERM are caught for the length of the loop (:class:`~mcocl.engine.contract.InterruptFlag`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from .. import heartbeat
from ..accumulate import Accumulator, RowRanges
from .contract import Halting, InterruptFlag, Progress


@dataclass
class FinishedChunk:
    """The statistics of blocks ``first .. first + len(stats) - 1``, ready to fold."""

    first: int
    stats: np.ndarray | RowRanges


class ChunkStream(Protocol):
    """A back end's finished chunks, as :func:`fold_chunks` consumes them."""

    @property
    def exhausted(self) -> bool:
        """True when every block of a bounded job was handed out."""

    def start(self, interrupt: InterruptFlag) -> float:
        """Get ready (builds, workers); return when the run's clock starts (``time.perf_counter``).

        ``interrupt`` is the run's Ctrl-C flag: a long start should give up
        waiting once it is set.
        """

    def next(self, interrupt: InterruptFlag) -> FinishedChunk | None:
        """Launch what may be launched, then the next finished chunk.

        Returns None when no chunk came (a failure was handled, a wait timed
        out, or nothing is left to run).  May raise when the run cannot go
        on (no device left).
        """

    def stop(self) -> None:
        """Hand out no new block (a halting rule fired); blocks in flight still come back."""

    def done(self) -> bool:
        """True when every block handed out has come back and been folded."""

    def device_rates(self, elapsed: float) -> tuple[tuple[str, float], ...]:
        """(device name, blocks per second of wall time) per device, for progress reports."""

    def close(self, failed: bool) -> None:
        """End the run (always called); ``failed`` when the loop is leaving on an exception."""


@dataclass
class FoldOutcome:
    """How a :func:`fold_chunks` loop ended.

    Attributes:
        stopped_by: ``blocks``, ``time``, ``target`` or ``interrupt``.
        seconds: wall time from the start of the run's clock to the end.
        start_blocks: the blocks folded before this run (a resumed state).
    """

    stopped_by: str
    seconds: float
    start_blocks: int


def fold_chunks(
    stream: ChunkStream,
    acc: Accumulator,
    halting: Halting,
    progress: Callable[[Progress], None] | None = None,
) -> FoldOutcome:
    """Fold ``stream``'s finished chunks into ``acc`` until it is done (see the module's docstring).

    Args:
        stream: the back end's chunks.
        acc: the accumulator (may hold a resumed state); folded here only.
        halting: the stopping rules and the checkpoint.
        progress: called after every fold.

    Returns:
        why and when the run ended; the statistics are in ``acc``.
    """
    start_blocks = acc.blocks_done
    stopped_by = ""
    last_ckpt = -math.inf  # the first fold is saved at once, then every checkpoint_every seconds
    with InterruptFlag() as interrupt:
        try:
            t0 = stream.start(interrupt)
            heartbeat.beat("start")
            while True:
                chunk = stream.next(interrupt)
                now = time.perf_counter()
                elapsed = now - t0
                if chunk is not None:
                    acc.add(chunk.first, chunk.stats)
                    if progress is not None:
                        rate = (acc.blocks_done - start_blocks) / elapsed if elapsed > 0 else 0.0
                        progress(Progress(acc.blocks_done, halting.max_blocks, elapsed, rate, halting.time_budget,
                                          stream.device_rates(elapsed)))
                    if halting.checkpoint and now - last_ckpt >= halting.checkpoint_every:
                        acc.save(halting.checkpoint)
                        last_ckpt = now
                    heartbeat.beat("fold")
                if interrupt.urgent:  # asked twice: keep what is folded, abandon the blocks in flight
                    stopped_by = "interrupt"
                    break
                if not stopped_by:
                    stopped_by = halting.reason(acc, elapsed, interrupt.requested, folded=chunk is not None)
                if stopped_by:
                    stream.stop()
                if stream.done():
                    break
        except BaseException:
            stream.close(failed=True)
            raise
        stream.close(failed=interrupt.urgent)
    heartbeat.beat("stop")
    stopped_by = halting.conclude(acc, stopped_by, interrupt.requested, stream.exhausted)
    return FoldOutcome(stopped_by, time.perf_counter() - t0, start_blocks)


__all__ = ["ChunkStream", "FinishedChunk", "FoldOutcome", "fold_chunks"]
