"""BVH build by locally-ordered agglomerative clustering (PLOC), vectorised with NumPy.

Meister & Bittner 2018, "Parallel Locally-Ordered Clustering for Bounding
Volume Hierarchy Construction" (IEEE TVCG 24(3)):

1. the primitives are sorted along a Morton (Z-order) curve of their
   centroids (63-bit codes, 21 bits per axis, on a cube around the centroids
   so that the curve's cells are cubes);
2. every cluster (at first one primitive) finds its nearest neighbour among
   the ``radius`` clusters on either side in that order, the distance being
   the surface area of the box around both;
3. clusters that are each other's nearest neighbour merge; the merged
   cluster takes the place of the left one and the order is compacted;
   steps 2-3 repeat until one cluster is left.

Each iteration is a handful of whole-array NumPy operations (``radius``
shifted-array box unions, no Python loop over clusters); about 4-5·N cluster
visits in all for N primitives.  Ties are broken by a strict order on pairs
(the distance, then the pair's lower and upper position), so that the
globally closest pair is always mutual: every iteration merges at least one
pair, and the result is deterministic.

Clustering may stop early (``stop`` clusters left); :func:`join_clusters`
then completes the tree with any hierarchy built over those clusters (the
default build joins the last N/32 with a top-down binned SAH build).

The binary tree is then cut into leaves by the surface-area heuristic,
bottom-up and exactly (the cost of a subtree is the lower of making it a
leaf, ``A·N`` for ``N <= max_leaf``, and keeping it internal,
``C_trav·A + cost(left) + cost(right)``; pbrt-v4 §7.3.2's cost model), and
written in the layout of :mod:`mcocl.render.bvh`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..host_memory import release_free_heap

MORTON_BITS = 21  # per axis: 63-bit codes


def _spread_bits(q: np.ndarray) -> np.ndarray:
    """Put bit k of each 21-bit integer at bit 3k (the classic magic-number interleave).

    Works in two uint64 buffers, in place (a big mesh's build touches no other table).
    """
    x = q.astype(np.uint64)
    x &= np.uint64(0x1FFFFF)
    t = np.empty_like(x)
    for shift, mask in ((32, 0x1F00000000FFFF), (16, 0x1F0000FF0000FF), (8, 0x100F00F00F00F00F),
                        (4, 0x10C30C30C30C30C3), (2, 0x1249249249249249)):
        np.left_shift(x, np.uint64(shift), out=t)
        x |= t
        x &= np.uint64(mask)
    return x


def morton_order(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Indices that sort the boxes ``[lo, hi]`` (N, 3) along the Morton curve of their centroids (stable)."""
    # doubled centroids, an axis at a time: the factor 1/2 cancels in the normalisation
    # (the sign of a zero minimum, which may depend on the reduction's order, does not change c - cmin)
    c = [lo[:, a].astype(np.float64) + hi[:, a] for a in range(3)]
    cmin = [float(x.min()) for x in c]
    ext = max(float(x.max()) - m for x, m in zip(c, cmin))
    scale = (2**MORTON_BITS - 1) / ext if ext > 0 else 0.0
    code = None
    for a in range(3):  # quantise in place, then interleave: x at bit 3k + 2, y at 3k + 1, z at 3k
        x = c[a]
        c[a] = None
        x -= cmin[a]
        x *= scale
        np.minimum(x, 2**MORTON_BITS - 1, out=x)
        bits = _spread_bits(x)
        del x
        if a < 2:
            bits <<= np.uint64(2 - a)
        if code is None:
            code = bits
        else:
            code |= bits
    # NumPy's default sort is several times faster than its stable one on 64-bit keys, but may order
    # equal keys differently on another CPU: equal codes are put in index order afterwards.
    order = np.argsort(code)
    sorted_code = code[order]
    same = sorted_code[1:] == sorted_code[:-1]
    if same.any():
        tied = np.zeros(len(code), bool)
        tied[1:] |= same
        tied[:-1] |= same
        at = np.flatnonzero(tied)
        group = np.cumsum(~np.concatenate([[False], same])[at])
        sub = order[at]
        order[at] = sub[np.lexsort((sub, group))]
    return order


@dataclass
class MergeTree:
    """A binary tree from clustering: nodes ``0..N-1`` are the primitives in Morton order, ``N..2N-2`` merges.

    Merge ``N + i`` joins ``left[i]`` and ``right[i]``; merges of one
    iteration are consecutive (``batches``: (first merge, count) per
    iteration), and a merge's children come from earlier iterations.  The root
    is the last merge.
    """

    order: np.ndarray  # int32 (N,): primitive of each leaf node (int64 when 2N-1 node ids do not fit)
    left: np.ndarray  # (N-1,) likewise
    right: np.ndarray  # likewise
    box: np.ndarray  # float32 (6, 2N-1): lo x, y, z, hi x, y, z of every node
    batches: list[tuple[int, int]]


def _area_scale(box: np.ndarray) -> float:
    """A power of two that keeps the clustering's float32 surface areas finite and above underflow.

    1 (no scaling) unless the scene spans more than 2^40 or less than 2^-40.
    """
    span = max(float(box[3 + a].max()) - float(box[a].min()) for a in range(3))
    if span == 0.0 or 2.0**-40 <= span <= 2.0**40:
        return 1.0
    return 2.0 ** -np.ceil(np.log2(span))


_BLOCK = 65536  # positions per block of the neighbour search: its temporaries stay in the CPU's cache


def _nearest(box: np.ndarray, r: int, rank_bits: int) -> np.ndarray:
    """For every cluster, a key whose low ``rank_bits`` bits say which neighbour is the nearest.

    ``box`` (6, c): the clusters' boxes in curve order.  The key of a
    candidate is the float32 bit pattern of the distance (non-negative, so
    its bits order like its value) with the low bits replaced by the
    candidate's rank (offsets -r..-1 are ranks 0..r-1, +1..+r are r..2r-1);
    the smallest key is the nearest candidate, ties going to the lowest rank.
    The lost low bits of the distance (a relative 2^-19) only widen ties.
    """
    c = box.shape[1]
    best = np.full(c, 0xFFFFFFFF, np.uint32)
    mask = np.uint32((0xFFFFFFFF >> rank_bits) << rank_bits)
    ext = np.empty((3, min(c, _BLOCK + r)), np.float32)
    tmp = np.empty(ext.shape[1], np.float32)
    for s0 in range(0, c, _BLOCK):
        s1 = min(c, s0 + _BLOCK)
        b = box[:, s0:min(c, s1 + r)]
        w = b.shape[1]
        for k in range(1, r + 1):  # pairs (i, i + k), i = s0 .. s0 + m - 1
            m = w - k
            e, t = ext[:, :m], tmp[:m]
            for a in range(3):
                np.maximum(b[3 + a, k:], b[3 + a, :m], out=e[a])
                np.minimum(b[a, k:], b[a, :m], out=t)
                e[a] -= t
            np.add(e[1], e[2], out=t)  # half the surface area: x (y + z) + y z
            t *= e[0]
            e[1] *= e[2]
            t += e[1]
            key = t.view(np.uint32)
            key &= mask
            mr = min(m, s1 - s0)
            np.minimum(best[s0:s0 + mr], key[:mr] | np.uint32(r + k - 1), out=best[s0:s0 + mr])
            np.minimum(best[s0 + k:s0 + k + m], key | np.uint32(r - k), out=best[s0 + k:s0 + k + m])
    return best


def _leaf_boxes(leaf_box: np.ndarray, lo: np.ndarray, hi: np.ndarray, order: np.ndarray) -> None:
    """Write the boxes ``[lo, hi]`` (N, 3) in the order ``order`` into ``leaf_box`` (6, N), an axis at a time."""
    for a in range(3):
        leaf_box[a], leaf_box[3 + a] = lo[:, a].take(order), hi[:, a].take(order)


def _node_type(n: int) -> type:
    """The integer type of the node ids of a tree of ``n`` primitives (2n - 1 nodes): int32 where they fit."""
    return np.int32 if 2 * n - 1 < 2**31 else np.int64


def cluster(lo: np.ndarray, hi: np.ndarray, radius: int = 8, stop: int = 1) -> tuple[MergeTree, np.ndarray]:
    """Agglomerative clustering of the boxes ``[lo, hi]`` (N >= 2, float32) into a :class:`MergeTree`.

    Merging stops once at most ``stop`` clusters are left; returns the tree
    (complete only when one cluster is left) and the node ids of the clusters left, in curve order.
    """
    n = len(lo)
    # Node ids in int32 where all 2N - 1 fit: the same numbers in half the memory (the tree's order, left and
    # right: 20 MB less for 10^6 primitives through the rest of the build, whose peak is flatten_tree's).
    itype = _node_type(n)
    order = morton_order(lo, hi).astype(itype)
    # Every node's box in one table (the tree's), leaves first: the merges are written into it as they
    # happen, with no concatenated copy of the two halves at the end (issue 13: memory of big meshes).
    node_box = np.empty((6, 2 * n - 1), np.float32)
    leaf_box = node_box[:, :n]  # (6, N)
    _leaf_boxes(leaf_box, lo, hi, order)
    scale = _area_scale(leaf_box)
    # Clusters in curve order: their boxes (scaled by a power of two if needed) and node ids.  The boxes
    # live in the first columns of a (6, N) table, compacted in place as clusters merge (a compacted
    # copy per iteration would hold two such tables at the start).  Unscaled, that table is the tree's
    # own leaf boxes, written again from lo and hi at the end (no working copy of them).
    work = leaf_box * np.float32(scale) if scale != 1.0 else leaf_box
    box = work
    row = np.empty(n, np.float32)
    ids = np.arange(n, dtype=itype)
    left = np.empty(n - 1, itype)
    right = np.empty(n - 1, itype)
    merged = node_box[:, n:]
    rank_bits = int(np.ceil(np.log2(2 * radius)))
    batches: list[tuple[int, int]] = []
    done = 0
    while len(ids) > max(stop, 1):
        c = len(ids)
        r = min(radius, c - 1)
        rank = _nearest(box, r, rank_bits) & np.uint32((1 << rank_bits) - 1)
        # Mutual pairs (i < j = i + k): i's nearest is its k-th right neighbour, j's is its k-th left one.
        # (np.compress and take: boolean and fancy indexing are several times slower on such masks.)
        i = np.flatnonzero(rank >= r)
        k = rank.take(i).astype(np.int64) - (r - 1)
        j = i + k
        mutual = rank.take(j) == r - k
        i, j = np.compress(mutual, i), np.compress(mutual, j)
        nm = len(i)
        if nm == 0:  # impossible for finite distances (see the module docstring)
            raise RuntimeError("BVH clustering made no progress (non-finite primitive bounds?)")
        left[done:done + nm] = ids.take(i)
        right[done:done + nm] = ids.take(j)
        # the merged boxes, a coordinate at a time, straight into the tree's table (no (6, nm) copies;
        # mode "clip": the positions are valid, and "raise" would gather into a temporary first)
        for a in range(6):
            into, other = merged[a, done:done + nm], row[:nm]
            np.take(box[a], i, out=into, mode="clip")
            np.take(box[a], j, out=other, mode="clip")
            (np.minimum if a < 3 else np.maximum)(into, other, out=into)
            box[a, i] = into
        ids[i] = n + done + np.arange(nm)
        keep = np.ones(c, bool)
        keep[j] = False
        ids = np.compress(keep, ids)
        for a in range(6):
            np.compress(keep, box[a], out=row[:c - nm])
            work[a, :c - nm] = row[:c - nm]
        box = work[:, :c - nm]
        batches.append((done, nm))
        done += nm
    if scale == 1.0:
        _leaf_boxes(leaf_box, lo, hi, order)
    else:  # the scaled boxes may have lost bits: take the unions of the exact leaf boxes instead
        for first, count in batches:
            lc, rc = left[first:first + count], right[first:first + count]
            p = slice(n + first, n + first + count)
            node_box[:3, p] = np.minimum(node_box[:3, lc], node_box[:3, rc])
            node_box[3:, p] = np.maximum(node_box[3:, lc], node_box[3:, rc])
    return MergeTree(order, left, right, node_box, batches), ids


def join_clusters(tree: MergeTree, roots: np.ndarray, nodes: np.ndarray, prims: np.ndarray) -> bool:
    """Complete ``tree`` with a hierarchy over its clusters ``roots`` (flattened as in :mod:`mcocl.render.bvh`).

    Each internal node of the hierarchy becomes a merge; each of its leaves
    must hold one cluster (returns False, leaving ``tree`` as it was, if not).
    Merges are added one depth level at a time, the deepest first, so that
    children still come before their parents.
    """
    u = nodes.view(np.uint32)[1:, 3].reshape(-1, 2, 2)
    ref, cnt = u[:, :, 0].astype(np.int64), u[:, :, 1].astype(np.int64)
    if np.any(cnt > 1):
        return False
    k = len(ref)
    n = len(tree.order)
    done = tree.batches[-1][0] + tree.batches[-1][1] if tree.batches else 0
    level = [np.zeros(1, np.int64)]  # internal nodes by depth
    while True:
        inner = ref[level[-1]][cnt[level[-1]] == 0]
        if not len(inner):
            break
        level.append(inner)
    merge_id = np.empty(k, np.int64)
    for lv in reversed(level):
        merge_id[lv] = n + done + np.arange(len(lv))
        r, leaf = ref[lv], cnt[lv] == 1
        child = np.empty_like(r)
        child[leaf] = roots[prims[r[leaf]].astype(np.int64)]
        child[~leaf] = merge_id[r[~leaf]]
        tree.left[done:done + len(lv)] = child[:, 0]
        tree.right[done:done + len(lv)] = child[:, 1]
        for a in range(6):
            op = np.minimum if a < 3 else np.maximum
            tree.box[a, n + done + np.arange(len(lv))] = op(tree.box[a, child[:, 0]], tree.box[a, child[:, 1]])
        tree.batches.append((done, len(lv)))
        done += len(lv)
    return True


_AREA_CHUNK = 1 << 16  # nodes per step of flatten_tree's float64 areas


def flatten_tree(tree: MergeTree, ids: np.ndarray, max_leaf: int, traversal_cost: float):
    """Cut ``tree`` into SAH-optimal leaves and write it in the node layout of :mod:`mcocl.render.bvh`.

    Returns (nodes, prims, internal nodes K, leaves, depth of the deepest internal node).
    """
    n = len(tree.order)
    left, right, box = tree.left, tree.right, tree.box
    total = 2 * n - 1
    # Per-node tables in int32 where every position fits, and the float64 areas a chunk at a time:
    # the same numbers in about half the memory of a big mesh's build (issue 13).  Each table is
    # dropped once its pass is done: on this machine a page the process touches for the first time
    # costs about as much as 4 KB of NumPy work, so the build's peak memory is also its time.
    itype = _node_type(n)
    # Between the passes the freed tables go back to the system (mcocl/host_memory.py): glibc would otherwise
    # keep the clustering's and each pass's freed memory resident under the next pass's tables, so that the
    # process's peak here was about 35 MB over what the arrays hold for 10^6 primitives (the compile stage's
    # peak, bench/scene_memory.py), at no measurable cost in time.
    release_free_heap()
    area = np.empty(total)  # half areas: only ratios matter
    for s in range(0, total, _AREA_CHUNK):
        ext = box[3:, s:s + _AREA_CHUNK].astype(np.float64) - box[:3, s:s + _AREA_CHUNK]
        area[s:s + _AREA_CHUNK] = ext[0] * ext[1] + ext[1] * ext[2] + ext[2] * ext[0]
    count = np.ones(total, itype)
    cost = area.copy()  # a primitive alone: A · 1
    is_leaf = np.ones(total, bool)  # the subtree is one leaf
    n_int = np.zeros(total, itype)  # internal nodes of the subtree once cut
    for first, num in tree.batches:  # bottom-up: children come from earlier iterations
        p = slice(n + first, n + first + num)
        lc, rc = left[first:first + num], right[first:first + num]
        cnt = count[lc] + count[rc]
        count[p] = cnt
        c_int = traversal_cost * area[p] + cost[lc] + cost[rc]
        c_leaf = np.where(cnt <= max_leaf, area[p] * cnt, np.inf)
        leaf = c_leaf <= c_int
        cost[p] = np.where(leaf, c_leaf, c_int)
        is_leaf[p] = leaf
        n_int[p] = np.where(leaf, 0, 1 + n_int[lc] + n_int[rc])
    del area, cost
    release_free_heap()
    root = total - 1
    if is_leaf[root]:  # the root is always internal, so the kernel starts from a node
        is_leaf[root] = False
        n_int[root] = 1 + n_int[left[-1]] + n_int[right[-1]]
    # Top-down: first primitive position of every node (in-order: a subtree's primitives are contiguous),
    # depth-first index and depth of the internal nodes of the cut tree (left child right after its parent).
    start = np.zeros(total, itype)
    pre = np.zeros(total, itype)
    depth = np.zeros(total, itype)
    internal = np.zeros(total, bool)  # an internal node of the cut tree
    internal[root] = True
    for first, num in reversed(tree.batches):
        p = slice(n + first, n + first + num)
        lc, rc = left[first:first + num], right[first:first + num]
        start[lc] = start[p]
        start[rc] = start[p] + count[lc]
        inn = internal[p]
        if not inn.any():
            continue
        il, ir, ip = lc[inn], rc[inn], np.arange(n + first, n + first + num)[inn]
        internal[il] = ~is_leaf[il]
        internal[ir] = ~is_leaf[ir]
        pre[il] = pre[ip] + 1
        pre[ir] = pre[ip] + 1 + n_int[il]
        depth[il] = depth[ip] + 1
        depth[ir] = depth[ip] + 1
    del n_int
    release_free_heap()
    out = np.empty(n, np.int64)
    out[start[:n]] = tree.order
    prims = ids[out].astype(np.uint32)
    del out
    nodes_by_pre = np.flatnonzero(internal)
    del internal
    k = len(nodes_by_pre)
    max_depth = int(depth.take(nodes_by_pre).max())
    del depth
    par = np.empty(k, itype)
    par[pre[nodes_by_pre]] = nodes_by_pre  # the internal nodes in depth-first order (pre: a permutation of 0..k-1)
    del nodes_by_pre
    par -= n  # merge i is node n + i
    # Each internal node's two children, their refs and counts, before the nodes exist: the per-node tables
    # (count, start, pre: 23 MB for 10^6 primitives) are then dropped, and the peak of the build, which is
    # here, holds k-long columns instead (about 12 MB).
    child = [side.take(par) for side in (left, right)]
    del par
    child_leaf = [is_leaf.take(ch) for ch in child]
    del is_leaf
    child_ref = [np.where(lf, start.take(ch), pre.take(ch)) for ch, lf in zip(child, child_leaf)]
    del start, pre
    child_cnt = [np.where(lf, count.take(ch), 0) for ch, lf in zip(child, child_leaf)]
    del count
    num_leaves = int(child_leaf[0].sum()) + int(child_leaf[1].sum())
    del child_leaf
    release_free_heap()
    # Row block of node q: (lo0, ref0) (hi0, cnt0) (lo1, ref1) (hi1, cnt1), written a column at a time
    # straight into the nodes (a staging table in column order would be one more table of the nodes' size).
    nodes = np.empty((1 + 4 * k, 4), np.float32)
    cols = nodes[1:].reshape(k, 2, 2, 4)
    ucols = cols.view(np.uint32)
    for c in range(2):
        for a in range(6):
            cols[:, c, a // 3, a % 3] = box[a].take(child[c])
        ucols[:, c, 0, 3] = child_ref[c]
        ucols[:, c, 1, 3] = child_cnt[c]
    nodes[0] = 0.0
    nodes.view(np.uint32)[0] = (n, k, max_depth, 0)
    return nodes, prims, k, num_leaves, max_depth


__all__ = ["MergeTree", "cluster", "flatten_tree", "join_clusters", "morton_order"]
