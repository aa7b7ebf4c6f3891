"""Bounding volume hierarchy: two builds vectorised with NumPy, flattened for the kernels.

Default build (``method="ploc"``, :mod:`mcocl.render.bvh_ploc`): the
primitives are clustered bottom-up along their Morton curve (PLOC, Meister &
Bittner 2018) until N / :data:`TOP_CLUSTER` clusters are left; the binned
build below, binning all three axes, then joins those clusters top-down
(where a top-down SAH split beats greedy merging, at 1/32 of its cost), and
the whole binary tree is cut into leaves by an exact bottom-up SAH pass.
10^6 triangles: about 0.6 CPU-seconds against 2.3-3.9 for the binned build
alone, for an SAH cost within 10 % of the binned build along the widest axis
(see bench/bvh_build.py).

Binned build (``method="binned"``; after Wald 2007, "On fast construction
of SAH-based bounding volume hierarchies", and pbrt-v4 §7.3.2): a node is
split along the axis of widest centroid extent (or the best of all three);
its centroids go into ``bins`` equal-width bins (one per primitive for
smaller nodes) and it is split at the bin boundary where the surface-area
heuristic

    cost = C_trav + (A_L·N_L + A_R·N_R) / A_node · C_isect   (C_isect = 1)

is lowest.  A node becomes a leaf when it holds one primitive, when
splitting costs more than intersecting all its primitives (``N·C_isect``,
considered only for ``N <= max_leaf``), or at depth :data:`MAX_DEPTH`; a node
whose centroids all fall in one bin is halved.

No Python loop runs over primitives or nodes: the tree is built one *level*
at a time, every node of the level at once.  The primitives of the nodes
still to split are kept as 1-D arrays grouped into the nodes' contiguous
ranges; per-bin counts are a ``bincount``, per-bin bounds ``minimum.at`` /
``maximum.at`` into a compact table (all nodes' bins end to end), the
prefix/suffix bounds of the bins are segmented scans, and the split is a
stable partition by a segmented prefix sum.  Leaves leave the arrays, so
later levels touch only what is left.  Where its time goes (10^6 triangles,
all axes): the segmented scans over bin tables (~20 %), the ``ufunc.at``
scatters (~15 %), per-level elementwise work (the rest) — every level
touches every primitive.

Flattened layout (``nodes``, float32 (1 + 4·K, 4); ``prims``, uint32):

- ``nodes[0]`` is a header ``(nprims, K, depth, 0)`` as uint bit patterns;
  ``nprims == 0`` means the hierarchy is empty and every ray misses.
- internal node ``k`` (root ``k = 0``, depth-first order, the left child
  right after its parent) occupies rows ``1 + 4k .. 4 + 4k``:
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

from .bvh_ploc import cluster, flatten_tree, join_clusters

MAX_DEPTH = 48  # the traversal stacks (trace_packet.cl PACKET_STACK = 64, bvh.cl BVH_WIDE_STACK = 168) need it
C_TRAV = 1.0  # cost of visiting a node (two box tests) relative to one primitive test
PLOC_RADIUS = 8  # default neighbourhood of the clustering build
TOP_CLUSTER = 32  # clustering stops at N / TOP_CLUSTER clusters; a binned all-axes build joins them


@dataclass
class BVH:
    """A flattened hierarchy and facts about it."""

    nodes: np.ndarray  # float32 (1 + 4K, 4)
    prims: np.ndarray  # uint32 (P,)
    num_nodes: int  # internal nodes K
    num_leaves: int
    depth: int  # deepest internal node (root = 0)
    bounds: np.ndarray  # float32 (2, 3): scene box (zeros when empty)


def _surface_area(lo, hi) -> np.ndarray:
    """Surface areas of boxes given as three arrays of lower and of upper corners (empty boxes give 0)."""
    d = [np.maximum(h - lo_, 0.0) for lo_, h in zip(lo, hi)]
    return 2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0])


def _scene_box(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """``np.stack([lo.min(axis=0), hi.max(axis=0)])`` of (N, 3) corners, a column at a time.

    A reduction over the first axis of an (N, 3) array is tens of times slower
    than one over each column; the two agree except possibly in the sign of a
    zero (which equal zero a min/max keeps depends on the order of
    evaluation), so a column whose extreme is zero is reduced as before.
    """
    box = np.empty((2, 3), lo.dtype)
    for a in range(3):
        box[0, a], box[1, a] = lo[:, a].min(), hi[:, a].max()
        if box[0, a] == 0:
            box[0, a] = lo.min(axis=0)[a]
        if box[1, a] == 0:
            box[1, a] = hi.max(axis=0)[a]
    return box


def _ranges(start: np.ndarray, count: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions covered by the ranges, the range of each position, and each range's offset."""
    offs = np.cumsum(count) - count
    seg = np.repeat(np.arange(len(count)), count)
    pos = start[seg] + (np.arange(int(count.sum())) - offs[seg])
    return pos, seg, offs


