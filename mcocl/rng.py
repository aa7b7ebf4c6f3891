"""The engine's random numbers, computed by the same OpenCL code the estimators use.

mcocl draws every random number from Philox4x32-10 (Random123), a counter-based
generator: the numbers of sample ``i``, dimension ``j`` under seed ``s`` are

    Philox4x32-10(counter=(lo32(i), hi32(i), j // 4, stream), key=(lo32(s), hi32(s)))[j % 4]

converted to a float by ``u = (floor(bits / 2**9) + 1/2) * 2**-23`` — the
centre of one of 2**23 equal cells, so ``0 < u < 1`` always and ``E[u] = 1/2``
exactly (see ``kernels/rng/uniform.cl``).

The stream tags and the grid are read from the kernels (``kernels/rng/streams.cl``,
``kernels/rng/uniform.cl``), so the host and the kernels share one definition.
"""

from __future__ import annotations

import re

import numpy as np
import pyopencl as cl

from . import runtime
from .errors import InputError


def kernel_constants(rel: str) -> dict[str, int]:
    """The integer ``#define NAME value`` constants of the kernel file ``rel`` (under ``kernels/``)."""
    text = (runtime.KERNEL_DIR / rel).read_text()
    pattern = re.compile(r"^#define\s+(\w+)\s+(0x[0-9a-fA-F]+|\d+)u?\b", re.M)
    return {m[1]: int(m[2], 0) for m in pattern.finditer(text)}


_STREAMS = kernel_constants("rng/streams.cl")
STREAM_SAMPLE = _STREAMS["RNG_STREAM_SAMPLE"]
STREAM_JITTER = _STREAMS["RNG_STREAM_JITTER"]
STREAM_AUX = _STREAMS["RNG_STREAM_AUX"]

#: The uniforms' grid: u = (m + 1/2) / GRID_CELLS, m < GRID_CELLS (tabulated densities count in these cells).
GRID_BITS = kernel_constants("rng/uniform.cl")["UNIFORM_GRID_BITS"]
GRID_CELLS = 1 << GRID_BITS


def _program(device: object = None) -> tuple[runtime.DeviceContext, cl.Program]:
    ctx = runtime.device_context(device)
    src = runtime.compose(["rng/rng_api.cl"])
    return ctx, runtime.build(ctx, src, ["-DLANES=1"], what="rng kernels")


def philox4x32_10(counters: np.ndarray, keys: np.ndarray, device: object = None) -> np.ndarray:
    """Philox4x32-10 of each (counter, key) pair, computed by the OpenCL kernel.

    Args:
        counters: ``(n, 4)`` array of uint32 (or one counter of shape ``(4,)``).
        keys: ``(n, 2)`` array of uint32 (or one key of shape ``(2,)``), broadcast
            against ``counters``.
        device: see :func:`mcocl.runtime.select_device`.

    Returns:
        ``(n, 4)`` uint32 array (``(4,)`` for a single counter).
    """
    c = np.asarray(counters)
    k = np.asarray(keys)
    single = c.ndim == 1
    c2 = np.atleast_2d(c)
    k2 = np.atleast_2d(k)
    if c2.shape[-1] != 4 or k2.shape[-1] != 2:
        raise InputError(f"counters must have 4 words and keys 2, got shapes {c.shape} and {k.shape}")
    for name, a in (("counters", c2), ("keys", k2)):
        if a.size and (a.min() < 0 or a.max() > 0xFFFFFFFF):
            raise InputError(f"{name} must be uint32 values")
    n = max(len(c2), len(k2))
    c2 = np.ascontiguousarray(np.broadcast_to(c2, (n, 4)), dtype=np.uint32)
    k2 = np.ascontiguousarray(np.broadcast_to(k2, (n, 2)), dtype=np.uint32)
    ctx, prg = _program(device)
    out = np.empty((n, 4), dtype=np.uint32)
    if n:
        mf = cl.mem_flags
        bc = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=c2)
        bk = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=k2)
        bo = cl.Buffer(ctx.context, mf.WRITE_ONLY, out.nbytes)
        runtime.kernel(prg, "philox_raw")(ctx.queue, (n,), None, bc, bk, bo)
        cl.enqueue_copy(ctx.queue, out, bo)
    return out[0] if single else out


def uniforms(seed: int, first: int, count: int, dims: int, stream: int = STREAM_SAMPLE, device: object = None) -> np.ndarray:
    """The uniforms in (0, 1) of samples ``first .. first+count-1``, dimensions ``0 .. dims-1``.

    Returns:
        ``(count, dims)`` float32 array, exactly the numbers an estimator sees.
    """
    if count < 0 or dims < 1:
        raise InputError(f"count must be >= 0 and dims >= 1, got {count}, {dims}")
    ctx, prg = _program(device)
    out = np.empty((count, dims), dtype=np.float32)
    if count:
        bo = cl.Buffer(ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
        runtime.kernel(prg, "uniforms")(ctx.queue, (count,), None, np.uint64(first), np.uint64(seed & (2**64 - 1)),
                     np.uint32(stream), np.uint32(dims), bo)
        cl.enqueue_copy(ctx.queue, out, bo)
    return out


def to_unit_float(bits: np.ndarray, device: object = None) -> np.ndarray:
    """The kernels' uint32 -> float conversion applied to ``bits`` (computed by the kernel).

    ``u = (floor(bits / 2**9) + 1/2) * 2**-23``: never 0 nor 1, unbiased.
    """
    b = np.ascontiguousarray(bits, dtype=np.uint32).ravel()
    ctx, prg = _program(device)
    out = np.empty(b.shape, dtype=np.float32)
    if b.size:
        mf = cl.mem_flags
        bb = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=b)
        bo = cl.Buffer(ctx.context, mf.WRITE_ONLY, out.nbytes)
        runtime.kernel(prg, "unit_floats")(ctx.queue, (b.size,), None, bb, bo)
        cl.enqueue_copy(ctx.queue, out, bo)
    return out.reshape(np.shape(bits))


def sampler_draws(seed: int, first: int, count: int, start: int, stream: int = STREAM_SAMPLE,
                  device: object = None) -> np.ndarray:
    """Dimensions ``start .. start + 5`` of samples ``first ..`` drawn three ways by the kernels' sampler.

    Returns a ``(count, 3, 6)`` float32 array: ``[:, 0]`` by ``sampler_next_1d``, ``[:, 1]`` by
    ``sampler_next_2d`` pairs, ``[:, 2]`` by one ``sampler_next_nd`` (``kernels/samplers/sampler.cl``);
    all three must equal :func:`uniforms` whatever ``start``.
    """
    if count < 0 or start < 0:
        raise InputError(f"rng.sampler_draws: count and start must be >= 0, got {count} and {start}")
    ctx, prg = _program(device)
    out = np.empty((count, 3, 6), dtype=np.float32)
    if count:
        bo = cl.Buffer(ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
        runtime.kernel(prg, "sampler_draws")(ctx.queue, (count,), None, np.uint64(first), np.uint64(seed),
                                             np.uint32(stream), np.uint32(start), bo)
        cl.enqueue_copy(ctx.queue, out, bo)
    return out
