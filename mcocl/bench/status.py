"""The bench's progress line: which problem and estimator runs, and the time left.

On a terminal one line is redrawn (at most ten times a second); elsewhere
(CI logs, pipes, tests) one line is printed when each run starts, so logs
stay short.
"""

from __future__ import annotations

import sys
import time
from typing import Any, TextIO


def _clock(s: float) -> str:
    s = max(int(round(s)), 0)
    return f"{s // 3600:d}:{s % 3600 // 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60:02d}:{s % 60:02d}"


class BenchStatus:
    """Progress of a bench: ``[3/40] two-peak-2d · balance [#####.....] 2.1/5 s, left 03:10``.

    Args:
        label: shown first (``bench integrate``).
        stream: where to draw (stderr by default).
    """

    def __init__(self, label: str, stream: TextIO | None = None) -> None:
        self.label = label
        self.stream = stream or sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.total = 0
        self.index = 0
        self.budget = 0.0
        self.current = ""
        self.run_seconds = 0.0
        self._last = 0.0
        self._width = 0

    def begin(self, total: int, budget: float) -> None:
        """``total`` runs of ``budget`` seconds each are about to start."""
        self.total, self.budget = total, budget

    def left(self) -> float:
        """Seconds left: the rest of this run and every run after it."""
        return max(self.budget - self.run_seconds, 0.0) + max(self.total - self.index, 0) * self.budget

    def _line(self) -> str:
        width = 20
        frac = min(self.run_seconds / self.budget, 1.0) if self.budget > 0 else 0.0
        bar = "#" * int(frac * width) + "." * (width - int(frac * width))
        return (f"{self.label} [{self.index}/{self.total}] {self.current} [{bar}] "
                f"{self.run_seconds:.1f}/{self.budget:g} s, left {_clock(self.left())}")

    def _draw(self, force: bool = False) -> None:
        now = time.monotonic()
        if not self.tty or (not force and now - self._last < 0.1):
            return
        self._last = now
        line = self._line()
        self.stream.write("\r" + line + " " * max(self._width - len(line), 0))
        self.stream.flush()
        self._width = len(line)

    def start_run(self, problem: str, estimator: str) -> None:
        """A run starts."""
        self.index += 1
        self.current = f"{problem} · {estimator}"
        self.run_seconds = 0.0
        if self.tty:
            self._draw(force=True)
        else:
            self.stream.write(f"{self.label} [{self.index}/{self.total}] {self.current} (left {_clock(self.left())})\n")
            self.stream.flush()

    def tick(self, run_seconds: float) -> None:
        """The current run has sampled for ``run_seconds``."""
        self.run_seconds = run_seconds
        self._draw()

    def end_run(self, record: Any) -> None:
        """A run ended (a failure is printed at once, not only in the report)."""
        self.run_seconds = self.budget
        if getattr(record, "failed", ""):
            self._clear()
            self.stream.write(f"{self.label}: {self.current} failed: {record.failed}\n")
            self.stream.flush()

    def _clear(self) -> None:
        if self.tty and self._width:
            self.stream.write("\r" + " " * self._width + "\r")
            self._width = 0

    def close(self) -> None:
        """Erase the line."""
        self._clear()
        self.stream.flush()
