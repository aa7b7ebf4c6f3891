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

The same records serve the shading of a hit (``prim_normal``, ``prim_area``,
``prim_sample_area`` of ``render/intersect.cl``), which need only v0 and the
edges: :func:`device_geometry` gives every triangle the row of its record
(``tri_rows``, after the leaves' first row), appending records for the
triangles the BVH leaves out (degenerate ones), so that the kernels need no
second triangle table (48 bytes a triangle less on the device).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..host_memory import release_free_heap
from ..layouts import BVH_HEADER, LEAF_PRIM
from .bvh import BVH
from .bvh_wide import plan_wide_nodes, write_wide_nodes

LEAF_ROWS = LEAF_PRIM.itemsize // 16  # float4 rows per record
_FILL_CHUNK = 1 << 16  # records per chunk of _fill_leaf_records


def _fill_leaf_records(out: np.ndarray, prims: np.ndarray, tri_vertices: np.ndarray, spheres: np.ndarray) -> None:
    """Write one LEAF_PRIM per entry of ``prims`` into ``out``, float32 (P, 12) (a view of the device table).

    Column blocks of the record: v0 | prim, e1 | pad1, e2 | pad2 (mcocl/layouts.py).
    Chunk by chunk of :data:`_FILL_CHUNK` records: the gathered vertices and
    the edges of 10^6 triangles would be 60 MB of temporaries at once.
    """
    prims = np.asarray(prims)
    for s in range(0, len(prims), _FILL_CHUNK):
        _fill_chunk(out[s:s + _FILL_CHUNK], prims[s:s + _FILL_CHUNK], tri_vertices, spheres)


def _fill_chunk(out: np.ndarray, prims: np.ndarray, tri_vertices: np.ndarray, spheres: np.ndarray) -> None:
    """:func:`_fill_leaf_records` for one chunk of records."""
    prims = np.asarray(prims, np.int64)
    nt = len(tri_vertices)
    out.view(np.uint32)[:, 3] = prims
    tri = prims < nt
    all_tri = bool(tri.all())
    rows = slice(None) if all_tri else tri
    v = np.asarray(tri_vertices, np.float32)[prims if all_tri else prims[tri], :, :3]
    out[rows, 0:3] = v[:, 0]
    out[rows, 4:7] = v[:, 1] - v[:, 0]  # float32 arithmetic: the kernel's own edges, bit for bit
    out[rows, 8:11] = v[:, 2] - v[:, 0]
    out[rows, 7] = 0.0
    out[rows, 11] = 0.0
    if not all_tri:
        c = np.asarray(spheres, np.float32)[prims[~tri] - nt]
        out[~tri, 0:3] = c[:, :3]
        out[~tri, 4:7] = c[:, :3]
        out[~tri, 7] = c[:, 3]  # row 1 is the sphere's (centre, radius) float4
        out[~tri, 8:12] = 0.0


def leaf_records(prims: np.ndarray, tri_vertices: np.ndarray, spheres: np.ndarray) -> np.ndarray:
    """One LEAF_PRIM per entry of ``prims`` (ids: ``p < T`` triangle p, else sphere p − T), as float32 (3P, 4)."""
    out = np.empty((len(prims), LEAF_PRIM.itemsize // 4), np.float32)
    _fill_leaf_records(out, prims, tri_vertices, spheres)
    return out.reshape(-1, 4)


def device_nodes(nodes: np.ndarray, prims: np.ndarray, tri_vertices: np.ndarray, spheres: np.ndarray,
                 extra: np.ndarray | None = None) -> np.ndarray:
    """The float32 (1 + 4K + 3P + 16W + 3E, 4) table the kernels read as ``bvh_nodes``.

    The binary nodes (the packet traversal's), the leaf records, then the
    8-wide nodes of the single-ray traversal (:mod:`mcocl.render.bvh_wide`),
    which start at row ``leaf_row + 3P``, then the records of the E primitive
    ids ``extra`` (those no leaf holds: :func:`device_geometry`).  Each part
    is written in place into the one table (for 10^6 triangles it is about
    110 MB: no concatenated copy).
    """
    return _device_table([nodes], prims, tri_vertices, spheres, extra)


def _device_table(held: list[np.ndarray], prims: np.ndarray, tri_vertices: np.ndarray, spheres: np.ndarray,
                  extra: np.ndarray | None) -> np.ndarray:
    """:func:`device_nodes` of the binary nodes ``held[0]``, which it takes out of ``held`` once they are copied
    into the table (the wide nodes are then written from the table's copy): where ``held`` had the only
    reference, the builder's nodes are freed before the leaf records and the wide nodes are written (for 10^6
    triangles 33 MB less at the peak of :func:`~mcocl.render.compiled.compile_scene`).  An empty BVH's nodes
    stay in ``held``."""
    nodes = np.asarray(held[0], np.float32)
    extra = np.zeros(0, np.int64) if extra is None else np.asarray(extra, np.int64)
    if len(prims) == 0 or len(nodes) == 0:  # no BVH: leaf_row stays 0, the extra records follow the nodes
        return np.concatenate([nodes, leaf_records(extra, tri_vertices, spheres)]) if len(extra) else nodes
    # the wide nodes' layout first (their count sizes the table), their records straight into it: no
    # second copy of them (26 MB for 10^6 triangles) beside the table
    plan = plan_wide_nodes(nodes)
    release_free_heap()  # the plan's freed temporaries (mcocl/host_memory.py)
    leaf_row, p, e = len(nodes), len(prims), len(extra)
    wide_end = leaf_row + LEAF_ROWS * p + (plan.rows if plan is not None else 0)
    out = np.empty((wide_end + LEAF_ROWS * e, 4), np.float32)
    out[:leaf_row] = nodes
    if plan is not None:  # the plan's boxes from the table's rows (the same bytes), not the builder's
        plan.box = out[1:leaf_row].reshape(plan.box.shape)
    held.clear()
    del nodes
    _fill_leaf_records(out[leaf_row:leaf_row + LEAF_ROWS * p].reshape(p, 4 * LEAF_ROWS), prims, tri_vertices, spheres)
    if plan is not None:
        write_wide_nodes(plan, out[leaf_row + LEAF_ROWS * p:wide_end])
        del plan
    if e:
        _fill_leaf_records(out[wide_end:].reshape(e, 4 * LEAF_ROWS), extra, tri_vertices, spheres)
    header = out[:1].view(BVH_HEADER.dtype())[0, 0]
    header["leaf_row"] = leaf_row
    return out


def device_geometry(nodes: np.ndarray, prims: np.ndarray, tri_vertices: np.ndarray,
                    spheres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The ``bvh_nodes`` table (:func:`device_nodes`, with a record for every triangle no leaf holds)
    and ``tri_rows``: uint32 (T,), the row of triangle t's record counted from the header's ``leaf_row``
    (the kernels' ``g->leaves + tri_rows[t]``)."""
    return _device_geometry([nodes], prims, tri_vertices, spheres)


def _device_geometry(held: list[np.ndarray], prims: np.ndarray, tri_vertices: np.ndarray,
                     spheres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`device_geometry` of the nodes ``held[0]``, taken out of ``held`` as :func:`_device_table` does."""
    prims = np.asarray(prims)  # (uint32 ids as they are: an int64 copy would be 8 MB per 10^6 more)
    nt = len(tri_vertices)
    rows = np.zeros(nt, np.uint32)
    placed = np.zeros(nt, bool)
    slots = np.flatnonzero(prims < nt)
    rows[prims[slots]] = LEAF_ROWS * slots
    placed[prims[slots]] = True
    del slots
    extra = np.flatnonzero(~placed)
    del placed
    table = _device_table(held, prims, tri_vertices, spheres, extra)
    leaf_row = int(table[:1].view(BVH_HEADER.dtype())[0, 0]["leaf_row"]) if len(table) else 0
    if len(table) - leaf_row >= 2**32:
        raise InputError(f"the scene's {nt} triangles need more device table rows than the kernels' 32-bit row numbers")
    rows[extra] = len(table) - LEAF_ROWS * len(extra) - leaf_row + LEAF_ROWS * np.arange(len(extra))
    return table, rows


@dataclass(eq=False)
class DeviceBVH:
    """A compiled scene's ``bvh_nodes`` device table and ``tri_rows`` (:func:`device_geometry`), made once, with the
    arrays they were made from.

    ``nodes`` is the binary tree as the scene keeps it: a view of the table's first rows, so that the tree
    exists once (for 10^6 triangles 33 MB less than a copy beside the table); its header's ``leaf_row``
    is the row after the tree, as in the table.
    """

    table: np.ndarray
    tri_rows: np.ndarray
    nodes: np.ndarray
    prims: np.ndarray
    tri_vertices: np.ndarray
    spheres: np.ndarray
    digest: str = ""

    def __post_init__(self) -> None:
        self.digest = self.digest or _source_digest(self.nodes, self.prims, self.tri_vertices, self.spheres)

    def made_from(self, nodes: np.ndarray, prims: np.ndarray, tri_vertices: np.ndarray, spheres: np.ndarray) -> bool:
        """Whether these are the very arrays the tables were made from, holding the same bytes (a scene whose
        arrays were replaced or changed in place needs new tables; the hash costs about 0.1 s for 10^6
        triangles, a fifth of making the tables again)."""
        return (nodes is self.nodes and prims is self.prims and tri_vertices is self.tri_vertices
                and spheres is self.spheres and _source_digest(nodes, prims, tri_vertices, spheres) == self.digest)


def _source_digest(*arrays: np.ndarray) -> str:
    """SHA-256 of the arrays' shapes, types and bytes (read in place: no copy of a C-contiguous array)."""
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype}{a.shape}".encode())
        h.update(a.reshape(-1).view(np.uint8))
    return h.hexdigest()


def adopt_bvh(bvh: BVH, tri_vertices: np.ndarray, spheres: np.ndarray) -> DeviceBVH:
    """:func:`device_geometry` of a builder's :class:`~mcocl.render.bvh.BVH`, whose ``nodes`` become the table's
    first rows: the tree is kept only as a view of the table.

    ``bvh`` gives up its nodes while the table is made: where it held the only reference, the builder's copy
    is freed as soon as the table holds the tree, before the leaf records and the wide nodes are written.
    """
    held = [bvh.nodes]
    bvh.nodes = np.zeros((0, 4), np.float32)  # for the making of the table: the tree is in `held`
    table, rows = _device_geometry(held, bvh.prims, tri_vertices, spheres)
    leaf_row = int(table[:1].view(BVH_HEADER.dtype())[0, 0]["leaf_row"]) if len(table) else 0
    # the table starts with the tree unless the BVH is empty (then its nodes were left in `held`)
    bvh.nodes = np.asarray(held[0], np.float32) if held else table[:leaf_row]
    return DeviceBVH(table, rows, bvh.nodes, bvh.prims, tri_vertices, spheres)


__all__ = ["LEAF_ROWS", "DeviceBVH", "adopt_bvh", "device_geometry", "device_nodes", "leaf_records"]
