"""Drive a job's blocks through a device until a halting rule fires.

A *job* is a range of blocks (units of work whose statistics are folded in
order by :class:`~mcocl.accumulate.Accumulator`); a *runner* is the job bound
to one device: it enqueues a chunk of consecutive blocks and later collects
their statistics.  The scheduler

- keeps two chunks in flight (double buffering), so the device never waits
  for Python to fold, report progress or decide to stop;
- sizes chunks from the measured throughput (about ``chunk_seconds`` each),
  in whole multiples of nothing but blocks, so the result does not depend on
  the chunking;
- halts on the block count, a time budget, a job-defined target (e.g. a
  standard error) or Ctrl-C (SIGINT), whichever comes first, and never drops
  a block that was already computed;
- saves a checkpoint after the first chunk and then every ``checkpoint_every``
  seconds when asked.
"""

from __future__ import annotations

import math
import signal
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from .accumulate import Accumulator
from .runtime import DeviceContext


class BlockRunner(Protocol):
    """A job bound to one device."""

    def enqueue(self, first_block: int, nblocks: int) -> Any:
        """Start computing blocks ``first_block .. first_block + nblocks - 1``; return a handle."""

    def collect(self, handle: Any) -> np.ndarray:
        """Wait for an enqueued chunk; return its ``(nblocks, *stat_shape)`` statistics."""


class BlockJob(Protocol):
    """What the scheduler needs to know about a job."""

    stat_shape: tuple[int, ...]

    def runner(self, ctx: DeviceContext) -> BlockRunner:
        """Build the job's program for a device and allocate its buffers."""


@dataclass
class Halting:
    """When to stop.  Every given rule applies; the first that fires wins.

    Attributes:
        max_blocks: total number of blocks of the job (``None``: unbounded).
        time_budget: seconds of wall time for this run.
        target: called with the accumulator after each fold; returns True
            when the job's own goal (e.g. a target standard error) is met.
        checkpoint: file to save the accumulator to every ``checkpoint_every``
            seconds and at the end.
    """

    max_blocks: int | None = None
    time_budget: float | None = None
    target: Callable[[Accumulator], bool] | None = None
    checkpoint: str | None = None
    checkpoint_every: float = 30.0

    def reason(self, acc: Accumulator, elapsed: float, interrupted: bool, folded: bool = True) -> str:
        """Why to stop now, or "" to go on: ``interrupt``, ``target`` (asked only
        right after a fold, the target being the costly rule), ``blocks`` or ``time``."""
        if interrupted:
            return "interrupt"
        if folded and self.target is not None and self.target(acc):
            return "target"
        if self.max_blocks is not None and acc.blocks_done >= self.max_blocks:
            return "blocks"
        if self.time_budget is not None and elapsed >= self.time_budget:
            return "time"
        return ""

    def conclude(self, acc: Accumulator, stopped_by: str, interrupted: bool, exhausted: bool) -> str:
        """Save the final checkpoint; return why the run stopped (derived when no rule fired yet)."""
        if not stopped_by:
            stopped_by = "interrupt" if interrupted else ("blocks" if exhausted else "time")
        if self.checkpoint:
            acc.save(self.checkpoint)
        return stopped_by


@dataclass
class Progress:
    """A progress report handed to the ``progress`` callback."""

    blocks_done: int
    max_blocks: int | None
    elapsed: float
    blocks_per_second: float
    time_budget: float | None
    # (device name, blocks per second of wall time) for each device of a
    # multi-device or Dask run, in device order; empty for one device.
    device_rates: tuple[tuple[str, float], ...] = ()

    @property
    def fraction(self) -> float | None:
        """Fraction done, by blocks or by time, whichever is further along."""
        fr = []
        if self.max_blocks:
            fr.append(self.blocks_done / self.max_blocks)
        if self.time_budget:
            fr.append(self.elapsed / self.time_budget)
        return min(max(fr), 1.0) if fr else None

    @property
    def eta(self) -> float | None:
        """Seconds left, estimated from the throughput so far."""
        left = []
        if self.max_blocks and self.blocks_per_second > 0:
            left.append((self.max_blocks - self.blocks_done) / self.blocks_per_second)
        if self.time_budget:
            left.append(max(self.time_budget - self.elapsed, 0.0))
        return min(left) if left else None