def _segmented_scan(x: np.ndarray, seg: np.ndarray, nseg: int, big: float, op: np.ufunc, reverse: bool) -> np.ndarray:
    """Inclusive min/max scan of ``x`` (R,), restarting at every change of ``seg`` (sorted ascending).

    One ``accumulate`` does every segment at once: each segment is lifted by
    a multiple of ``big`` (> twice the range of ``x``, a power of two) so that
    values carried over from earlier segments never win; ``x`` must be
    shifted to be non-negative.  The results feed only cost estimates, so the
    rounding of the lifted float64 values (~1e-10 of the scene size) is harmless.
    """
    rising = (op is np.maximum) != reverse
    off = (seg if rising else (nseg - seg)).astype(np.float64) * big
    if reverse:
        return (op.accumulate((x + off)[::-1]) - off[::-1])[::-1]
    return op.accumulate(x + off) - off


class _Bins:
    """SAH evaluation of the bins of every node of a level along one candidate axis per node."""

    def __init__(self, nbin: np.ndarray, count: np.ndarray, gmin: np.ndarray, big: float) -> None:
        self.nbin, self.count, self.gmin, self.big = nbin, count, gmin, big
        self.s = len(nbin)
        self.base = np.cumsum(nbin) - nbin
        self.tsize = int(nbin.sum())
        self.tseg = np.repeat(np.arange(self.s), nbin)

    def evaluate(self, c: np.ndarray, cmin: np.ndarray, ext: np.ndarray, box: list[np.ndarray]):
        """Best split of each node from per-primitive centroids ``c`` along the axis.

        Returns (cost (A_L·N_L + A_R·N_R, inf if none), last bin of the left side,
        N_L, the bin of every primitive).
        """
        nbin, count, base, tsize, tseg, s = self.nbin, self.count, self.base, self.tsize, self.tseg, self.s
        ext = ext.astype(np.float64)
        scale = np.where(ext > 0, nbin / np.where(ext > 0, ext, 1.0), 0.0).astype(np.float32)
        b = ((c - np.repeat(cmin, count)) * np.repeat(scale, count)).astype(np.int64)
        np.minimum(b, np.repeat(nbin - 1, count), out=b)
        key = b + np.repeat(base, count)
        cnt = np.bincount(key, minlength=tsize)
        # Per-bin boxes, shifted by gmin to be >= 0; an empty bin gets lo = big - 1, hi = 0
        # so that it never wins a min/max scan (its side then has no primitive and no cost).
        pre, suf = [], []
        for a in range(6):
            is_lo = a < 3
            op = np.minimum if is_lo else np.maximum
            t = np.full(tsize, np.inf if is_lo else -np.inf, np.float32)
            op.at(t, key, box[a])
            t = t.astype(np.float64) - self.gmin[a % 3]
            t[~np.isfinite(t)] = self.big - 1 if is_lo else 0.0
            pre.append(_segmented_scan(t, tseg, s, self.big, op, False))
            suf.append(_segmented_scan(t, tseg, s, self.big, op, True))
        del key
        # Split after bin j: left = bins ..j of the node (prefix j), right = j+1.. (suffix j+1).
        cs = np.cumsum(cnt)
        nl = cs - np.repeat((cs - cnt)[base], nbin)
        nl_j = nl[:-1]
        nr_j = np.repeat(count, nbin)[:-1] - nl_j
        area_l = _surface_area([x[:-1] for x in pre[:3]], [x[:-1] for x in pre[3:]])
        area_r = _surface_area([x[1:] for x in suf[:3]], [x[1:] for x in suf[3:]])
        del pre, suf
        cost = np.full(tsize, np.inf)
        cost[:-1] = np.where((tseg[:-1] == tseg[1:]) & (nl_j > 0) & (nr_j > 0), area_l * nl_j + area_r * nr_j, np.inf)
        best_cost = np.minimum.reduceat(cost, base)
        cand = np.where(cost == np.repeat(best_cost, nbin), np.arange(tsize), tsize)
        best_bin = np.minimum.reduceat(cand, base) - base
        best_nl = nl[np.minimum(base + best_bin, tsize - 1)]
        return best_cost, best_bin, best_nl, b


