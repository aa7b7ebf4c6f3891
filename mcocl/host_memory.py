"""Give the C heap's free memory back to the system (glibc's ``malloc_trim``; nothing elsewhere).

glibc serves allocations below its mmap threshold from the heap, and that
threshold rises to the size of the largest block freed (up to 32 MB on 64-bit
systems), so that after a scene's compilation — hundreds of NumPy temporaries
of a few MB — the process keeps about 190 MB of freed heap resident for a
10^6-triangle scene (``bench/scene_memory.py``): memory no array uses, which
only ``malloc_trim`` returns.  Calling it between the stages of a render
costs a walk over the heap (milliseconds) and changes no result.

A trim is skipped while the heap holds less than :data:`TRIM_FREE_BYTES` free
(glibc's ``mallinfo2``): what a small render frees (10-20 MB for a 160 x 120
image) the next one allocates again, and every page a trim gave back costs a
page fault and a cleared page then (perf, 60 renders of scenes/caustic.json:
6-7 % of the process's cycles in the kernel's page-fault and clear_page paths,
and up to 2.4 ms per trim).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
from collections.abc import Callable
from typing import TypeVar

F = TypeVar("F", bound=Callable)
# Free heap below which a trim would only hand back pages the next render faults in again.
TRIM_FREE_BYTES = 32 << 20


class _MallInfo2(ctypes.Structure):
    _fields_ = [(name, ctypes.c_size_t) for name in
                ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks", "fordblks",
                 "keepcost")]


@functools.cache
def _libc():
    """The C library, or None where it cannot be loaded."""
    name = ctypes.util.find_library("c")
    try:
        return ctypes.CDLL(name) if name else None
    except OSError:
        return None


@functools.cache
def _malloc_trim():
    """glibc's ``malloc_trim``, or None where the C library has none (macOS, Windows, musl)."""
    return getattr(_libc(), "malloc_trim", None)


@functools.cache
def _mallinfo2():
    """glibc's ``mallinfo2`` (2.33 and later), or None."""
    fn = getattr(_libc(), "mallinfo2", None)
    if fn is not None:
        fn.restype = _MallInfo2
    return fn


def free_heap_bytes() -> int | None:
    """The bytes of the C heap's free chunks (glibc's ``mallinfo2().fordblks``), or None where unknown."""
    info = _mallinfo2()
    return None if info is None else int(info().fordblks)


def release_free_heap() -> bool:
    """Return the C heap's free pages to the system once it holds :data:`TRIM_FREE_BYTES` free or more;
    whether the C library could (glibc)."""
    trim = _malloc_trim()
    if trim is None:
        return False
    free = free_heap_bytes()
    if free is None or free >= TRIM_FREE_BYTES:
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


__all__ = ["TRIM_FREE_BYTES", "free_heap_bytes", "release_free_heap", "releases_free_heap"]