@dataclass
class DeviceStats:
    """What one device (or Dask worker) did in a run.

    Attributes:
        name: the device's name (sub-devices: ``name [k/N]``; Dask workers:
            ``address: name``).
        blocks: blocks it computed and that were folded.
        chunks: chunks (launches or Dask tasks) it completed.
        busy_seconds: time it had work in flight.
        build_seconds: time its program build took (0 when cached).
        error: why it dropped out, if it failed.
    """

    name: str
    blocks: int = 0
    chunks: int = 0
    busy_seconds: float = 0.0
    build_seconds: float = 0.0
    error: str | None = None

    def blocks_per_second(self, seconds: float) -> float:
        """Its throughput over ``seconds`` of wall time (the run's duration)."""
        return self.blocks / seconds if seconds > 0 else 0.0


class DeviceFailureWarning(RuntimeWarning):
    """A device failed during a run; its chunks went to the remaining devices."""


@dataclass
class RunReport:
    """What happened in one :func:`run` (or multi-device / Dask run)."""

    seconds: float
    blocks: int
    stopped_by: str  # "blocks", "time", "target", "interrupt"
    devices: list[str] = field(default_factory=list)
    chunks: int = 0
    per_device: list[DeviceStats] = field(default_factory=list)
    failures: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def device_rates(self) -> list[tuple[str, float]]:
        """(device name, blocks per second of wall time) for every device."""
        return [(d.name, d.blocks_per_second(self.seconds)) for d in self.per_device]

    @property
    def interrupted(self) -> bool:
        """True when the run was stopped by Ctrl-C."""
        return self.stopped_by == "interrupt"


class _Interrupt:
    """Turns SIGINT into a flag while a run is in progress (main thread only)."""

    def __init__(self) -> None:
        self.flag = False
        self._old: Any = None

    def __enter__(self) -> _Interrupt:
        if threading.current_thread() is threading.main_thread():
            self._old = signal.signal(signal.SIGINT, self._handler)
        return self

    def _handler(self, signum: int, frame: Any) -> None:
        if self.flag:  # second Ctrl-C: give up at once
            signal.signal(signal.SIGINT, self._old)
            raise KeyboardInterrupt
        self.flag = True

    def __exit__(self, *exc: object) -> None:
        if self._old is not None:
            signal.signal(signal.SIGINT, self._old)


def run(
    job: BlockJob,
    acc: Accumulator,
    halting: Halting,
    ctx: DeviceContext,
    progress: Callable[[Progress], None] | None = None,
    chunk_seconds: float = 0.15,
    first_chunk: int = 1,
    runner: BlockRunner | None = None,
) -> RunReport:
    """Compute blocks from ``acc.blocks_done`` on until ``halting`` says stop.

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
        a :class:`RunReport`; the statistics are in ``acc``.
    """
    if runner is None:
        runner = job.runner(ctx)
    t0 = time.perf_counter()
    next_block = start_blocks = acc.blocks_done
    inflight: deque[tuple[int, int, Any, float]] = deque()
    rate = 0.0  # blocks per second, measured
    stopped_by = ""
    chunks = 0
    last_ckpt = -math.inf  # the first fold is saved at once, then every checkpoint_every seconds
    size = max(int(first_chunk), 1)

    def remaining_blocks() -> float:
        return math.inf if halting.max_blocks is None else halting.max_blocks - next_block

    def want_more(now: float) -> bool:
        if remaining_blocks() <= 0:
            return False
        if halting.time_budget is not None and now - t0 >= halting.time_budget:
            return False
        return True

    with _Interrupt() as intr:
        while True:
            now = time.perf_counter()
            # Launch until two chunks are in flight.
            while len(inflight) < 2 and not stopped_by and not intr.flag and want_more(now):
                n = size
                if rate > 0:
                    n = max(1, int(rate * chunk_seconds))
                    if halting.time_budget is not None:
                        # the blocks already in flight take inflight / rate seconds
                        left = halting.time_budget - (now - t0) - sum(c[1] for c in inflight) / rate
                        n = max(1, min(n, int(rate * max(left, 0.0)) + 1))
                n = int(min(n, remaining_blocks()))
                handle = runner.enqueue(next_block, n)
                inflight.append((next_block, n, handle, time.perf_counter()))
                next_block += n
                chunks += 1
                size = min(size * 2, 1 << 20)
            if not inflight:
                break
            first, n, handle, t_enq = inflight.popleft()
            stats = runner.collect(handle)
            acc.add(first, stats)
            now = time.perf_counter()
            done = acc.blocks_done
            el = now - t0
            rate = (done - start_blocks) / el if el > 0 else 0.0
            if progress is not None:
                progress(Progress(done, halting.max_blocks, el, rate, halting.time_budget))
            if halting.checkpoint and now - last_ckpt >= halting.checkpoint_every:
                acc.save(halting.checkpoint)
                last_ckpt = now
            if not stopped_by:
                stopped_by = halting.reason(acc, el, intr.flag)
    stopped_by = halting.conclude(acc, stopped_by, intr.flag, remaining_blocks() <= 0)
    seconds = time.perf_counter() - t0
    return RunReport(
        seconds=seconds,
        blocks=acc.blocks_done,
        stopped_by=stopped_by,
        devices=[ctx.name],
        chunks=chunks,
        per_device=[DeviceStats(ctx.name, acc.blocks_done - start_blocks, chunks, seconds,
                                float(getattr(runner, "build_seconds", 0.0)))],
    )



