"""Stopping a run as Ctrl-C does, for the tests of interrupt and resume: a progress callback for the API,
and a Ctrl-C to a command-line render."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
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


def ctrl_c_render_cli(args: list[str], env: dict[str, str] | None = None) -> tuple[int, str, str]:
    """Run ``python -m mcocl render ARGS``, press Ctrl-C (SIGINT) once its progress bar shows a block
    in the film, and return (exit status, stdout, stderr) of the rest of the run."""
    proc = subprocess.Popen([sys.executable, "-m", "mcocl", "render", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)
    try:
        deadline = time.monotonic() + 240
        line = ""
        while time.monotonic() < deadline:  # the progress bar's first line: a block is in the film
            line = proc.stderr.readline()
            if line.startswith("render [") or not line:
                break
        assert line.startswith("render ["), f"no progress line; stderr: {line!r}"
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    return proc.returncode, out, err
