"""The job contract: what every back end of the engine agrees on.

This module owns the types that the public APIs, the back ends and the
progress bar share, and nothing that runs a job:

- :class:`BlockJob` and :class:`BlockRunner`: a job is a range of *blocks*
  (units of work whose statistics are folded in block order by
  :class:`~mcocl.accumulate.Accumulator`); a runner is the job bound to one
  device, which enqueues a chunk of consecutive blocks and later collects
  their statistics;
- :class:`Halting`: when to stop (blocks, time budget, a job-defined target,
  Ctrl-C) and where to save checkpoints;
- :class:`Placement`: where a job runs (one device, several, sub-devices, a
  Dask cluster);
- :class:`Progress`: the report handed to a progress callback;
- :class:`RunReport` and :class:`DeviceStats`: what happened in a run;
- :class:`DeviceFailureWarning`: a device dropped out and its work moved on;
- :class:`InterruptFlag`: Ctrl-C (SIGINT) turned into a flag for the length
  of a run, so that a run stops cleanly after the blocks in flight.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from ..accumulate import Accumulator, RowRanges
from ..runtime import DeviceContext


class BlockRunner(Protocol):
    """A job bound to one device."""

    def enqueue(self, first_block: int, nblocks: int) -> Any:
        """Start computing blocks ``first_block .. first_block + nblocks - 1``; return a handle."""

    def collect(self, handle: Any) -> np.ndarray | RowRanges:
        """Wait for an enqueued chunk; return its ``(nblocks, *stat_shape)`` statistics (dense, or sparse as
        :class:`~mcocl.accumulate.RowRanges`)."""


class BlockJob(Protocol):
    """What the back ends need to know about a job.

    A job is plain data: the Dask back end pickles it and builds its runner on
    every worker.
    """

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
        if self.time_budget is not None and elapsed >= self.time_budget and acc.blocks_done > 0:
            return "time"  # (never before the first block: see Sizer.size)
        return ""

    def save_checkpoint(self, acc: Accumulator) -> None:
        """Save ``acc`` to the checkpoint file, if one was asked for."""
        if self.checkpoint:
            acc.save(self.checkpoint)

    def conclude(self, acc: Accumulator, stopped_by: str, interrupted: bool, exhausted: bool) -> str:
        """Save the final checkpoint; return why the run stopped (derived when no rule fired yet)."""
        if not stopped_by:
            stopped_by = "interrupt" if interrupted else ("blocks" if exhausted else "time")
        self.save_checkpoint(acc)
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
            ``address (name)``).
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
    """What happened in one run, on whichever back end."""

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


@dataclass
class Placement:
    """Where a job runs (see :func:`mcocl.engine.dispatch.execute`).

    Attributes:
        device: one device (index, name substring, or None for the default);
            with ``client``, the device every Dask worker picks for itself.
        devices: several devices: a list of specs, a comma-separated string,
            or ``"all"`` (:mod:`mcocl.devices`).
        split: partition each device that supports OpenCL device fission
            into this many sub-devices and use them as devices.
        client: a ``dask.distributed.Client`` (or a scheduler address) to run
            chunks on as Dask tasks (:mod:`mcocl.engine.dask_cluster`);
            excludes ``devices`` and ``split``.
    """

    device: Any = None
    devices: Any = None
    split: int | None = None
    client: Any = None

    @property
    def is_single(self) -> bool:
        """True when the job runs on one local device."""
        return self.devices is None and not self.split and self.client is None


class InterruptFlag:
    """Ctrl-C and SIGTERM as flags: a context manager for the length of one run.

    While it is active (and only when entered on the main thread, the one
    Python delivers signals to), SIGINT and SIGTERM do not raise:

    - the first sets :attr:`requested`: the run stops handing out new blocks,
      folds the blocks in flight, saves its checkpoint and reports
      ``stopped_by="interrupt"``, so nothing computed is lost;
    - the second sets :attr:`urgent` as well: the run stops at once without
      waiting to fold the blocks still in flight, and still saves and returns
      everything folded so far (a user who presses Ctrl-C twice, or a service
      manager that repeats SIGTERM, must not lose the image);
    - a third restores the previous handlers and raises
      :class:`KeyboardInterrupt`.

    A terminating service manager sends SIGTERM where a user presses Ctrl-C;
    both mean "stop and keep what you have".  Leaving the context restores
    the previous handlers, except where :attr:`linger` is set (the command
    line sets it) and a stop was asked for: then requests go on being counted
    until the process ends, and only the third in all raises
    :class:`KeyboardInterrupt`.  The stopped run's result is reported and
    saved after the context ends; without this, a second Ctrl-C or a SIGTERM
    that came a moment after the first (a supervisor, a service manager)
    landed there and lost it (issue 10).

    Attributes:
        requested: True once a stop was asked for.
        urgent: True once it was asked for twice.
    """

    SIGNALS = (signal.SIGINT, signal.SIGTERM)
    # Keep counting requests after a stopped run (see the class docstring); a process-wide choice.
    linger = False

    def __init__(self) -> None:
        self.requested = False
        self.urgent = False
        self._count = 0
        self._old: dict[int, Any] = {}

    def __enter__(self) -> InterruptFlag:
        if threading.current_thread() is threading.main_thread():
            for sig in self.SIGNALS:
                self._old[sig] = signal.signal(sig, self._handler)
        return self

    def _restore(self) -> None:
        for sig, old in self._old.items():
            signal.signal(sig, old)
        self._old = {}

    def _handler(self, signum: int, frame: Any) -> None:
        self._count += 1
        if self._count >= 3:  # a third request: give up at once
            self._restore()
            raise KeyboardInterrupt
        self.requested = True
        self.urgent = self._count >= 2

    def __exit__(self, *exc: object) -> None:
        if self.requested and InterruptFlag.linger and self._old:
            return  # the handler stays, and counts on towards the third request
        self._restore()


__all__ = [
    "BlockJob",
    "BlockRunner",
    "DeviceFailureWarning",
    "DeviceStats",
    "Halting",
    "InterruptFlag",
    "Placement",
    "Progress",
    "RunReport",
]
