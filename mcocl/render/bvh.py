"""Bounding volume hierarchy: a binned-SAH build vectorised with NumPy, flattened for the kernels.

Build (after Wald 2007, "On fast construction of SAH-based bounding volume
hierarchies", and pbrt-v4 §7.3): every node tries ``bins`` equal-width
centroid bins on each of the three axes and splits where the surface-area
heuristic

    cost = C_trav + (A_L·N_L + A_R·N_R) / A_node · C_isect

is lowest; a node becomes a leaf when it holds one primitive, when splitting
costs more than intersecting all its primitives (``N·C_isect``, only for
``N <= max_leaf``) or at depth :data:`MAX_DEPTH`.

No Python loop runs over primitives or nodes: the tree is built one *level*
at a time, every node of the level at once.  Three index arrays hold the
primitives sorted by centroid along x, y and z, each partitioned into the
nodes' contiguous ranges; a node's bins are then contiguous runs of those
arrays, so per-bin bounds are ``reduceat`` reductions and per-bin counts a
``bincount``.  After a split the three arrays are partitioned stably (a
segmented prefix sum), which keeps each sorted within every child.

Flattened layout (``nodes``, float32 (1 + 4·K, 4); ``prims``, uint32):

- ``nodes[0]`` is a header ``(nprims, K, depth, 0)`` as uint bit patterns;
  ``nprims == 0`` means the hierarchy is empty and every ray misses.
- internal node ``k`` (root ``k = 0``) occupies rows ``1 + 4k .. 4 + 4k``:
  ``(lo0.xyz, ref0) (hi0.xyz, cnt0) (lo1.xyz, ref1) (hi1.xyz, cnt1)`` — the
  boxes of its two children, stored in the parent so that one fetch tests
  both.  ``cnt == 0``: the child is internal node ``ref``; ``cnt > 0``: the
  child is a leaf holding ``prims[ref : ref + cnt]``.  (``ref``/``cnt`` are
  uint bit patterns in the float ``w`` lanes.)
- ``prims`` holds primitive ids (the ids of :mod:`mcocl.render.compiled`).

A hierarchy over one primitive is a root whose two children are the same leaf.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MAX_DEPTH = 48  # the kernel's traversal stack (bvh.cl BVH_STACK = 64) must exceed this
C_TRAV = 1.0  # cost of visiting a node (two box tests) relative to one primitive test


@dataclass
class BVH:
    """A flattened hierarchy and facts about it."""

    nodes: np.ndarray  # float32 (1 + 4K, 4)
    prims: np.ndarray  # uint32 (P,)
    num_nodes: int  # internal nodes K
    num_leaves: int
    depth: int  # deepest internal node (root = 0)
    bounds: np.ndarray  # float32 (2, 3): scene box (zeros when empty)


def _surface_area(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Surface areas of boxes given as (3, ...) corner arrays (empty boxes give 0)."""
    d = np.maximum(hi - lo, 0.0)
    return 2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0])


