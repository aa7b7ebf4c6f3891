"""Scene-table buffers over the host arrays (render/table_buffers.py) and the heap trim (host_memory.py)."""

from __future__ import annotations

import platform

import numpy as np
import pyopencl as cl

from mcocl import runtime
from mcocl.host_memory import release_free_heap
from mcocl.render.table_buffers import shares_host_memory, table_buffer


def test_table_buffer_holds_the_table_and_aliases_it_where_the_device_shares_host_memory():
    ctx = runtime.device_context()
    table = np.arange(4 * 1000, dtype=np.float32).reshape(-1, 4)
    buf = table_buffer(ctx.context, ctx.device, table)
    got = np.empty_like(table)
    cl.enqueue_copy(ctx.queue, got, buf)
    assert got.tobytes() == table.tobytes()
    aliased = bool(buf.flags & cl.mem_flags.USE_HOST_PTR)
    assert aliased == shares_host_memory(ctx.device)
    assert not buf.flags & cl.mem_flags.WRITE_ONLY and buf.flags & cl.mem_flags.READ_ONLY
    if aliased:  # pyopencl keeps the array alive with the buffer
        assert buf.hostbuf is not None


def test_table_buffer_takes_a_non_contiguous_table_as_its_contiguous_copy():
    ctx = runtime.device_context()
    table = np.arange(64, dtype=np.uint32).reshape(8, 8)[:, ::2]
    buf = table_buffer(ctx.context, ctx.device, table)
    got = np.empty(table.shape, np.uint32)
    cl.enqueue_copy(ctx.queue, got, buf)
    assert np.array_equal(got, table)


def test_release_free_heap_trims_on_glibc():
    assert release_free_heap() == (platform.libc_ver()[0] == "glibc")


def test_release_free_heap_trims_only_a_heap_with_much_free(monkeypatch):
    import mcocl.host_memory as hm

    calls: list[int] = []
    monkeypatch.setattr(hm, "_malloc_trim", lambda: calls.append)
    monkeypatch.setattr(hm, "free_heap_bytes", lambda: hm.TRIM_FREE_BYTES - 1)
    assert hm.release_free_heap() is True and calls == []  # a small render's free heap stays for the next one
    monkeypatch.setattr(hm, "free_heap_bytes", lambda: hm.TRIM_FREE_BYTES)
    assert hm.release_free_heap() is True and calls == [0]
    monkeypatch.setattr(hm, "free_heap_bytes", lambda: None)  # mallinfo2 unknown: trim as before
    assert hm.release_free_heap() is True and calls == [0, 0]


def test_free_heap_bytes_reads_glibc():
    from mcocl.host_memory import free_heap_bytes

    got = free_heap_bytes()
    lib, version = platform.libc_ver()
    if lib == "glibc" and tuple(int(v) for v in version.split(".")[:2]) >= (2, 33):  # mallinfo2's first release
        assert got is not None and got >= 0
    elif lib != "glibc":
        assert got is None
