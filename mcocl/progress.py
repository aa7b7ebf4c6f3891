"""A progress bar for long runs, on stderr.

Redraws at most ten times a second; on a terminal it rewrites one line, and
elsewhere (CI logs, pipes) it prints a line every few seconds so logs stay
short.  It shows the work done, its rate and the time left.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

from .engine.contract import Progress


def _si(v: float) -> str:
    for unit, scale in (("G", 1e9), ("M", 1e6), ("k", 1e3)):
        if abs(v) >= scale:
            return f"{v / scale:.3g}{unit}"
    return f"{v:.3g}"


def _clock(s: float | None) -> str:
    if s is None or s != s:
        return "--:--"
    s = int(round(s))
    return f"{s // 3600:d}:{s % 3600 // 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60:02d}:{s % 60:02d}"


class ProgressBar:
    """Renders :class:`~mcocl.engine.contract.Progress` reports.

    Args:
        label: what runs (shown first).
        unit: the name of the counted work (``samples``, ``spp``, ``walks``).
        per_block: how many units one scheduler block holds.
        stream: where to draw (stderr by default).
    """

    def __init__(self, label: str, unit: str = "samples", per_block: float = 1.0, stream: TextIO | None = None) -> None:
        self.label = label
        self.unit = unit
        self.per_block = per_block
        self.stream = stream or sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._last = 0.0
        self._line = ""
        self.extra = ""

    def update(self, p: Progress) -> None:
        """Draw a report (throttled)."""
        now = time.monotonic()
        if now - self._last < (0.1 if self.tty else 5.0):
            return
        self._last = now
        frac = p.fraction
        width = 24
        bar = ""
        if frac is not None:
            filled = int(frac * width)
            bar = "[" + "#" * filled + "." * (width - filled) + f"] {100 * frac:5.1f}% "
        done = p.blocks_done * self.per_block
        rate = p.blocks_per_second * self.per_block
        line = (f"{self.label} {bar}{_si(done)} {self.unit}, {_si(rate)} {self.unit}/s, "
                f"elapsed {_clock(p.elapsed)}, left {_clock(p.eta)}{self.extra}")
        rates = getattr(p, "device_rates", ())
        if len(rates) > 1:  # several devices or Dask workers: each one's rate, in device order
            line += " | " + " ".join(f"{_si(r * self.per_block)}/s" for _, r in rates)
        self._draw(line)

    def _draw(self, line: str) -> None:
        if self.tty:
            pad = max(len(self._line) - len(line), 0)
            self.stream.write("\r" + line + " " * pad)
        else:
            self.stream.write(line + "\n")
        self.stream.flush()
        self._line = line

    def close(self) -> None:
        """End the bar's line."""
        if self.tty and self._line:
            self.stream.write("\n")
            self.stream.flush()
