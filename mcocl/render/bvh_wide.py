"""A 4-wide BVH for single-ray traversal, collapsed from the binary tree of :mod:`mcocl.render.bvh`.

Each wide node is a binary internal node with its children replaced by
their own children where they are internal (Wald et al. 2008, "Getting rid
of packets", and Dammertz et al. 2008, "Shallow bounding volume
hierarchies": a multi-branching BVH whose node test uses the CPU's vector
width); a leaf child stays a leaf.  So a wide node has 2 to 4 children and
the tree is about half as deep: one visit tests four boxes in float4 lanes
(``render/bvh.cl``, ``trace_closest``/``trace_any``) where the binary tree
needed two visits of two scalar tests.  The boxes are the builder's own
(no new rounding), so the box tests give the binary tree's distances.

Record :data:`~mcocl.layouts.BVH_WIDE_NODE` (8 float4, structure of arrays:
``lo_x`` .. ``hi_z`` of the four children, then their ``ref`` and ``cnt``):
``cnt == 0``: wide node ``ref``; :data:`EMPTY_SLOT`: no child; otherwise a leaf
of ``cnt`` primitives whose leaf records start at slot ``ref``
(:mod:`mcocl.render.bvh_leaves`).  Wide node 0 is the root; nodes are listed
level by level.
"""

from __future__ import annotations

import numpy as np

from ..layouts import BVH_WIDE_NODE

EMPTY_SLOT = np.uint32(0xFFFFFFFF)
WIDE_ROWS = BVH_WIDE_NODE.itemsize // 16  # float4 rows per wide node


def wide_nodes(nodes: np.ndarray) -> np.ndarray:
    """The 4-wide nodes of a flattened binary BVH (``nodes`` of :class:`mcocl.render.bvh.BVH`), float32 (8W, 4)."""
    k = (len(nodes) - 1) // 4
    if k == 0:
        return np.zeros((0, 4), np.float32)
    f = np.asarray(nodes, np.float32)[1:1 + 4 * k].reshape(k, 2, 2, 4)
    u = f.view(np.uint32)
    lo, hi = f[:, :, 0, :3], f[:, :, 1, :3]  # (K, 2, 3)
    ref, cnt = u[:, :, 0, 3].astype(np.int64), u[:, :, 1, 3]  # (K, 2)
    # Slots 2c, 2c+1 of binary node j: the children of its child c when c is internal, else c and nothing.
    inner = cnt == 0
    m = np.where(inner, ref, 0)
    s_lo = np.where(inner[:, :, None, None], lo[m], np.stack([lo, np.zeros_like(lo)], 2))  # (K, 2, 2, 3)
    s_hi = np.where(inner[:, :, None, None], hi[m], np.stack([hi, np.zeros_like(hi)], 2))
    s_ref = np.where(inner[:, :, None], ref[m], np.stack([ref, np.zeros_like(ref)], 2))
    s_cnt = np.where(inner[:, :, None], cnt[m], np.stack([cnt, np.full_like(cnt, EMPTY_SLOT)], 2))
    s_lo, s_hi = s_lo.reshape(k, 4, 3), s_hi.reshape(k, 4, 3)
    s_ref, s_cnt = s_ref.reshape(k, 4), s_cnt.reshape(k, 4)
    # The binary nodes that become wide nodes: the root, then every internal slot of a wide node.
    order, frontier = [], np.zeros(1, np.int64)
    while len(frontier):
        order.append(frontier)
        frontier = s_ref[frontier][s_cnt[frontier] == 0]
    order = np.concatenate(order)
    index = np.full(k, -1, np.int64)
    index[order] = np.arange(len(order))
    w_inner = s_cnt[order] == 0
    w_ref = np.where(w_inner, index[np.where(w_inner, s_ref[order], 0)], s_ref[order])
    rec = np.zeros(len(order), BVH_WIDE_NODE.dtype())
    for axis, name in enumerate("xyz"):
        rec[f"lo_{name}"] = s_lo[order, :, axis]
        rec[f"hi_{name}"] = s_hi[order, :, axis]
    rec["ref"] = w_ref.astype(np.uint32)
    rec["cnt"] = s_cnt[order]
    return rec.view(np.float32).reshape(-1, 4)


__all__ = ["EMPTY_SLOT", "WIDE_ROWS", "wide_nodes"]
