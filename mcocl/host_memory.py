"""Give the C heap's free memory back to the system (glibc's ``malloc_trim``; nothing elsewhere).

glibc serves allocations below its mmap threshold from the heap, and that
threshold rises to the size of the largest block freed (up to 32 MB on 64-bit
systems), so that after a scene's compilation — hundreds of NumPy temporaries
of a few MB — the process keeps about 190 MB of freed heap resident for a
10^6-triangle scene (``bench/scene_memory.py``): memory no array uses, which
only ``malloc_trim`` returns.  Calling it between the stages of a render
costs a walk over the heap (milliseconds) and changes no result.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
from collections.abc import Callable
from typing import TypeVar

F = TypeVar("F", bound=Callable)


@functools.cache
def _malloc_trim():
    """glibc's ``malloc_trim``, or None where the C library has none (macOS, Windows, musl)."""
    name = ctypes.util.find_library("c")
    try:
        return ctypes.CDLL(name).malloc_trim if name else None
    except (OSError, AttributeError):
        return None


def release_free_heap() -> bool:
    """Return the C heap's free pages to the system; whether the C library could (glibc)."""
    trim = _malloc_trim()
    if trim is None:
        return False
    trim(0)
    return True


def releases_free_heap(fn: F) -> F:
    """Decorate ``fn`` to call :func:`release_free_heap` when it returns or raises (its own big tables
    are freed by then: what a render built for the device does not stay resident after it)."""
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        finally:
            release_free_heap()
    return wrapper  # type: ignore[return-value]


__all__ = ["release_free_heap", "releases_free_heap"]
