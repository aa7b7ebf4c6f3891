"""Where a job runs: :func:`execute` picks the back end a placement asks for.

This is the engine's entry point for the public APIs (``integrate``,
``solve_fredholm``, ``render``).  It is the only module that knows every back
end; the back ends know the contract, the chunking policy and the fold loop,
and never each other.
"""

from __future__ import annotations

from collections.abc import Callable

from ..accumulate import Accumulator
from ..devices import resolve_devices
from ..runtime import DeviceContext, device_context
from .contract import BlockJob, BlockRunner, Halting, Placement, Progress, RunReport
from .dask_cluster import run_dask
from .multi_device import run_devices
from .one_device import run_one_device


def execute(
    job: BlockJob,
    acc: Accumulator,
    halting: Halting,
    placement: Placement | None = None,
    progress: Callable[[Progress], None] | None = None,
    runner: BlockRunner | None = None,
    ctx: DeviceContext | None = None,
) -> RunReport:
    """Run ``job`` where ``placement`` says.

    - one device (the default): :func:`~mcocl.engine.one_device.run_one_device`;
    - ``devices`` and/or ``split``: :func:`~mcocl.engine.multi_device.run_devices`,
      one feeder thread per device or sub-device (a choice that comes down
      to one device runs on the one-device back end);
    - ``client``: :func:`~mcocl.engine.dask_cluster.run_dask`, chunks as Dask tasks.

    Whatever the placement, blocks are folded in block order, so the sums are
    bit-identical to a one-device run of the same job (on devices that build
    the same kernel: same lane width and compiler).

    Args:
        job: the job.
        acc: the accumulator to fold into (may hold a resumed state).
        halting: the stopping rules and the checkpoint.
        placement: where to run (default: the default device).
        progress: called after every fold.
        runner, ctx: a runner already built on ``ctx`` (the API builds one
            first, to report compile errors early); reused, not rebuilt,
            when ``ctx`` is one of the placement's devices.

    Raises:
        InputError: a malformed placement.
        DeviceError: no device is left after failures (multi-device, Dask).
    """
    placement = placement or Placement()
    if not placement.is_single or placement.client is not None:
        _pin_lanes(job, runner)
    if placement.client is not None:
        return run_dask(job, acc, halting, placement, progress=progress)
    if placement.is_single:
        if ctx is None:
            ctx = device_context(placement.device)
        return run_one_device(job, acc, halting, ctx, progress=progress, runner=runner)
    choice = resolve_devices(placement.device, placement.devices, placement.split)
    contexts = choice.contexts
    runners = {k: runner for k, c in enumerate(contexts) if runner is not None and c is ctx}
    if len(contexts) == 1:
        return run_one_device(job, acc, halting, contexts[0], progress=progress, runner=runners.get(0))
    report = run_devices(job, acc, halting, contexts, progress=progress, runners=runners)
    report.notes = choice.notes + report.notes
    return report


def _pin_lanes(job: BlockJob, runner: BlockRunner | None) -> None:
    """Give every device the lane width of the build the API already made.

    A job without a lane width builds each device's default, and devices (a
    sub-device, a Dask worker's device) may report different ones; the lane
    width changes the order of sums inside a block, so the blocks' last bits
    would depend on which device computed them.
    """
    lanes = getattr(runner, "lanes", None)
    if lanes is not None and getattr(job, "lanes", 0) is None:
        job.lanes = int(lanes)  # type: ignore[attr-defined]


__all__ = ["execute"]