@dataclass
class Placement:
    """Where a job runs (see :func:`execute`).

    Attributes:
        device: one device (index, name substring, or None for the default);
            with ``client``, the device every Dask worker picks for itself.
        devices: several devices: a list of specs, a comma-separated string,
            or ``"all"`` (:mod:`mcocl.devices`).
        split: partition each device that supports OpenCL device fission
            into this many sub-devices and use them as devices.
        client: a ``dask.distributed.Client`` (or a scheduler address) to run
            chunks on as Dask tasks (:mod:`mcocl.distributed`); excludes
            ``devices`` and ``split``.
    """

    device: Any = None
    devices: Any = None
    split: int | None = None
    client: Any = None

    @property
    def is_single(self) -> bool:
        """True when the job runs on one local device."""
        return self.devices is None and not self.split and self.client is None


def execute(
    job: BlockJob,
    acc: Accumulator,
    halting: Halting,
    placement: Placement | None = None,
    progress: Callable[[Progress], None] | None = None,
    runner: BlockRunner | None = None,
    ctx: DeviceContext | None = None,
) -> RunReport:
    """Run ``job`` where ``placement`` says; the single entry point of the public APIs.

    - one device (the default): :func:`run`;
    - ``devices`` and/or ``split``: :func:`mcocl.multidevice.run_devices`,
      one feeder thread per device or sub-device;
    - ``client``: :func:`mcocl.distributed.run_dask`, chunks as Dask tasks.

    Whatever the placement, blocks are folded in block order, so the sums are
    bit-identical to a one-device run of the same job (on devices that build
    the same kernel: same lane width and compiler).

    Args:
        runner, ctx: a runner already built on ``ctx`` (the API builds one
            first, to report compile errors early); reused, not rebuilt,
            when ``ctx`` is one of the placement's devices.

    Raises:
        InputError: a malformed placement.
        DeviceError: no device is left after failures (multi-device, Dask).
    """
    from .runtime import device_context

    placement = placement or Placement()
    if placement.client is not None:
        from .distributed import run_dask

        return run_dask(job, acc, halting, placement, progress=progress)
    if placement.is_single:
        if ctx is None:
            ctx = device_context(placement.device)
        return run(job, acc, halting, ctx, progress=progress, runner=runner)
    from .devices import resolve_devices
    from .multidevice import run_devices

    choice = resolve_devices(placement.device, placement.devices, placement.split)
    contexts = choice.contexts
    runners = {k: runner for k, c in enumerate(contexts) if runner is not None and c is ctx}
    if len(contexts) == 1:
        return run(job, acc, halting, contexts[0], progress=progress, runner=runners.get(0))
    report = run_devices(job, acc, halting, contexts, progress=progress, runners=runners)
    report.notes = choice.notes + report.notes
    return report