def build_bvh(lo: np.ndarray, hi: np.ndarray, ids: np.ndarray | None = None,
              max_leaf: int = 8, bins: int = 16, traversal_cost: float = C_TRAV,
              all_axes: bool = False, method: str = "ploc", radius: int = PLOC_RADIUS) -> BVH:
    """Build a BVH over primitives with boxes ``[lo, hi]`` (N, 3).

    Args:
        lo, hi: primitive bounds (finite).
        ids: the primitive id stored for each box (default ``arange(N)``).
        max_leaf: leaves are never chosen for more primitives than this
            (except at :data:`MAX_DEPTH` in the binned build).
        bins: centroid bins of a node in the binned build (a node of fewer
            primitives gets one bin per primitive); with ``method="ploc"``,
            in the binned build that joins the last clusters.
        traversal_cost: C_trav of the SAH, relative to one primitive test.
        all_axes: ``method="binned"``: bin all three axes and keep the best
            split (better trees of elongated or flat geometry, about twice
            the build time) instead of only the axis of widest centroid extent.
        method: ``"ploc"`` (default): agglomerative clustering along the
            Morton curve joined by a binned top (see the module docstring),
            4-7x faster than ``"binned"`` on 10^6 triangles; ``"binned"``:
            top-down binned SAH only.  A clustered tree deeper than
            :data:`MAX_DEPTH` (which the kernels' stack cannot hold) is
            rebuilt by the binned build.
        radius: ``method="ploc"``: neighbours searched on either side of a
            cluster (Meister & Bittner's r; 4-32 gave SAH costs within 4 %
            of each other on the bench's meshes, 8 costs half of 16).

    Raises:
        ValueError: an unknown ``method``, or non-finite bounds.
    """
    lo = np.asarray(lo, dtype=np.float32).reshape(-1, 3)
    hi = np.asarray(hi, dtype=np.float32).reshape(-1, 3)
    n = len(lo)
    ids = np.arange(n, dtype=np.uint32) if ids is None else np.asarray(ids, dtype=np.uint32)
    if method not in ("ploc", "binned"):
        raise ValueError(f"build_bvh: unknown method {method!r} (expected 'ploc' or 'binned')")
    if n == 0:
        return BVH(np.zeros((1, 4), np.float32), np.zeros(0, np.uint32), 0, 0, 0, np.zeros((2, 3), np.float32))
    if not (np.isfinite(lo).all() and np.isfinite(hi).all()):
        raise ValueError("build_bvh: primitive bounds must be finite")
    if method == "ploc" and n > 1:
        tree, roots = cluster(lo, hi, radius, stop=n // TOP_CLUSTER if n >= 4 * TOP_CLUSTER else 1)
        if len(roots) > 1:
            box = tree.box[:, roots].T
            top = _build_binned(box[:, :3], box[:, 3:], np.arange(len(roots), dtype=np.uint32), 1, bins,
                                traversal_cost, True)
            if not join_clusters(tree, roots, top.nodes, top.prims):
                tree, roots = cluster(lo, hi, radius)
        bounds = _scene_box(lo, hi)
        # The tree holds the boxes now (its leaves, in curve order): a caller that keeps no reference of
        # its own (compile_scene) has them freed before the flattening's tables exist.
        del lo, hi
        nodes, prims, k, leaves, depth = flatten_tree(tree, ids, max_leaf, traversal_cost)
        if depth <= MAX_DEPTH:
            return BVH(nodes, prims, k, leaves, depth, bounds)
        lo, hi = _tree_input_boxes(tree)
    return _build_binned(lo, hi, ids, max_leaf, bins, traversal_cost, all_axes)


def _tree_input_boxes(tree) -> tuple[np.ndarray, np.ndarray]:
    """The primitive boxes ``lo``, ``hi`` (N, 3) given to :func:`build_bvh`, in their order, from a clustering's leaves."""
    n = len(tree.order)
    lo, hi = np.empty((n, 3), np.float32), np.empty((n, 3), np.float32)
    lo[tree.order], hi[tree.order] = tree.box[:3, :n].T, tree.box[3:, :n].T
    return lo, hi


def _build_binned(lo: np.ndarray, hi: np.ndarray, ids: np.ndarray, max_leaf: int, bins: int,
                  traversal_cost: float, all_axes: bool) -> BVH:
    """The top-down binned-SAH build of :func:`build_bvh` (``method="binned"``; see the module docstring)."""
    n = len(lo)
    gmin = lo.min(axis=0).astype(np.float64)
    span = float((hi.max(axis=0) - gmin).max())
    big = 2.0 ** np.ceil(np.log2(2.0 * span + 1.0))
    # The primitives of the nodes still to split, as separate 1-D arrays (NumPy
    # gathers, scatters and reductions on 1-D arrays are several times faster
    # than on rows of a 2-D array), grouped into the nodes' contiguous ranges.
    # Per-primitive copies of per-node values use np.repeat (a sequential
    # expansion) rather than indexing by node, which is a gather.
    box = [np.ascontiguousarray(lo[:, a]) for a in range(3)] + [np.ascontiguousarray(hi[:, a]) for a in range(3)]
    pid = np.arange(n, dtype=np.int64)
    out = np.empty(n, np.int64)  # final primitive order: leaves write their ranges here

    rec_lo, rec_hi, rec_start, rec_count, rec_leaf, rec_left = [], [], [], [], [], []
    count = np.array([n], np.int64)  # the active nodes of this level, in order
    out_start = np.zeros(1, np.int64)  # where each node's primitives go in `out`
    first_id = 0
    depth = 0
    max_internal_depth = 0
    while len(count):
        s = len(count)
        m = len(pid)
        offs = np.cumsum(count) - count
        nodes = np.arange(s)

        def rep(x, _count=count):
            return np.repeat(x, _count)

        nb_lo = np.stack([np.minimum.reduceat(box[a], offs) for a in range(3)])
        nb_hi = np.stack([np.maximum.reduceat(box[3 + a], offs) for a in range(3)])
        # Candidate axes: the widest extent of the centroids (pbrt-v4 §7.3.2), or all three.
        # (Centroids are kept doubled, lo + hi: the factor 1/2 cancels in the binning.)
        cen = [box[a] + box[3 + a] for a in range(3)]
        c_lo = np.stack([np.minimum.reduceat(cen[a], offs) for a in range(3)])
        c_hi = np.stack([np.maximum.reduceat(cen[a], offs) for a in range(3)])
        nbin = np.minimum(count, bins)
        geo = _Bins(nbin, count, gmin, big)
        if all_axes:
            best_cost = np.full(s, np.inf)
            best_bin = np.zeros(s, np.int64)
            best_nl = np.zeros(s, np.int64)
            best_axis = np.zeros(s, np.int64)
            bs = []
            for a in range(3):
                ca, ba, na, ba_ = geo.evaluate(cen[a], c_lo[a], c_hi[a] - c_lo[a], box)
                better = ca < best_cost
                best_cost = np.where(better, ca, best_cost)
                best_bin = np.where(better, ba, best_bin)
                best_nl = np.where(better, na, best_nl)
                best_axis = np.where(better, a, best_axis)
                bs.append(ba_)
            if s > 1:
                ap = rep(best_axis)
                b = np.where(ap == 0, bs[0], np.where(ap == 1, bs[1], bs[2]))
                del ap
            else:
                b = bs[int(best_axis[0])]
            del bs
        else:
            axis = np.argmax(c_hi - c_lo, axis=0)
            if s > 1:
                ap = rep(axis)
                caxis = np.where(ap == 0, cen[0], np.where(ap == 1, cen[1], cen[2]))
                del ap
            else:
                caxis = cen[int(axis[0])]
            best_cost, best_bin, best_nl, b = geo.evaluate(
                caxis, c_lo[axis, nodes], (c_hi - c_lo)[axis, nodes], box)
            del caxis
        del cen

        area = np.maximum(_surface_area(nb_lo.astype(np.float64), nb_hi.astype(np.float64)), 1e-30)
        split_cost = traversal_cost + best_cost / area
        leaf = (count == 1) | (depth >= MAX_DEPTH) | ((count <= max_leaf) & (count <= split_cost))
        if depth == 0 and n > 1:
            leaf[:] = False  # the root is always internal, so the kernel starts from a node
        # No valid SAH split (all centroids in one bin): halve the node in its current order.
        nosah = ~leaf & ~np.isfinite(best_cost)
        best_nl = np.where(nosah, count // 2, best_nl)
        best_bin = np.where(nosah, -1, best_bin)

        split = ~leaf
        nsplit = int(split.sum())
        next_first = first_id + s
        left_ids = np.full(s, -1, np.int64)
        left_ids[split] = next_first + 2 * np.arange(nsplit)
        rec_lo.append(nb_lo.T)
        rec_hi.append(nb_hi.T)
        rec_start.append(out_start)
        rec_count.append(count)
        rec_leaf.append(leaf)
        rec_left.append(left_ids)
        local = np.arange(m) - rep(offs)
        leaf_p = rep(leaf) if nsplit < s else None
        if leaf_p is not None:  # leaves: their primitives take their final place
            out[(rep(out_start) + local)[leaf_p]] = pid[leaf_p]
        if not nsplit:
            break
        max_internal_depth = depth
        # Stable partition of each split node: left = bins <= best_bin (or the first half),
        # into the compacted arrays of the next level; leaves' primitives go past the end.
        f = b <= rep(best_bin)
        if nosah.any():
            f |= rep(nosah) & (local < rep(best_nl))
        del b
        csf = np.cumsum(f)
        rank_l = csf - f - rep((csf - f)[offs])
        del csf
        sizes = np.where(split, count, 0)
        new_offs = np.cumsum(sizes) - sizes
        newpos = rep(new_offs) + np.where(f, rank_l, rep(best_nl) + local - rank_l)
        del rank_l, f, local
        mk = int(sizes.sum())
        if leaf_p is not None:
            newpos[leaf_p] = mk + np.arange(m - mk)
        pid_new = np.empty(m, np.int64)
        pid_new[newpos] = pid
        pid = pid_new[:mk]
        for a in range(6):
            v = np.empty(m, np.float32)
            v[newpos] = box[a]
            box[a] = v[:mk]
        del newpos
        snl, scn, sos = best_nl[split], count[split], out_start[split]
        count = np.stack([snl, scn - snl], axis=1).ravel()
        out_start = np.stack([sos, sos + snl], axis=1).ravel()
        first_id = next_first
        depth += 1

    prims = ids[out]
    return _flatten(np.concatenate(rec_lo), np.concatenate(rec_hi), np.concatenate(rec_start),
                    np.concatenate(rec_count), np.concatenate(rec_leaf), np.concatenate(rec_left),
                    prims, max_internal_depth, [len(c) for c in rec_count])


def _preorder(internal: np.ndarray, r_left: np.ndarray, level_sizes: list[int]) -> np.ndarray:
    """Depth-first (pre-order) index of every internal record, the left subtree first.

    Nodes stored in this order put a node's left child right after it and
    keep subtrees together, so a ray walking down the tree touches nearby
    memory (the build's breadth-first order scattered each path over the
    whole array: 2-3x slower traversal of large meshes, measured).
    """
    starts = np.cumsum(level_sizes) - np.asarray(level_sizes)
    sub = internal.astype(np.int64)  # internal nodes in each subtree
    levels = []
    for st, sz in zip(starts, level_sizes):
        idx = np.arange(st, st + sz)
        levels.append(idx[internal[idx]])
    for par in reversed(levels):
        sub[par] += sub[r_left[par]] + sub[r_left[par] + 1]
    pre = np.zeros(len(internal), np.int64)
    for par in levels:
        left = r_left[par]
        pre[left] = pre[par] + 1
        pre[left + 1] = pre[par] + 1 + sub[left]
    return pre


def _flatten(r_lo, r_hi, r_start, r_count, r_leaf, r_left, prims, depth, level_sizes) -> BVH:
    """Store each internal node (in depth-first order) as the two boxes and references of its children."""
    internal = ~r_leaf
    k = int(internal.sum())
    node_of = _preorder(internal, r_left, level_sizes) if k else None
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
