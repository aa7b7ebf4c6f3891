"""The one chunking policy: which blocks go out next, and how many at a time.

Every back end hands blocks out in *chunks* of consecutive blocks.  This
module owns

- :class:`ChunkQueue`: the blocks still to compute, handed out in block order
  (blocks given back by a failed device first);
- :class:`ChunkPolicy` and :class:`Sizer`: how big a chunk is, from the
  measured throughput of whoever takes it;
- :func:`chunk_block_limit`: the most blocks one chunk may hold.

The policy, in order:

1. A taker whose throughput is not measured yet gets ``first_chunk`` blocks,
   doubling with every chunk it takes, so a slow device is found out early
   and a fast one soon gets big chunks.
2. Once measured, a chunk is about ``chunk_seconds`` of work *for the taker*
   (blocks per busy second, smoothed): a fast GPU takes big chunks and a slow
   CPU small ones, and both come back at the same pace.
3. Near the end of a bounded job that several takers share, a taker takes at
   most half of its share of the blocks left (guided self-scheduling,
   Polychronopoulos & Kuck 1987), but no chunk under ``1/tail_floor`` of its
   normal size (tiny chunks cost launches and gain nothing), so all takers
   finish within a fraction of a chunk of each other.
4. Under a time budget a chunk ends about when the budget does (the blocks
   already in flight count), and no new block is handed out once it is spent.
5. A chunk holds at most ``max_chunk`` blocks and ``MAX_CHUNK_BYTES`` of
   statistics.

Chunk sizes never change a result: the accumulator folds block by block in
block order, whatever the chunks were.
"""

from __future__ import annotations

import heapq
import math
import threading
import time
from dataclasses import dataclass

import numpy as np

from .contract import Halting

MAX_CHUNK_BLOCKS = 1 << 20
# A chunk's statistics (float64, one array per block) stay under this size: a
# render's block is a whole film, and a chunk of them must not fill the memory
# (nor, on Dask, the network).
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


@dataclass(frozen=True)
class ChunkPolicy:
    """The knobs of the chunking policy (see the module's docstring).

    Attributes:
        chunk_seconds: the work one chunk should be for the taker, once its
            throughput is known.
        first_chunk: blocks in a taker's first chunk (its throughput unknown).
        max_chunk: the largest chunk in blocks (tests use it to force many
            chunks); chunks also hold at most ``MAX_CHUNK_BYTES`` of statistics.
        tail_floor: near the end, no chunk under ``1/tail_floor`` of the normal one.
        new_weight: the weight of a new throughput measurement in the smoothed rate.
    """

    chunk_seconds: float = 0.15
    first_chunk: int = 1
    max_chunk: int | None = None
    tail_floor: int = 8
    new_weight: float = 0.5


class Taker:
    """One device, or a pool of alike Dask workers, as the sizer sees it.

    Written by the thread that feeds the device, read by every thread that
    sizes a chunk (plain floats: a stale value only sizes one chunk a little off).

    Attributes:
        rate: blocks per busy second, smoothed (0: not measured yet).
        start_size: the size of its next chunk while ``rate`` is unknown.
        last_done: when its last chunk came back (``time.perf_counter``).
        alive: False once it failed: it takes no share of the blocks left.
    """

    def __init__(self, first_chunk: int) -> None:
        self.rate = 0.0
        self.start_size = max(int(first_chunk), 1)
        self.last_done = 0.0
        self.alive = True


class Sizer:
    """Chunk sizes for every taker of one run, by the policy of this module.

    Args:
        chunks: the run's queue (its position and end give the blocks left).
        halting: the run's stopping rules (the time budget shortens chunks).
        policy: the knobs.
        stat_shape: one block's statistics (limits the blocks of a chunk).
        takers: how many takers (devices, or 1 for a pool of Dask workers).
    """

    def __init__(self, chunks: ChunkQueue, halting: Halting, policy: ChunkPolicy, stat_shape: tuple[int, ...],
                 takers: int = 1) -> None:
        self.chunks = chunks
        self.halting = halting
        self.policy = policy
        self.max_chunk = chunk_block_limit(stat_shape, policy.max_chunk)
        self.takers = [Taker(policy.first_chunk) for _ in range(takers)]
        self.t0 = time.perf_counter()

    def start_clock(self, t0: float) -> None:
        """Count the time budget from ``t0`` (``time.perf_counter``), when the run's clock starts."""
        self.t0 = t0

    def busy_seconds(self, k: int, enqueued: float, now: float) -> float:
        """How long taker ``k`` worked on the chunk that came back at ``now``.

        Its in-order queue started the chunk when it was enqueued or when the
        chunk before it came back, whichever was later.
        """
        t = self.takers[k]
        busy = now - max(enqueued, t.last_done)
        t.last_done = now
        return busy

    def measure(self, k: int, nblocks: int, seconds: float) -> None:
        """Record that taker ``k`` computed ``nblocks`` in ``seconds`` of work."""
        t = self.takers[k]
        if seconds > 0:
            sample = nblocks / seconds
            w = self.policy.new_weight
            t.rate = sample if t.rate <= 0 else (1.0 - w) * t.rate + w * sample

    def drop(self, k: int) -> None:
        """Taker ``k`` failed: it no longer shares the blocks left."""
        self.takers[k].alive = False

    def size(self, k: int, inflight_blocks: int = 0, alike: int = 1) -> tuple[int, bool]:
        """(chunk size, whether new blocks may be taken) for taker ``k``.

        Args:
            k: the taker.
            inflight_blocks: its blocks already in flight (they take time
                out of a time budget).
            alike: how many alike workers share this taker's rate (Dask's
                pool); its share of the blocks left is divided among them.
        """
        t = self.takers[k]
        p = self.policy
        if t.rate <= 0:
            n = t.start_size
            t.start_size = min(t.start_size * 2, MAX_CHUNK_BLOCKS)
        else:
            n = max(1, int(t.rate * p.chunk_seconds))
            share = 1.0
            if len(self.takers) > 1 or alike > 1:
                total = sum(o.rate for o in self.takers if o.alive and o.rate > 0)
                share = t.rate / total / max(alike, 1)
            if self.chunks.max_blocks is not None and share < 1.0:
                remaining = self.chunks.max_blocks - self.chunks.next_block
                floor = max(1, n // p.tail_floor)
                n = min(n, max(floor, math.ceil(remaining * share / 2)))
        allow_new = True
        budget = self.halting.time_budget
        if budget is not None:
            left = budget - (time.perf_counter() - self.t0)
            # A fresh run computes at least its first block, however small the
            # budget: a result of no samples at all is no estimate.
            allow_new = left > 0 or (self.chunks.next_block == 0 and t.rate <= 0)
            if t.rate > 0:
                left -= inflight_blocks / t.rate  # the blocks already in flight take this long
                n = max(1, min(n, int(t.rate * max(left, 0.0)) + 1))
        return min(n, self.max_chunk), allow_new


__all__ = ["MAX_CHUNK_BLOCKS", "MAX_CHUNK_BYTES", "ChunkPolicy", "ChunkQueue", "Sizer", "Taker", "chunk_block_limit"]
