"""The options every job shares, checked once: :class:`RunOptions`.

``integrate``, ``solve_fredholm`` and ``render`` (and their CLI commands) take
the same seed, placement (device, devices, split, client), halting (time
budget, target error), persistence (checkpoint, resume), progress and lane
options.  They are validated here and nowhere else, so the same bad value gets
the same :class:`~mcocl.errors.InputError` message from every API and the CLI.

One name per concept:

=============  ===============  =========================================
API            CLI              deprecated names (still accepted)
=============  ===============  =========================================
time_budget    --time           ``time`` (render)
target_error   --target-error   ``target_stderr`` (integrate, solve_fredholm),
                                ``noise`` (render); CLI ``--target-stderr``,
                                ``--noise``
=============  ===============  =========================================

What ``target_error`` measures is each job's own error: the standard error of
an integral, the largest standard error over a walk's query points, the mean
relative standard error over a render's pixels.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from .engine.contract import Halting, Placement, Progress
from .errors import InputError
from .output_files import check_output_file
from .progress import ProgressBar
from .validate import exact_integer, file_path, positive_number, whole_number

# Vector widths the kernels' lane dialect implements (kernels/lanes.cl: LANES 1, 2, 4, 8, 16).
SUPPORTED_LANES = (1, 2, 4, 8, 16)
SEED_LIMIT = 2**64

def renamed_keyword(api: str, new: str, new_value: Any, old: str, old_value: Any) -> Any:
    """The value of option ``new``, given either as ``new=`` or as its deprecated name ``old=``.

    ``old=`` still works but warns with a :class:`DeprecationWarning` naming
    ``new``; giving both is an :class:`InputError`.
    """
    if old_value is None:
        return new_value
    warnings.warn(f"{api}(): {old}= is deprecated; use {new}= instead", DeprecationWarning, stacklevel=3)
    if new_value is not None:
        raise InputError(f"give {new}= only ({old}= is its deprecated name), not both")
    return old_value


def check_lanes(v: Any) -> int | None:
    """``v`` as a lane width the kernels implement, or None (the device's default)."""
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or v not in SUPPORTED_LANES:
        raise InputError(f"lanes must be {', '.join(map(str, SUPPORTED_LANES[:-1]))} or {SUPPORTED_LANES[-1]}, "
                         f"got {v!r}")
    return int(v)


@dataclass(frozen=True)
class RunOptions:
    """The validated options shared by every job (see the module docstring).

    Constructing one checks every field; a bad value raises
    :class:`~mcocl.errors.InputError` naming the option.

    Attributes:
        seed: 64-bit seed; the result depends on nothing else.
        time_budget: stop after this many seconds (``None``: no limit).
        target_error: stop once the job's error measure is at most this.
        device, devices, split, client: where to run (:class:`mcocl.engine.contract.Placement`).
        lanes: samples per vector instruction (``None``: the device's; 1: scalar kernel).
        checkpoint: save the sums to this file periodically and at the end.
        resume: continue from this checkpoint.
        progress: True for a progress bar on stderr, or a callback.
    """

    seed: int = 0
    time_budget: float | None = None
    target_error: float | None = None
    device: Any = None
    devices: Any = None
    split: int | None = None
    client: Any = None
    lanes: int | None = None
    checkpoint: str | None = None
    resume: str | None = None
    progress: bool | Callable[[Progress], None] = False

    def __post_init__(self) -> None:
        def put(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        put("seed", exact_integer("seed", self.seed, 0, SEED_LIMIT, "2**64"))
        if self.time_budget is not None:
            put("time_budget", positive_number("time_budget", self.time_budget, "seconds"))
        if self.target_error is not None:
            put("target_error", positive_number("target_error", self.target_error))
        if self.split is not None:
            put("split", whole_number("split", self.split, 1))
        put("lanes", check_lanes(self.lanes))
        put("checkpoint", file_path("checkpoint", self.checkpoint))
        if self.checkpoint is not None:  # before any work: a run must not end in "cannot write"
            check_output_file(self.checkpoint, "checkpoint", "checkpoint")
        put("resume", file_path("resume", self.resume))
        if not (isinstance(self.progress, bool) or callable(self.progress)):
            raise InputError(f"progress must be True, False or a callable, got {self.progress!r}")

    def require_stop(self, budget: str, value: Any) -> None:
        """Raise unless something ends the run: the job's own ``budget`` (samples, walks) or a halting option."""
        if value is None and self.time_budget is None and self.target_error is None:
            raise InputError(f"{budget}=None needs time_budget= or target_error= to know when to stop")

    @property
    def placement(self) -> Placement:
        """Where the job runs."""
        return Placement(device=self.device, devices=self.devices, split=self.split, client=self.client)

    def halting(self, max_blocks: int | None, target: Callable[[Any], bool] | None) -> Halting:
        """When the job stops: its block count, ``time_budget``, its ``target`` test, and checkpoints."""
        return Halting(max_blocks=max_blocks, time_budget=self.time_budget, target=target,
                       checkpoint=self.checkpoint)

    def progress_reporter(self, label: str, unit: str, per_block: int) -> tuple[
            Callable[[Progress], None] | None, ProgressBar | None]:
        """``(callback, bar)``: a progress bar when ``progress`` is True, the user's callback, or neither."""
        if self.progress is True:
            bar = ProgressBar(label, unit=unit, per_block=per_block)
            return bar.update, bar
        if callable(self.progress):
            return self.progress, None
        return None, None
