"""Vertex normals computed from a mesh's faces, as Mitsuba 3 computes them for a mesh file without any.

Each face adds its unit normal, weighted by its interior angle at the corner, to each of its three
vertices; the sums are normalised (Thürmer and Wüthrich, "Computing vertex normals from polygonal
facets", JGT 3(1), 1998 — the weighting Mitsuba 3.9's ``Mesh::recompute_vertex_normals`` uses).
Degenerate faces (zero area) add nothing; a vertex that no face gives a direction gets (1, 0, 0), as in
Mitsuba.  Mitsuba computes them from the world-space positions (after ``to_world``); so does
:func:`world_space_vertex_normals`, then takes them back to the mesh's frame, where mcocl keeps normals.
"""

from __future__ import annotations

import numpy as np

from ..host_memory import release_free_heap
from . import transform as tf

# Faces per block of angle_weighted_normals: its (block, 3, 3) float64 corners and per-corner temporaries, about
# 6 MB at 2^14 faces (2^16 held 25 MB, 2.05x the file in bench/load_memory.py's xml_xyz load; 2^14, 1.85x).
_FACES = 1 << 14


def _world_corners(vertices: np.ndarray, f: np.ndarray, matrix: np.ndarray | None) -> np.ndarray:
    """The (n, 3, 3) float64 corners of the faces ``f`` (n, 3) int64: ``vertices``' rows, through ``matrix``.

    ``tf.apply_points(matrix, vertices.astype(float64))[f]`` without a float64 table of every vertex (63 MB at
    the 2.6 * 10^6 vertices of bench/load_memory.py's mesh, issue 13): the block's rows are widened and multiplied
    by :func:`transform.rows_times`, whose product gives each row of two or more the same bits whatever rows are
    around it (OpenBLAS's kernel is one fused multiply-add chain per entry; a block here has 3 rows or more),
    then translated as :func:`transform.apply_points` translates them.
    """
    p = np.take(vertices, f, axis=0).astype(np.float64, copy=False)  # gather first: a float32 mesh is widened a block at a time
    if matrix is None:
        return p
    flat = tf.rows_times(p.reshape(-1, 3), matrix[:3, :3].T)
    flat += matrix[:3, 3]
    return flat.reshape(p.shape)


def _face_terms(vertices: np.ndarray, faces: np.ndarray, corners: range,
                matrix: np.ndarray | None = None) -> tuple[np.ndarray, dict]:
    """For the non-degenerate faces of a block (``faces`` (n, 3) over ``vertices``, placed by ``matrix``): their
    vertex indices (m, 3) int64, and for each corner k of ``corners`` and each axis the term it adds to its vertex,
    ``terms[k][axis]`` (the unit face normal's component times the interior angle at k)."""
    f = np.asarray(faces, np.int64)
    p = _world_corners(vertices, f, matrix)  # (n, 3, 3): the corners of each face
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    length = np.linalg.norm(n, axis=1)
    valid = length > 0.0
    n = n[valid] / length[valid, None]
    p, f = p[valid], f[valid]
    terms = {}
    for k in corners:
        a = p[:, (k + 1) % 3] - p[:, k]
        b = p[:, (k + 2) % 3] - p[:, k]
        a /= np.linalg.norm(a, axis=1, keepdims=True)
        b /= np.linalg.norm(b, axis=1, keepdims=True)
        angle = np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1.0, 1.0))
        terms[k] = [n[:, axis] * angle for axis in range(3)]
    return f, terms


def _normalise(out: np.ndarray) -> None:
    """Divide each row of ``out`` by its length in place, a block of rows at a time (a row's numbers are its
    own: the same bits as the whole table's); a zero row becomes (1, 0, 0), as in Mitsuba."""
    for s, e in tf.row_blocks(len(out)):
        rows = out[s:e]
        norm = np.linalg.norm(rows, axis=1)
        bogus = norm == 0.0
        rows[~bogus] /= norm[~bogus, None]
        rows[bogus] = (1.0, 0.0, 0.0)


def angle_weighted_normals(vertices: np.ndarray, faces: np.ndarray, matrix: np.ndarray | None = None) -> np.ndarray:
    """(V, 3) float64 unit vertex normals of the triangles ``faces`` (F, 3) over ``vertices`` (V, 3), placed by
    the affine ``matrix`` when given (the normals of the world-space mesh, in world space).

    A mesh of more than :data:`_FACES` faces is taken a block of faces at a time (a last block of one face
    joins the one before: each face's numbers are then those of the whole table), so that the float64
    corners and their temporaries are a block's, not a dozen tables of every face (1.4 GB for the
    5.2 * 10^6 triangles of a 100 MB PLY, issue 13).  Each corner's terms are summed into their vertices in
    face order over every face, then added to the normals, one corner after the other, as ``np.bincount``
    of every face's terms sums them (np.add.at adds in index order, as bincount does): the same bits.  The
    first corner's sums go straight into the normals (zero plus a sum is that sum); the others' are summed
    one axis at a time into a (V,) table, so that the load holds the normals and one axis's sums, not the
    world-space vertices and three (V, 3) tables (issue 13: 3.55x the file).
    """
    v = np.asarray(vertices)  # widened a block of faces at a time (_world_corners)
    m = None if matrix is None else np.asarray(matrix, np.float64)
    edges = list(range(0, len(faces), _FACES)) + [len(faces)]
    if len(edges) > 2 and edges[-1] - edges[-2] == 1:
        del edges[-2]
    blocks = list(zip(edges[:-1], edges[1:]))
    out = np.zeros((len(v), 3))
    if len(blocks) <= 1:  # one block: every face's terms at once
        f, terms = _face_terms(v, faces, range(3), m)
        for k in range(3):
            for axis in range(3):
                out[:, axis] += np.bincount(f[:, k], weights=terms[k][axis], minlength=len(v))
    else:
        for a, b in blocks:
            f, terms = _face_terms(v, faces[a:b], range(1), m)
            for axis in range(3):
                np.add.at(out[:, axis], f[:, 0], terms[0][axis])
        corner_sum = np.empty(len(v))
        for k in (1, 2):
            for axis in range(3):
                corner_sum[:] = 0.0
                for a, b in blocks:
                    f, terms = _face_terms(v, faces[a:b], range(k, k + 1), m)
                    np.add.at(corner_sum, f[:, k], terms[k][axis])
                out[:, axis] += corner_sum
        del corner_sum
    _normalise(out)
    return out


def world_space_vertex_normals(vertices: np.ndarray, faces: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """The normals :func:`angle_weighted_normals` gives the world-space mesh (``matrix`` applied to
    ``vertices``), expressed in the mesh's frame: Mᵀ n, which mcocl's normal transform M⁻ᵀ maps back to n.

    The world-space normals become the mesh-frame ones in place, a block of rows at a time (each row's product
    is its own, as in :func:`_world_corners`): no second (V, 3) table."""
    m = np.asarray(matrix, np.float64)
    out = angle_weighted_normals(vertices, faces, m)
    for s, e in tf.row_blocks(len(out)):
        out[s:e] = out[s:e] @ m[:3, :3]  # rows n_wᵀ M = (Mᵀ n_w)ᵀ
    release_free_heap()  # the face blocks' freed temporaries (mcocl/host_memory.py): not kept with the scene
    return out


__all__ = ["angle_weighted_normals", "world_space_vertex_normals"]
