"""Read-only device buffers over the scene's tables, without a second copy where the device shares host memory.

``cl.mem_flags.COPY_HOST_PTR`` gives the device its own copy of a table: on
a GPU with its own memory that is the upload, but on a device that works in
host memory (``CL_DEVICE_HOST_UNIFIED_MEMORY``: PoCL's CPU device, integrated
GPUs) it is a second copy of every table in the same RAM — for a 10^6-triangle
scene about 240 MB more (``bench/scene_memory.py``).  There
``USE_HOST_PTR`` lets the kernels read the NumPy array itself: PoCL's CPU
device aliases it (measured: no growth of the resident memory, whatever the
array's alignment); pyopencl keeps the array alive as long as the buffer
(``Buffer.hostbuf``).  The kernels only read these buffers, so the bytes they
see, and the images, are the same either way.
"""

from __future__ import annotations

import numpy as np
import pyopencl as cl


def shares_host_memory(device: cl.Device) -> bool:
    """Whether ``device`` reads host memory directly (CL_DEVICE_HOST_UNIFIED_MEMORY; False if it does not say)."""
    try:
        return bool(device.host_unified_memory)
    except cl.Error:  # removed from OpenCL 3.0's required queries: a device may refuse it
        return False


def table_buffer(context: cl.Context, device: cl.Device, table: np.ndarray) -> cl.Buffer:
    """A read-only buffer holding ``table`` (made C-contiguous): over the array itself where the device
    shares host memory, else a copy.  The array must not change while the buffer lives."""
    mf = cl.mem_flags
    table = np.ascontiguousarray(table)
    where = mf.USE_HOST_PTR if shares_host_memory(device) else mf.COPY_HOST_PTR
    return cl.Buffer(context, mf.READ_ONLY | where, hostbuf=table)


__all__ = ["shares_host_memory", "table_buffer"]
