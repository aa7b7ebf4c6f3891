"""The BVH's device table: leaf records in leaf order and the 4-wide nodes collapsed from the binary tree."""

from __future__ import annotations

import numpy as np
import pytest

from mcocl.layouts import BVH_HEADER, BVH_WIDE_NODE, LEAF_PRIM
from mcocl.render.bvh import build_bvh
from mcocl.render.bvh_leaves import device_geometry, device_nodes, leaf_records
from mcocl.render.bvh_wide import EMPTY_SLOT, MERGED_LEAF, WIDE_ROWS, WIDTH, wide_nodes


def binary_children(nodes: np.ndarray):
    """(lo, hi, ref, cnt) of every child slot of the binary tree, (K, 2, ...)."""
    f = nodes[1:].reshape(-1, 2, 2, 4)
    u = f.view(np.uint32)
    return f[:, :, 0, :3], f[:, :, 1, :3], u[:, :, 0, 3], u[:, :, 1, 3]


def wide_children(w: np.ndarray):
    """(lo, hi, ref, cnt) of every slot of the wide nodes, (W, WIDTH, ...)."""
    raw = w.reshape(-1, WIDE_ROWS * 4).view(BVH_WIDE_NODE.dtype())[:, 0]
    # each field is stored as two float4 rows: children 0-3 (f_0), then 4-7 (f_4)
    rec = {f: np.concatenate([raw[f"{f}_0"], raw[f"{f}_4"]], 1)
           for f in ("lo_x", "lo_y", "lo_z", "hi_x", "hi_y", "hi_z", "ref", "cnt")}
    lo = np.stack([rec["lo_x"], rec["lo_y"], rec["lo_z"]], -1)
    hi = np.stack([rec["hi_x"], rec["hi_y"], rec["hi_z"]], -1)
    return lo, hi, rec["ref"], rec["cnt"]


@pytest.mark.parametrize("n,max_leaf", [(1, 4), (2, 4), (7, 1), (3000, 4), (3000, 1)])
def test_wide_tree_holds_every_leaf_once_with_the_binary_boxes(n, max_leaf):
    rng = np.random.default_rng(n + max_leaf)
    lo = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
    hi = lo + rng.uniform(0, 0.05, (n, 3)).astype(np.float32)
    b = build_bvh(lo, hi, max_leaf=max_leaf)
    blo, bhi, bref, bcnt = binary_children(b.nodes)
    w = wide_nodes(b.nodes, max_leaf=1)  # no merging: the binary tree's own leaves
    wlo, whi, wref, wcnt = wide_children(w)
    nw = len(wref)
    leaf, inner = (wcnt != 0) & (wcnt != EMPTY_SLOT), wcnt == 0
    # every wide node but the root is the child of exactly one slot; refs stay in range
    assert sorted(wref[inner].tolist()) == list(range(1, nw))
    # the leaves are the binary tree's, each once (a one-primitive tree lists its leaf twice in both)
    want = sorted(zip(bref[bcnt > 0].tolist(), bcnt[bcnt > 0].tolist()))
    got = sorted(zip(wref[leaf].tolist(), wcnt[leaf].tolist()))
    assert got == want
    # a leaf slot's box is that leaf's box in the binary tree
    key = {(r, c): (lo_, hi_) for r, c, lo_, hi_ in zip(bref[bcnt > 0], bcnt[bcnt > 0], blo[bcnt > 0], bhi[bcnt > 0])}
    for r, c, lo_, hi_ in zip(wref[leaf], wcnt[leaf], wlo[leaf], whi[leaf]):
        assert np.array_equal(key[(r, c)][0], lo_) and np.array_equal(key[(r, c)][1], hi_)
    # every wide node has 2 to WIDTH children
    per_node = ((wcnt != EMPTY_SLOT).reshape(nw, WIDTH)).sum(1)
    assert per_node.min() >= 2 and per_node.max() <= WIDTH


@pytest.mark.parametrize("n,max_leaf", [(2, 4), (9, 1), (3000, 1), (3000, 4)])
def test_merged_leaves_cover_every_primitive_once_inside_their_boxes(n, max_leaf):
    rng = np.random.default_rng(7 * n + max_leaf)
    lo = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
    hi = lo + rng.uniform(0, 0.05, (n, 3)).astype(np.float32)
    b = build_bvh(lo, hi, max_leaf=max_leaf)
    wlo, whi, wref, wcnt = wide_children(wide_nodes(b.nodes))
    nw = len(wref)
    leaf, inner = (wcnt != 0) & (wcnt != EMPTY_SLOT), wcnt == 0
    assert sorted(wref[inner].tolist()) == list(range(1, nw))
    _, _, bref, bcnt = binary_children(b.nodes)
    assert nw <= max(1, (bcnt == 0).sum())  # never more nodes than the collapse without merging
    cover = np.zeros(n, int)
    for r, c, lo_, hi_ in zip(wref[leaf], wcnt[leaf], wlo[leaf], whi[leaf]):
        cover[r:r + c] += 1
        # a leaf bigger than the builder's leaves is a merged subtree of at most MERGED_LEAF primitives
        assert c <= max(MERGED_LEAF, bcnt.max())
        p = b.prims[r:r + c]
        assert (lo_ <= lo[p]).all() and (hi[p] <= hi_).all()
    assert (cover == 1).all()


