"""An 8-wide BVH for single-ray traversal, collapsed from the binary tree of :mod:`mcocl.render.bvh`.

Each wide node is a binary internal node with its children replaced by
their own children where they are internal, and any slot left empty filled
by splitting the internal child of largest surface area (Wald et al. 2008, "Getting rid
of packets", and Dammertz et al. 2008, "Shallow bounding volume
hierarchies": a multi-branching BVH whose node test uses the CPU's vector
width); a leaf child stays a leaf.  So a wide node has 2 to :data:`WIDTH` = 8
children and the tree is about a third as deep: one visit tests eight boxes in
float8 lanes (``render/bvh.cl``, ``trace_closest``/``trace_any``).  On the
10^6-triangle meshes of ``bench/trace_bench.py`` 8 children beat 4 by 5-40 %
(M rays per CPU-second): a node visit there is a cache miss, and a shallower
tree has fewer of them one after another.  The boxes are the builder's own
(no new rounding), so the box tests give the binary tree's distances.
Subtrees of at most :data:`MERGED_LEAF` primitives become one leaf: on a big
mesh a node visit is a cache miss while a leaf's records are one run.

Record :data:`~mcocl.layouts.BVH_WIDE_NODE` (16 float4, structure of arrays:
``lo_x`` .. ``hi_z`` of the eight children, then their ``ref`` and ``cnt``;
each field is two float4 rows, ``f_0`` for children 0-3 and ``f_4`` for 4-7):
``cnt == 0``: wide node ``ref``; :data:`EMPTY_SLOT`: no child; otherwise a leaf
of ``cnt`` primitives whose leaf records start at slot ``ref``
(:mod:`mcocl.render.bvh_leaves`).  Wide node 0 is the root; nodes are listed
in the binary tree's depth-first order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..layouts import BVH_WIDE_NODE

EMPTY_SLOT = np.uint32(0xFFFFFFFF)
WIDE_ROWS = BVH_WIDE_NODE.itemsize // 16  # float4 rows per wide node
WIDTH = 8  # children per wide node: bvh.cl tests them in float8 lanes
_FIELD_AT = {name: BVH_WIDE_NODE.dtype().fields[f"{name}_0"][1] // 4
             for name in ("lo_x", "lo_y", "lo_z", "hi_x", "hi_y", "hi_z", "ref", "cnt")}  # float offset of child 0
assert all(BVH_WIDE_NODE.dtype().fields[f"{name}_4"][1] // 4 == at + 4 for name, at in _FIELD_AT.items())
assert sorted(_FIELD_AT.values()) == list(range(0, BVH_WIDE_NODE.itemsize // 4, WIDTH))
MERGED_LEAF = 4  # subtrees of at most this many primitives become one leaf (bench/trace_bench.py: 4 beat 1 and 8)


def merge_small_subtrees(ref: np.ndarray, cnt: np.ndarray, max_prims: int) -> tuple[np.ndarray, np.ndarray]:
    """Child slots (K, 2) of a binary tree with every subtree of at most ``max_prims`` primitives made one leaf.

    A subtree qualifies when its leaves' ranges are contiguous in ``prims``
    (the builder's depth-first leaves are); its leaf records are then one run,
    so the traversal tests them one after another from one place in memory
    instead of visiting nodes that each cost a cache miss on a big scene.
    """
    k = len(ref)
    levels, frontier = [], np.zeros(1, np.int64)
    while len(frontier):
        levels.append(frontier)
        frontier = ref[frontier][cnt[frontier] == 0]
    first, end, count = np.zeros(k, np.int64), np.zeros(k, np.int64), np.zeros(k, np.int64)
    for nodes in reversed(levels):  # children before parents
        r, c = ref[nodes], cnt[nodes].astype(np.int64)
        inner = c == 0
        m = np.where(inner, r, 0)
        f = np.where(inner, first[m], r)
        e = np.where(inner, end[m], r + c)
        n = np.where(inner, count[m], c)
        # (two children: elementwise, several times faster than reductions over rows of two)
        first[nodes], end[nodes], count[nodes] = np.minimum(f[:, 0], f[:, 1]), np.maximum(e[:, 0], e[:, 1]), n[:, 0] + n[:, 1]
    inner = cnt == 0
    m = np.where(inner, ref, 0)
    small = inner & (count[m] <= max_prims) & (end[m] - first[m] == count[m])
    return np.where(small, first[m], ref), np.where(small, count[m], cnt).astype(np.uint32)


def _wide_slots(nodes: np.ndarray, ref: np.ndarray, inner: np.ndarray, area: np.ndarray) -> np.ndarray:
    """The binary child slots (q = 2j + c, -1: empty) of the wide nodes made from binary nodes ``nodes``, (n, WIDTH).

    A binary node's children are replaced by their own children where they
    are internal; then, while a slot is empty, the internal child of largest
    surface area gives way to its two children (Wald et al. 2008's greedy
    collapse; fewer, fuller wide nodes).  The slots have ``ref``'s integer type.
    """
    two = np.arange(2, dtype=ref.dtype)
    q = 2 * nodes[:, None] + two  # (n, 2)
    kids = 2 * ref[q, None] + two  # (n, 2, 2)
    slots = np.full((len(nodes), WIDTH), -1, ref.dtype)
    slots[:, :4] = np.where(inner[q][..., None], kids, np.stack([q, np.full_like(q, -1)], 2)).reshape(-1, 4)
    for _ in range(WIDTH - 2):
        is_inner = (slots >= 0) & inner[np.maximum(slots, 0)]
        empty = slots < 0
        rows = np.flatnonzero(empty.any(1) & is_inner.any(1))
        if not len(rows):
            break
        a = np.where(is_inner[rows], area[np.maximum(slots[rows], 0)], -1.0)
        pick, hole = a.argmax(1), empty[rows].argmax(1)
        child = ref[slots[rows, pick]]
        slots[rows, pick], slots[rows, hole] = 2 * child, 2 * child + 1
    return slots


def _surface_areas(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Half the surface area of each box (N, 3) in float64, ``ex·ey + ey·ez + ez·ex`` of the float32 extents.

    Axis by axis (the same operations in the same order as on an (N, 3) float64
    extent table, so the same numbers), without that 24-bytes-a-box table.
    """
    ex, ey, ez = ((hi[:, a] - lo[:, a]).astype(np.float64) for a in range(3))
    return ex * ey + ey * ez + ez * ex


def _index_type(k: int, ref: np.ndarray) -> type:
    """int32 when the slot numbers (below 2k) and the refs (binary nodes, leaf starts) fit, else int64:
    the temporaries of the collapse at half the size (about 60 MB less for 10^6 triangles)."""
    top = max(2 * k, int(ref.max(initial=0)) + 1)
    return np.int32 if top < 2**31 else np.int64


@dataclass
class WidePlan:
    """Which binary child fills each slot of each wide node (:func:`plan_wide_nodes`), before any record is written.

    ``box``: the binary child slots' boxes, (2K, 2, 4) rows lo, hi (a view of the binary nodes); ``ref``,
    ``cnt``: each binary child slot's ref and count (small subtrees merged); ``slot``: (W, WIDTH) the binary
    child slot in each wide child slot (0 where empty), ``valid``: not empty, ``internal``: a wide node;
    ``index``: the wide node of each binary node that becomes one.
    """

    box: np.ndarray
    ref: np.ndarray
    cnt: np.ndarray
    slot: np.ndarray
    valid: np.ndarray
    internal: np.ndarray
    index: np.ndarray

    @property
    def rows(self) -> int:
        """The float4 rows of the wide nodes' records (16W)."""
        return len(self.slot) * WIDE_ROWS


def plan_wide_nodes(nodes: np.ndarray, max_leaf: int = MERGED_LEAF) -> WidePlan | None:
    """The layout of the 8-wide nodes of a flattened binary BVH (None when it has no node): see :func:`wide_nodes`.

    The binary boxes are read in place (views of ``nodes``) and the indices are
    int32 where they fit: for 10^6 triangles the plan holds about 20 MB.
    """
    k = (len(nodes) - 1) // 4
    if k == 0:
        return None
    f = np.asarray(nodes, np.float32)[1:1 + 4 * k].reshape(k, 2, 2, 4)
    ref, cnt = merge_small_subtrees(f.view(np.uint32)[:, :, 0, 3].astype(np.int64), f.view(np.uint32)[:, :, 1, 3],
                                    max_leaf)
    # Binary child slot q = 2j + c (child c of binary node j): its box (rows lo, hi), ref and count.
    box = f.reshape(2 * k, 2, 4)
    ref, cnt = ref.reshape(-1).astype(_index_type(k, ref)), cnt.reshape(-1)
    area = _surface_areas(box[:, 0, :3], box[:, 1, :3])
    inner = cnt == 0
    # Only the binary nodes that become wide nodes get slots: the root, then level by level every
    # internal slot of a wide node (a third to a fifth of the binary nodes).
    nodes_of, slots_of, frontier = [], [], np.zeros(1, ref.dtype)
    while len(frontier):
        slots = _wide_slots(frontier, ref, inner, area)
        s_inner = (slots >= 0) & inner[np.maximum(slots, 0)]
        nodes_of.append(frontier)
        slots_of.append(slots)
        frontier = ref[slots[s_inner]]
    del area
    # Listed in the binary tree's depth-first order: a wide node's first internal child follows it and
    # every subtree is one run of memory.
    order = np.concatenate(nodes_of)
    perm = np.argsort(order, kind="stable")
    order, slots = order[perm], np.concatenate(slots_of)[perm]
    del nodes_of, slots_of, perm
    valid = slots >= 0
    sq = np.maximum(slots, 0)
    del slots
    index = np.full(k, -1, ref.dtype)
    index[order] = np.arange(len(order), dtype=ref.dtype)
    return WidePlan(box, ref, cnt, sq, valid, valid & inner[sq], index)


def write_wide_nodes(plan: WidePlan, out: np.ndarray) -> None:
    """Write the records of ``plan``'s wide nodes into ``out``, float32 (``plan.rows``, 4) (every byte of it)."""
    rec = out.reshape(len(plan.slot), BVH_WIDE_NODE.itemsize // 4)
    sq, valid = plan.slot, plan.valid
    # children 0-3 in field name_0, 4-7 in name_4 right after it: each field's eight children are one run of
    # the record, written as such, one field at a time
    for corner, name in ((0, "lo"), (1, "hi")):
        for axis, comp in enumerate("xyz"):
            at = _FIELD_AT[f"{name}_{comp}"]
            rec[:, at:at + WIDTH] = np.where(valid, plan.box[sq, corner, axis], np.float32(0.0))
    sref = plan.ref[sq]
    at = _FIELD_AT["ref"]
    rec.view(np.uint32)[:, at:at + WIDTH] = np.where(plan.internal, plan.index[np.where(plan.internal, sref, 0)],
                                                     sref).astype(np.uint32)
    del sref
    at = _FIELD_AT["cnt"]
    rec.view(np.uint32)[:, at:at + WIDTH] = np.where(valid, plan.cnt[sq], EMPTY_SLOT)


def wide_nodes(nodes: np.ndarray, max_leaf: int = MERGED_LEAF) -> np.ndarray:
    """The 8-wide nodes of a flattened binary BVH (``nodes`` of :class:`mcocl.render.bvh.BVH`), float32 (16W, 4).

    Subtrees of at most ``max_leaf`` primitives become leaves (:func:`merge_small_subtrees`).
    :func:`plan_wide_nodes` then :func:`write_wide_nodes` (into a caller's table: no copy).
    """
    plan = plan_wide_nodes(nodes, max_leaf)
    if plan is None:
        return np.zeros((0, 4), np.float32)
    out = np.empty((plan.rows, 4), np.float32)
    write_wide_nodes(plan, out)
    return out


__all__ = ["EMPTY_SLOT", "MERGED_LEAF", "WIDE_ROWS", "WIDTH", "WidePlan", "merge_small_subtrees", "plan_wide_nodes",
           "wide_nodes", "write_wide_nodes"]
