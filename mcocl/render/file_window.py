"""A forward-moving window onto the bytes of an open file: a text reader's chunks without the whole file.

A streamed reader (:mod:`mcocl.render.ply_reader`'s ASCII body) asks for
bytes at positions that only move forward; the window holds the bytes from
the earliest position still wanted to the furthest one asked for, so a read
holds one chunk of the file rather than all of it (issue 13: a scene holds at
most twice its files' size in memory).
"""

from __future__ import annotations

import os
from typing import BinaryIO

import numpy as np


class FileWindow:
    """The bytes of ``f`` (``size`` of them, from its start) as far as they are asked for, forward only."""

    def __init__(self, f: BinaryIO, size: int | None = None) -> None:
        self.f = f
        self.size = os.fstat(f.fileno()).st_size if size is None else size
        self.base, self.buf = 0, b""  # self.buf holds the file's bytes self.base .. self.base + len(self.buf)

    def __len__(self) -> int:
        return self.size

    def _cover(self, first: int, stop: int, drop: bool = True) -> None:
        """Hold the bytes ``first .. stop`` (clipped to the file), dropping those before ``first`` if ``drop``."""
        if first < self.base:  # gone back (a reader's rewind): read again from there
            self.base, self.buf = first, b""
        if drop and first > self.base:
            self.buf = self.buf[first - self.base:]
            self.base = first
        have = self.base + len(self.buf)
        stop = min(stop, self.size)
        if stop > have:
            self.f.seek(have)
            parts = [self.buf]
            while have < stop:
                block = self.f.read(stop - have)
                if not block:  # the file shrank since its size was taken
                    raise OSError(f"the file ended at byte {have} of {self.size}")
                parts.append(block)
                have += len(block)
            self.buf = b"".join(parts)

    def bytes_view(self, first: int, stop: int) -> np.ndarray:
        """The bytes ``first .. stop`` as uint8 (a view of the window); earlier bytes are let go."""
        self._cover(first, stop)
        return np.frombuffer(self.buf, np.uint8, count=min(stop, self.size) - first, offset=first - self.base)

    def rfind(self, sub: bytes, first: int, stop: int) -> int:
        """``bytes.rfind`` over the file's bytes ``first .. stop``."""
        self._cover(first, stop)
        at = self.buf.rfind(sub, first - self.base, stop - self.base)
        return at if at < 0 else at + self.base

    def find(self, sub: bytes, first: int, stop: int) -> int:
        """``bytes.find`` over the file's bytes ``first .. stop``, covering them a few chunks at a time."""
        step = 1 << 20
        at = first
        while at < min(stop, self.size):
            end = min(at + step, stop)
            self._cover(first, end, drop=False)
            k = self.buf.find(sub, at - self.base, end - self.base)
            if k >= 0:
                return k + self.base
            at = max(end - len(sub) + 1, at + 1)
            step *= 2
        return -1


__all__ = ["FileWindow"]