def test_leaf_records_hold_each_slots_vertices_and_edges_bit_for_bit():
    rng = np.random.default_rng(5)
    tv = np.zeros((50, 3, 4), np.float32)
    tv[:, :, :3] = rng.normal(size=(50, 3, 3))
    spheres = np.array([[0.5, -1.0, 2.0, 0.25], [1.0, 2.0, 3.0, 4.0]], np.float32)
    prims = rng.permutation(52).astype(np.uint32)
    rec = leaf_records(prims, tv, spheres).reshape(-1, 12).view(LEAF_PRIM.dtype())[:, 0]
    assert np.array_equal(rec["prim"], prims)
    tri = prims < 50
    v = tv[prims[tri], :, :3]
    assert np.array_equal(rec["v0"][tri], v[:, 0])
    assert np.array_equal(rec["e1"][tri], v[:, 1] - v[:, 0]) and np.array_equal(rec["e2"][tri], v[:, 2] - v[:, 0])
    s = spheres[prims[~tri] - 50]
    assert np.array_equal(rec["e1"][~tri], s[:, :3]) and np.array_equal(rec["pad1"][~tri], s[:, 3])


def test_device_table_layout():
    rng = np.random.default_rng(2)
    tris = rng.normal(size=(200, 3, 3)).astype(np.float32)
    tv = np.zeros((200, 3, 4), np.float32)
    tv[:, :, :3] = tris
    b = build_bvh(tris.min(1), tris.max(1))
    table = device_nodes(b.nodes, b.prims, tv, np.zeros((0, 4), np.float32))
    header = table[:1].view(BVH_HEADER.dtype())[0, 0]
    assert header["leaf_row"] == len(b.nodes) and header["nprims"] == len(b.prims)
    assert np.array_equal(table[:len(b.nodes), :].view(np.uint32)[1:], b.nodes.view(np.uint32)[1:])
    wide_row = len(b.nodes) + 3 * len(b.prims)
    assert np.array_equal(table[wide_row:].view(np.uint32), wide_nodes(b.nodes).view(np.uint32))
    # an empty hierarchy stays the header alone: every ray misses before anything else is read
    empty = build_bvh(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32))
    assert np.array_equal(device_nodes(empty.nodes, empty.prims, tv[:0], np.zeros((0, 4), np.float32)), empty.nodes)


