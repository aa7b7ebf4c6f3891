"""Signs of life from a supervised run to the process that supervises it.

The command line runs the device work of ``integrate``, ``solve``, ``render``
and ``bench`` in a child process (:mod:`mcocl.cli.supervise`): user snippets
run natively, and an endless loop or a wild write in one cannot be stopped or
survived from inside the process that runs it.  The parent needs to know when
sampling starts (the ``--time`` budget counts from there, not from the kernel
build) and that the child is still folding results.  The child writes one
short line per event to a pipe whose file descriptor the parent passes in
``MCOCL_HEARTBEAT_FD``; without that variable every call here does nothing.
"""

from __future__ import annotations

import os
import threading

ENV = "MCOCL_HEARTBEAT_FD"

_lock = threading.Lock()
_fd: int | None = None
_checked = False


def _channel() -> int | None:
    global _fd, _checked
    if not _checked:
        _checked = True
        text = os.environ.get(ENV, "")
        _fd = int(text) if text.isdigit() else None
    return _fd


def beat(event: str) -> None:
    """Tell the supervisor about ``event`` (``start``: sampling begins; ``fold``:
    a chunk of results was added; ``stop``: the run is writing its outputs).

    Never raises: a supervisor that went away must not stop the run.
    """
    global _fd
    with _lock:
        fd = _channel()
        if fd is None:
            return
        try:
            os.write(fd, (event + "\n").encode())
        except OSError:
            _fd = None
