"""Cast rays through a compiled scene with the kernels' own traversal (``render/raycast.cl``).

For tests (the BVH against brute force), debugging and the traversal
benchmark; the renderer itself calls ``trace_closest``/``trace_any`` inside
its megakernel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyopencl as cl

from ..runtime import DeviceContext, build, compose, device_context, kernel
from .compiled import CompiledScene
from .device_scene import geom_args

MISS = np.uint32(0xFFFFFFFF)
ITEMS = 1024  # work-items per launch; each loops over a strided share of the rays


@dataclass
class RayHits:
    """Closest hits (``t`` = inf and ``prim`` = :data:`MISS` where nothing is hit) and any-hit flags."""

    t: np.ndarray  # float32 (N,)
    prim: np.ndarray  # uint32 (N,)
    b1: np.ndarray  # float32 (N,)
    b2: np.ndarray  # float32 (N,)
    any: np.ndarray  # bool (N,)


def _program(ctx: DeviceContext) -> cl.Program:
    return build(ctx, compose(["render/raycast.cl"]), ["-DLANES=1"], what="raycast kernel")


def _f4(a: np.ndarray) -> np.ndarray:
    out = np.zeros((len(a), 4), np.float32)
    out[:, :3] = a
    return out


def cast_rays(scene: CompiledScene, origins: np.ndarray, directions: np.ndarray, tmax: np.ndarray | float = np.inf,
              device=None, closest: bool = True, any_hit: bool = True) -> RayHits:
    """Trace rays ``origins + t·directions`` (N, 3) with ``0 < t < tmax`` on an OpenCL device."""
    ctx = device if isinstance(device, DeviceContext) else device_context(device)
    n = len(origins)
    prg = _program(ctx)
    mf = cl.mem_flags
    tm = np.ascontiguousarray(np.broadcast_to(np.asarray(tmax, np.float32), (n,)))
    hits = np.zeros((max(n, 1), 4), np.float32)
    anyv = np.zeros(max(n, 1), np.uint32)
    if n:
        bo = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=_f4(origins))
        bd = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=_f4(directions))
        bt = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=tm)
        bh = cl.Buffer(ctx.context, mf.WRITE_ONLY, hits.nbytes)
        ba = cl.Buffer(ctx.context, mf.WRITE_ONLY, anyv.nbytes)
        mode = (1 if closest else 0) | (2 if any_hit else 0)
        items = min(n, ITEMS)
        gsz, lsz = ctx.work_size(items)
        kernel(prg, "raycast")(ctx.queue, gsz, lsz, *geom_args(scene, ctx), bo, bd, bt, bh, ba,
                               np.uint32(n), np.uint32(mode), np.uint32(items))
        cl.enqueue_copy(ctx.queue, hits, bh)
        cl.enqueue_copy(ctx.queue, anyv, ba)
    hits, anyv = hits[:n], anyv[:n]
    return RayHits(hits[:, 0].copy(), hits[:, 1].view(np.uint32).copy(), hits[:, 2].copy(), hits[:, 3].copy(),
                   anyv.astype(bool))


def query_prims(scene: CompiledScene, prims: np.ndarray, points: np.ndarray, u: np.ndarray,
                device=None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Kernel ``prim_normal``/``prim_area``/``prim_sample_area`` for each primitive.

    Returns (normals at ``points``, areas, area samples for ``u`` (N, 2), their normals).
    """
    ctx = device if isinstance(device, DeviceContext) else device_context(device)
    n = len(prims)
    prg = _program(ctx)
    mf = cl.mem_flags
    bp = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(prims, np.uint32))
    bx = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=_f4(points))
    bu = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(u, np.float32))
    na = np.zeros((n, 4), np.float32)
    sp = np.zeros((n, 4), np.float32)
    sn = np.zeros((n, 4), np.float32)
    bna = cl.Buffer(ctx.context, mf.WRITE_ONLY, na.nbytes)
    bsp = cl.Buffer(ctx.context, mf.WRITE_ONLY, sp.nbytes)
    bsn = cl.Buffer(ctx.context, mf.WRITE_ONLY, sn.nbytes)
    gsz, lsz = ctx.work_size(n)
    kernel(prg, "prim_query")(ctx.queue, gsz, lsz, *geom_args(scene, ctx), bp, bx, bu, bna, bsp, bsn, np.uint32(n))
    cl.enqueue_copy(ctx.queue, na, bna)
    cl.enqueue_copy(ctx.queue, sp, bsp)
    cl.enqueue_copy(ctx.queue, sn, bsn)
    return na[:, :3], na[:, 3], sp[:, :3], sn[:, :3]


__all__ = ["MISS", "RayHits", "cast_rays", "query_prims"]