def _ranges(start: np.ndarray, count: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions covered by the ranges, the range of each position, and each range's offset."""
    offs = np.cumsum(count) - count
    seg = np.repeat(np.arange(len(count)), count)
    pos = start[seg] + (np.arange(int(count.sum())) - offs[seg])
    return pos, seg, offs


def _segmented_scan(x: np.ndarray, seg: np.ndarray, nseg: int, big: float, op: np.ufunc, reverse: bool) -> np.ndarray:
    """Inclusive min/max scan of ``x`` (3, R), restarting at every change of ``seg`` (sorted ascending).

    One ``accumulate`` does every segment at once: each segment is lifted by
    a multiple of ``big`` (> twice the range of ``x``, a power of two) so that
    values carried over from earlier segments never win; ``x`` must be
    shifted to be non-negative.  The results feed only cost estimates, so the
    rounding of the lifted float64 values (~1e-10 of the scene size) is harmless.
    """
    rising = (op is np.maximum) != reverse
    off = (seg if rising else (nseg - seg)).astype(np.float64) * big
    if reverse:
        return (op.accumulate((x + off)[:, ::-1], axis=1) - off[::-1])[:, ::-1]
    return op.accumulate(x + off, axis=1) - off


def build_bvh(lo: np.ndarray, hi: np.ndarray, ids: np.ndarray | None = None,
              max_leaf: int = 8, bins: int = 16) -> BVH:
    """Build a binned-SAH BVH over primitives with boxes ``[lo, hi]`` (N, 3).

    Args:
        lo, hi: primitive bounds.
        ids: the primitive id stored for each box (default ``arange(N)``).
        max_leaf: leaves are never chosen for more primitives than this
            (except at :data:`MAX_DEPTH`).
        bins: centroid bins per axis.
    """
    lo_t = np.ascontiguousarray(np.asarray(lo, dtype=np.float32).T)  # (3, N): contiguous rows
    hi_t = np.ascontiguousarray(np.asarray(hi, dtype=np.float32).T)
    n = lo_t.shape[1]
    ids = np.arange(n, dtype=np.uint32) if ids is None else np.asarray(ids, dtype=np.uint32)
    if n == 0:
        return BVH(np.zeros((1, 4), np.float32), np.zeros(0, np.uint32), 0, 0, 0, np.zeros((2, 3), np.float32))
    cen = 0.5 * (lo_t + hi_t)
    orders = [np.argsort(cen[a], kind="stable") for a in range(3)]
    is_left = np.zeros(n, dtype=bool)
    gmin = lo_t.min(axis=1).astype(np.float64)[:, None]
    span = float((hi_t.max(axis=1) - gmin[:, 0]).max())
    big = 2.0 ** np.ceil(np.log2(2.0 * span + 1.0))

    # Per-node records, appended level by level (node id = order of appearance).
    rec_lo, rec_hi, rec_start, rec_count, rec_leaf, rec_left = [], [], [], [], [], []
    start = np.zeros(1, np.int64)
    count = np.array([n], np.int64)
    first_id = 0
    depth = 0
    max_internal_depth = 0
    while len(start):
        s = len(start)
        pos, seg, offs = _ranges(start, count)
        m = len(pos)
        p0 = orders[0][pos]
        nlo = np.minimum.reduceat(lo_t[:, p0], offs, axis=1)
        nhi = np.maximum.reduceat(hi_t[:, p0], offs, axis=1)
        clo = np.minimum.reduceat(cen[:, p0], offs, axis=1)
        chi = np.maximum.reduceat(cen[:, p0], offs, axis=1)
        best_cost = np.full(s, np.inf)
        best_axis = np.zeros(s, np.int64)
        best_nl = np.zeros(s, np.int64)
        try_split = count > 1
        for a in range(3):
            pa = orders[a][pos]
            ext = (chi[a] - clo[a]).astype(np.float64)
            scale = np.where(ext > 0, bins / np.where(ext > 0, ext, 1.0), 0.0)
            b = np.minimum((cen[a, pa] - clo[a, seg]) * scale[seg], bins - 1).astype(np.int64)
            key = seg * bins + b  # non-decreasing: positions are sorted by this axis' centroid
            runs = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
            rseg = seg[runs]
            rcnt = np.diff(np.r_[runs, m])
            rlo = np.minimum.reduceat(lo_t[:, pa], runs, axis=1).astype(np.float64) - gmin
            rhi = np.maximum.reduceat(hi_t[:, pa], runs, axis=1).astype(np.float64) - gmin
            # Split after run r: left = runs ..r of the node, right = r+1.. of the node.
            plo = _segmented_scan(rlo, rseg, s, big, np.minimum, False)
            phi = _segmented_scan(rhi, rseg, s, big, np.maximum, False)
            slo = _segmented_scan(rlo, rseg, s, big, np.minimum, True)
            shi = _segmented_scan(rhi, rseg, s, big, np.maximum, True)
            cs = np.cumsum(rcnt)
            seg_first = np.flatnonzero(np.r_[True, rseg[1:] != rseg[:-1]])  # one per node
            nl = cs - (cs - rcnt)[seg_first][rseg]
            cost = np.full(len(runs), np.inf)
            inner = np.flatnonzero(rseg[:-1] == rseg[1:])
            cost[inner] = (_surface_area(plo[:, inner], phi[:, inner]) * nl[inner]
                           + _surface_area(slo[:, inner + 1], shi[:, inner + 1]) * (count[rseg[inner]] - nl[inner]))
            segmin = np.minimum.reduceat(cost, seg_first)
            cand = np.where(cost == segmin[rseg], np.arange(len(runs)), len(runs))
            first = np.minimum.reduceat(cand, seg_first)
            ok = np.isfinite(segmin) & (segmin < best_cost)
            best_cost = np.where(ok, segmin, best_cost)
            best_axis = np.where(ok, a, best_axis)
            best_nl = np.where(ok, nl[np.minimum(first, len(runs) - 1)], best_nl)
        area = np.maximum(_surface_area(nlo.astype(np.float64), nhi.astype(np.float64)), 1e-30)
        split_cost = C_TRAV + best_cost / area
        leaf = ~try_split | (depth >= MAX_DEPTH) | ((count <= max_leaf) & (count <= split_cost))
        if depth == 0 and n > 1:
            leaf[:] = False  # the root is always internal, so the kernel starts from a node
        # No valid SAH split (all centroids in one bin on every axis): halve the range.
        nosah = ~leaf & ~np.isfinite(best_cost)
        best_axis = np.where(nosah, np.argmax(nhi - nlo, axis=0), best_axis)
        best_nl = np.where(nosah, count // 2, best_nl)

        split = ~leaf
        nsplit = int(split.sum())
        next_first = first_id + s
        left_ids = np.full(s, -1, np.int64)
        left_ids[split] = next_first + 2 * np.arange(nsplit)
        rec_lo.append(nlo.T)
        rec_hi.append(nhi.T)
        rec_start.append(start)
        rec_count.append(count)
        rec_leaf.append(leaf)
        rec_left.append(left_ids)
        if not nsplit:
            break
        max_internal_depth = depth
        # Left/right flag of every primitive of a split node, from its chosen axis' order.
        psplit = split[seg]
        local = np.arange(m) - offs[seg]
        for a in range(3):
            sel = psplit & (best_axis[seg] == a)
            is_left[orders[a][pos[sel]]] = local[sel] < best_nl[seg[sel]]
        # Stable partition of the three orders inside each split node (keeps them sorted).
        spos, sseg, slocal = pos[psplit], seg[psplit], local[psplit]
        seg_first = np.r_[True, sseg[1:] != sseg[:-1]]
        for a in range(3):
            pr = orders[a][spos]
            f = is_left[pr]
            cs = np.cumsum(f)
            excl = cs - f
            rank_l = excl - np.maximum.accumulate(np.where(seg_first, excl, 0))
            newpos = start[sseg] + np.where(f, rank_l, best_nl[sseg] + (slocal - rank_l))
            orders[a][newpos] = pr
        sst, scn, snl = start[split], count[split], best_nl[split]
        start = np.stack([sst, sst + snl], axis=1).ravel()
        count = np.stack([snl, scn - snl], axis=1).ravel()
        first_id = next_first
        depth += 1

    prims = ids[orders[0]]
    return _flatten(np.concatenate(rec_lo), np.concatenate(rec_hi), np.concatenate(rec_start),
                    np.concatenate(rec_count), np.concatenate(rec_leaf), np.concatenate(rec_left),
                    prims, max_internal_depth)


def _flatten(r_lo, r_hi, r_start, r_count, r_leaf, r_left, prims, depth) -> BVH:
    """Store each internal node as the two boxes and references of its children."""
    internal = ~r_leaf
    node_of = np.cumsum(internal) - 1  # node index of each internal record
    k = int(internal.sum())
    nodes = np.zeros((1 + 4 * k, 4), np.float32)
    u = nodes.view(np.uint32)
    if k == 0:  # a single primitive: the root is a leaf; both children of a root node point to it
        k = 1
        nodes = np.zeros((5, 4), np.float32)
        u = nodes.view(np.uint32)
        for c in (0, 1):
            nodes[1 + 2 * c, :3], nodes[2 + 2 * c, :3] = r_lo[0], r_hi[0]
            u[1 + 2 * c, 3], u[2 + 2 * c, 3] = 0, 1
        u[0] = (len(prims), 1, 0, 0)
        return BVH(nodes, prims, 1, 1, 0, np.stack([r_lo[0], r_hi[0]]))
    parents = np.flatnonzero(internal)
    rows = 1 + 4 * node_of[parents]
    for c in (0, 1):
        ch = r_left[parents] + c
        nodes[rows + 2 * c, :3] = r_lo[ch]
        nodes[rows + 2 * c + 1, :3] = r_hi[ch]
        ch_leaf = r_leaf[ch]
        u[rows + 2 * c, 3] = np.where(ch_leaf, r_start[ch], node_of[ch]).astype(np.uint32)
        u[rows + 2 * c + 1, 3] = np.where(ch_leaf, r_count[ch], 0).astype(np.uint32)
    node_depth = int(depth)
    u[0] = (len(prims), k, node_depth, 0)
    return BVH(nodes, prims.astype(np.uint32), k, int(r_leaf.sum()), node_depth, np.stack([r_lo[0], r_hi[0]]))


__all__ = ["BVH", "C_TRAV", "MAX_DEPTH", "build_bvh"]