@pytest.mark.parametrize("max_leaf", [1, MERGED_LEAF])
def test_wide_nodes_are_the_same_with_int64_indices(monkeypatch, max_leaf):
    # the collapse indexes in int32 where the slot numbers fit, in int64 beyond: both give the same records
    import mcocl.render.bvh_wide as bw

    rng = np.random.default_rng(5)
    lo = rng.random((3000, 3), dtype=np.float32)
    b = build_bvh(lo, lo + 0.05 * rng.random((3000, 3), dtype=np.float32))
    narrow = wide_nodes(b.nodes, max_leaf)
    assert bw._index_type(len(b.nodes) // 4, np.zeros(1, np.int64)) is np.int32
    assert bw._index_type(2**30, np.zeros(1, np.int64)) is np.int64  # slot 2k no longer fits
    assert bw._index_type(4, np.array([2**31], np.int64)) is np.int64  # nor a leaf start
    monkeypatch.setattr(bw, "_index_type", lambda k, ref: np.int64)
    assert np.array_equal(wide_nodes(b.nodes, max_leaf).view(np.uint32), narrow.view(np.uint32))
    assert bw.plan_wide_nodes(b.nodes, max_leaf).ref.dtype == np.int64


@pytest.mark.parametrize("in_tree", ["some", "none", "empty"])
def test_every_triangle_has_its_record_at_its_row(in_tree):
    """device_geometry: triangle t's record (v0 | t, e1, e2, the float32 edges) lies at leaf_row + tri_rows[t],
    those no leaf holds (left out of the BVH: degenerate) included; with spheres in the leaves, or
    with no tree at all (leaf_row 0: the records follow the header)."""
    rng = np.random.default_rng(5)
    nt = 60
    tv = np.zeros((nt, 3, 4), np.float32)
    tv[:, :, :3] = rng.normal(size=(nt, 3, 3))
    spheres = np.array([[0, 0, 0, 0.5], [1, 2, 3, 0.25]], np.float32)[:0 if in_tree == "empty" else 2]
    kept = np.flatnonzero(rng.random(nt) < 0.8) if in_tree == "some" else np.zeros(0, np.int64)
    ids = np.concatenate([kept, nt + np.arange(len(spheres))]).astype(np.uint32)
    lo = np.concatenate([tv[kept, :, :3].min(1), spheres[:, :3] - spheres[:, 3:]])
    hi = np.concatenate([tv[kept, :, :3].max(1), spheres[:, :3] + spheres[:, 3:]])
    b = build_bvh(lo, hi, ids)
    table, rows = device_geometry(b.nodes, b.prims, tv, spheres)
    assert len(kept) < nt and rows.dtype == np.uint32 and len(rows) == nt
    leaf_row = int(table[:1].view(BVH_HEADER.dtype())[0, 0]["leaf_row"])
    rec = table[leaf_row + rows[:, None] + np.arange(3)]  # (T, 3, 4)
    assert np.array_equal(rec[:, 0, 3].view(np.uint32), np.arange(nt))
    assert np.array_equal(rec[:, 0, :3], tv[:, 0, :3])
    assert np.array_equal(rec[:, 1, :3], tv[:, 1, :3] - tv[:, 0, :3])
    assert np.array_equal(rec[:, 2, :3], tv[:, 2, :3] - tv[:, 0, :3])
    # the tree's own part is device_nodes' table unchanged; the left-out triangles' records follow it
    tree = device_nodes(b.nodes, b.prims, tv, spheres)
    assert np.array_equal(table[:len(tree)].view(np.uint32), tree.view(np.uint32))
    assert len(table) == len(tree) + 3 * (nt - len(kept))


@pytest.mark.parametrize("in_tree", ["all", "none"])
def test_adopt_bvh_frees_the_builders_nodes_and_makes_the_same_table(monkeypatch, in_tree):
    """adopt_bvh: the table and rows of device_geometry, the BVH's nodes replaced by the table's first rows, and the
    builder's own nodes array freed before the leaf records are written (no reference to it is left)."""
    import weakref

    from mcocl.render import bvh_leaves
    from mcocl.render.bvh_leaves import adopt_bvh

    rng = np.random.default_rng(7)
    nt = 300
    tv = rng.normal(size=(nt, 3, 3)).astype(np.float32)
    ids = np.arange(nt if in_tree == "all" else 0, dtype=np.uint32)
    b = build_bvh(tv[ids].min(1), tv[ids].max(1), ids)
    spheres = np.zeros((0, 4), np.float32)
    want_table, want_rows = device_geometry(b.nodes.copy(), b.prims, tv, spheres)
    # the tree as the table's first rows (its header now names the leaf row); an empty BVH keeps its own nodes
    want_nodes = want_table[:len(b.nodes)] if in_tree == "all" else b.nodes.copy()
    builders = weakref.ref(b.nodes)
    alive_at_fill = []
    fill = bvh_leaves._fill_leaf_records

    def watched_fill(*args):
        alive_at_fill.append(builders() is not None)
        fill(*args)

    monkeypatch.setattr(bvh_leaves, "_fill_leaf_records", watched_fill)
    got = adopt_bvh(b, tv, spheres)
    assert np.array_equal(got.table.view(np.uint32), want_table.view(np.uint32))
    assert np.array_equal(got.tri_rows, want_rows)
    assert b.nodes is got.nodes and np.array_equal(got.nodes.view(np.uint32), want_nodes.view(np.uint32))
    if in_tree == "all":  # the tree is the table's first rows: the builder's array is gone
        assert got.nodes.base is got.table and builders() is None and alive_at_fill == [False]
    else:  # an empty BVH keeps its own nodes (the header alone)
        assert builders() is got.nodes


def test_merge_tree_node_ids_are_int32_where_they_fit():
    """cluster's merge tree holds its node ids in int32 below 2^31 nodes (12 bytes a primitive less), int64 above."""
    from mcocl.render import bvh_ploc

    rng = np.random.default_rng(3)
    lo = rng.random((500, 3), dtype=np.float32)
    tree, _ = bvh_ploc.cluster(lo, lo + 0.01)
    assert tree.order.dtype == tree.left.dtype == tree.right.dtype == np.int32
    assert sorted(np.concatenate([tree.left, tree.right])) == list(range(2 * 500 - 2))  # every node but the root once
    assert bvh_ploc._node_type(2**30) is np.int32 and bvh_ploc._node_type(2**30 + 1) is np.int64
