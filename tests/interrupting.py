"""A progress callback that stops a run as Ctrl-C does, for the tests of interrupt and resume."""

from __future__ import annotations

import os
import signal
from collections.abc import Callable
from typing import Any


def interrupt_after_first_fold() -> Callable[[Any], None]:
    """A ``progress=`` callback that sends SIGINT to this process at the first fold: the run stops
    after the blocks in flight, as it does on a Ctrl-C."""
    calls: list[int] = []

    def callback(p: Any) -> None:
        calls.append(p.blocks_done)
        if len(calls) == 1:
            os.kill(os.getpid(), signal.SIGINT)

    return callback
