"""What the OpenCL compiler prints during a build, kept off the user's terminal unless asked for.

PoCL's clang writes its summaries (``24 warnings generated.``, ``1 error
generated.``) straight to the process's file descriptor 2, outside Python, so
neither ``warnings`` filters nor ``sys.stderr`` replacements reach them.  The
runtime therefore points descriptor 2 at a temporary file for the duration of
a build (:func:`compiler_stderr_captured`) and drops what was written there;
the lane build that is expected to fail on some user snippets (and then falls
back to the scalar build) is the common source of such lines.

Build logs are shown on request only: ``mcocl --verbose`` (which calls
:func:`set_build_log`) or the environment variable ``MCOCL_BUILD_LOG=1``.  Then
nothing is captured and every non-empty log is printed with the name of what
was built (:func:`show_build_log`).
"""

from __future__ import annotations

import os
import sys
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager

ENV_VAR = "MCOCL_BUILD_LOG"

_requested: bool | None = None
_lock = threading.Lock()
_depth = 0
_saved_fd: int | None = None
_sink = None


def set_build_log(show: bool | None) -> None:
    """Show (``True``) or hide (``False``) build logs; ``None`` defers to ``MCOCL_BUILD_LOG``."""
    global _requested
    _requested = show


def build_log_requested() -> bool:
    """True when build logs are to be shown (see :func:`set_build_log`)."""
    if _requested is not None:
        return _requested
    return os.environ.get(ENV_VAR, "").strip().lower() not in ("", "0", "false", "no", "off")


@contextmanager
def compiler_stderr_captured() -> Iterator[None]:
    """Send what is written to file descriptor 2 during the block to a discarded file.

    Builds on several threads share one capture (the descriptor is the
    process's): the first to enter redirects, the last to leave restores.
    Anything else written to descriptor 2 meanwhile (a progress redraw from
    another thread) is dropped too; builds take about a second.  When build
    logs are requested nothing is captured.
    """
    if build_log_requested():
        yield
        return
    global _depth, _saved_fd, _sink
    with _lock:
        if _depth == 0:
            _flush_stderr()
            try:
                saved = os.dup(2)
            except OSError:  # no descriptor 2 (a detached process): nothing reaches a terminal anyway
                saved = None
            if saved is not None:
                _sink = tempfile.TemporaryFile()
                os.dup2(_sink.fileno(), 2)
            _saved_fd = saved
        _depth += 1
    try:
        yield
    finally:
        with _lock:
            _depth -= 1
            if _depth == 0 and _saved_fd is not None:
                _flush_stderr()
                os.dup2(_saved_fd, 2)
                os.close(_saved_fd)
                _sink.close()
                _saved_fd, _sink = None, None


def _flush_stderr() -> None:
    try:
        sys.stderr.flush()
    except (AttributeError, OSError, ValueError):  # no stderr, or a closed one
        pass


def show_build_log(what: str, device: str, options: tuple[str, ...], log: str, failed: bool = False) -> None:
    """Print a build log on stderr when build logs are requested and the log is not empty."""
    if not build_log_requested() or not log.strip():
        return
    state = "failed" if failed else "succeeded"
    print(f"mcocl: build of the {what} on {device} {state} ({' '.join(options)}); compiler log:\n{log.rstrip()}",
          file=sys.stderr)


__all__ = ["ENV_VAR", "build_log_requested", "compiler_stderr_captured", "set_build_log", "show_build_log"]
