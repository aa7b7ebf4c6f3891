"""Test doubles for the multi-device and Dask schedulers.

- :func:`capture_job` runs ``mcocl.integrate`` on one device and keeps the
  job it built, with the accumulator totals: the reference of every
  bit-identity test, and a real job to hand to the schedulers directly.
- :class:`FaultyJob` wraps a job so that its runner fails on chosen devices
  (at build, at a launch or at a collect, after some chunks): the device
  feeder sees exactly what a lost device or an out-of-memory launch gives it.
- :class:`SlowJob` makes one device slow (a sleep per block), to check that
  chunk sizes follow each device's throughput.
- :func:`small_cornell` is a tiny render job's scene.

Jobs here are plain picklable data, like the engine's, so they also run on
Dask workers (pickled by value: see ``cloudpickle.register_pickle_by_value``).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

import mcocl.integration.api as integration_api
from mcocl.engine.dispatch import execute
from mcocl.errors import DeviceError


def small_cornell(size: int = 16) -> Any:
    """The Cornell box scene at ``size`` x ``size`` pixels, compiled."""
    from mcocl.render.compiled import compile_scene
    from mcocl.render.scene_file import load_scene

    sc = load_scene(Path(__file__).resolve().parent.parent / "scenes" / "cornell.json")
    sc.camera.width = sc.camera.height = size
    return compile_scene(sc)


@dataclass
class Captured:
    """A job built by the integration API, and its one-device result."""

    job: Any
    shape: tuple[int, ...]
    max_blocks: int | None
    totals: np.ndarray
    blocks: int


def capture_job(monkeypatch: Any, integrand: str, **kwargs: Any) -> Captured:
    """Run ``mcocl.integrate(integrand, **kwargs)`` and keep its job and totals."""
    seen: dict[str, Any] = {}

    def spy(job, acc, halting, placement=None, progress=None, runner=None, ctx=None):
        report = execute(job, acc, halting, placement, progress, runner, ctx)
        seen.update(job=job, shape=acc.shape, max_blocks=halting.max_blocks,
                    totals=acc.totals.copy(), blocks=acc.blocks_done)
        return report

    with monkeypatch.context() as m:
        m.setattr(integration_api, "execute", spy)
        integration_api.integrate(integrand, **kwargs)
    return Captured(seen["job"], seen["shape"], seen["max_blocks"], seen["totals"], seen["blocks"])


def _matches(where: str | int | None, ctx: Any) -> bool:
    if where is None:
        return False
    if isinstance(where, int):  # a process id (a Dask worker)
        return os.getpid() == where
    return where == "*" or where == ctx.name


class FaultyRunner:
    """Delegates to a real runner; raises once ``after`` chunks went through."""

    def __init__(self, inner: Any, stage: str, after: int, message: str) -> None:
        self.inner = inner
        self.stage = stage
        self.after = after
        self.message = message
        self.calls = 0
        self.build_seconds = getattr(inner, "build_seconds", 0.0)

    def enqueue(self, first_block: int, nblocks: int) -> Any:
        if self.stage == "enqueue":
            self.calls += 1
            if self.calls > self.after:
                raise RuntimeError(self.message)
        return self.inner.enqueue(first_block, nblocks)

    def collect(self, handle: Any) -> np.ndarray:
        if self.stage == "collect":
            self.calls += 1
            if self.calls > self.after:
                raise RuntimeError(self.message)
        return self.inner.collect(handle)


@dataclass
class FaultyJob:
    """A job whose runner fails on the devices ``where`` names.

    Attributes:
        inner: the real job.
        where: a device name, ``"*"`` (every device) or a process id.
        stage: ``build`` (the runner cannot be built), ``enqueue`` or ``collect``.
        after: chunks that succeed before the failure.
        error: ``device`` (a :class:`DeviceError` at build) or ``runtime``.
    """

    inner: Any
    where: str | int | None
    stage: str = "enqueue"
    after: int = 2
    error: str = "runtime"
    stat_shape: tuple[int, ...] = field(init=False)

    def __post_init__(self) -> None:
        self.stat_shape = self.inner.stat_shape

    def runner(self, ctx: Any) -> Any:
        if not _matches(self.where, ctx):
            return self.inner.runner(ctx)
        if self.stage == "build":
            if self.error == "device":
                raise DeviceError(f"injected build failure on {ctx.name}")
            raise RuntimeError(f"injected build failure on {ctx.name}")
        return FaultyRunner(self.inner.runner(ctx), self.stage, self.after, f"injected {self.stage} failure on {ctx.name}")


class SlowRunner:
    """Delegates to a real runner; each collect sleeps ``per_block`` seconds per block."""

    def __init__(self, inner: Any, per_block: float) -> None:
        self.inner = inner
        self.per_block = per_block

    def enqueue(self, first_block: int, nblocks: int) -> Any:
        return self.inner.enqueue(first_block, nblocks), nblocks

    def collect(self, handle: Any) -> np.ndarray:
        h, nblocks = handle
        time.sleep(self.per_block * nblocks)
        return self.inner.collect(h)


@dataclass
class SlowJob:
    """A job that is ``per_block`` seconds per block slower on the device named ``slow``."""

    inner: Any
    slow: str
    per_block: float
    stat_shape: tuple[int, ...] = field(init=False)

    def __post_init__(self) -> None:
        self.stat_shape = self.inner.stat_shape

    def runner(self, ctx: Any) -> Any:
        r = self.inner.runner(ctx)
        return SlowRunner(r, self.per_block) if ctx.name == self.slow else r
