"""The BVH's device table: the builder's nodes followed by the leaves' primitives in leaf order.

The builder (:mod:`mcocl.render.bvh`) leaves a leaf as a range of ``prims``,
primitive ids that index the triangle table: every primitive test then
costs a load of the id and a gather of three vertices from wherever the
triangle happens to lie (for 10^6 triangles, a cache miss per test).  The
traversal kernels (``render/bvh.cl``, ``render/trace_packet.cl``) instead read
one :data:`~mcocl.layouts.LEAF_PRIM` per slot of ``prims``, stored in the same
order after the nodes, so that a leaf's primitives are contiguous and the
edges Möller–Trumbore needs are precomputed.  The edges are float32
differences of float32 vertices, exactly what the kernel computed before, so
hits are bit-identical to the indirect layout.

The header's ``leaf_row`` (``nodes[0].w``) is the row of the first record.
"""

from __future__ import annotations

import numpy as np

from ..layouts import BVH_HEADER, LEAF_PRIM
from .bvh_wide import wide_nodes

LEAF_ROWS = LEAF_PRIM.itemsize // 16  # float4 rows per record


def leaf_records(prims: np.ndarray, tri_vertices: np.ndarray, spheres: np.ndarray) -> np.ndarray:
    """One LEAF_PRIM per entry of ``prims`` (ids: ``p < T`` triangle p, else sphere p − T), as float32 (3P, 4)."""
    prims = np.asarray(prims, np.int64)
    nt = len(tri_vertices)
    rec = np.zeros(len(prims), LEAF_PRIM.dtype())
    rec["prim"] = prims.astype(np.uint32)
    tri = prims < nt
    v = np.asarray(tri_vertices, np.float32)[prims[tri], :, :3]
    t = rec[tri]
    t["v0"] = v[:, 0]
    t["e1"] = v[:, 1] - v[:, 0]  # float32 arithmetic: the kernel's own edges, bit for bit
    t["e2"] = v[:, 2] - v[:, 0]
    rec[tri] = t
    if (~tri).any():
        c = np.asarray(spheres, np.float32)[prims[~tri] - nt]
        s = rec[~tri]
        s["v0"] = c[:, :3]
        s["e1"] = c[:, :3]
        s["pad1"] = c[:, 3]  # row 1 is the sphere's (centre, radius) float4
        rec[~tri] = s
    return rec.view(np.float32).reshape(-1, 4)


def device_nodes(nodes: np.ndarray, prims: np.ndarray, tri_vertices: np.ndarray, spheres: np.ndarray) -> np.ndarray:
    """The float32 (1 + 4K + 3P + 8W, 4) table the kernels read as ``bvh_nodes``.

    The binary nodes (the packet traversal's), the leaf records, then the
    4-wide nodes of the single-ray traversal (:mod:`mcocl.render.bvh_wide`),
    which start at row ``leaf_row + 3P``.
    """
    nodes = np.asarray(nodes, np.float32)
    if len(prims) == 0 or len(nodes) == 0:
        return nodes
    out = np.concatenate([nodes, leaf_records(prims, tri_vertices, spheres), wide_nodes(nodes)])
    header = out[:1].view(BVH_HEADER.dtype())[0, 0]
    header["leaf_row"] = len(nodes)
    return out


__all__ = ["LEAF_ROWS", "device_nodes", "leaf_records"]
