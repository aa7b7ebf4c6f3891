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

# Faces per block of angle_weighted_normals: its (block, 3, 3) float64 corners and per-corner temporaries.
_FACES = 1 << 16


def _face_terms(v: np.ndarray, faces: np.ndarray, corners: range) -> tuple[np.ndarray, dict]:
    """For the non-degenerate faces of a block (``faces`` (n, 3) over ``v``): their vertex indices (m, 3) int64,
    and for each corner k of ``corners`` and each axis the term it adds to its vertex, ``terms[k][axis]`` (the
    unit face normal's component times the interior angle at k)."""
    f = np.asarray(faces, np.int64)
    p = v[f]  # (n, 3, 3): the corners of each face
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


def angle_weighted_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(V, 3) float64 unit vertex normals of the triangles ``faces`` (F, 3) over ``vertices`` (V, 3).

    A mesh of more than :data:`_FACES` faces is taken a block of faces at a time (a last block of one face
    joins the one before: each face's numbers are then those of the whole table), so that the float64
    corners and their temporaries are a block's, not a dozen tables of every face (1.4 GB for the
    5.2 * 10^6 triangles of a 100 MB PLY, issue 13).  Each corner's terms are summed into their vertices in
    face order over every face, then added to the normals, one corner after the other, as ``np.bincount``
    of every face's terms sums them (np.add.at adds in index order, as bincount does): the same bits.
    """
    v = np.asarray(vertices, np.float64)
    edges = list(range(0, len(faces), _FACES)) + [len(faces)]
    if len(edges) > 2 and edges[-1] - edges[-2] == 1:
        del edges[-2]
    out = np.zeros_like(v)
    if len(edges) <= 2:  # one block: every face's terms at once
        f, terms = _face_terms(v, faces, range(3))
        for k in range(3):
            for axis in range(3):
                out[:, axis] += np.bincount(f[:, k], weights=terms[k][axis], minlength=len(v))
    else:
        corner_sum = np.empty_like(v)
        for k in range(3):
            corner_sum[:] = 0.0
            for a, b in zip(edges[:-1], edges[1:]):
                f, terms = _face_terms(v, faces[a:b], range(k, k + 1))
                for axis in range(3):
                    np.add.at(corner_sum[:, axis], f[:, k], terms[k][axis])
            out += corner_sum
        del corner_sum
    norm = np.linalg.norm(out, axis=1)
    bogus = norm == 0.0
    out[~bogus] /= norm[~bogus, None]
    out[bogus] = (1.0, 0.0, 0.0)
    return out


def world_space_vertex_normals(vertices: np.ndarray, faces: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """The normals :func:`angle_weighted_normals` gives the world-space mesh (``matrix`` applied to
    ``vertices``), expressed in the mesh's frame: Mᵀ n, which mcocl's normal transform M⁻ᵀ maps back to n."""
    m = np.asarray(matrix, np.float64)
    world = angle_weighted_normals(tf.apply_points(m, np.asarray(vertices, np.float64)), faces)
    normals = world @ m[:3, :3]  # rows n_wᵀ M = (Mᵀ n_w)ᵀ
    del world
    release_free_heap()  # the face blocks' freed temporaries (mcocl/host_memory.py): not kept with the scene
    return normals


__all__ = ["angle_weighted_normals", "world_space_vertex_normals"]
