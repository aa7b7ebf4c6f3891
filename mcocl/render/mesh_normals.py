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

from . import transform as tf


def angle_weighted_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(V, 3) float64 unit vertex normals of the triangles ``faces`` (F, 3) over ``vertices`` (V, 3)."""
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64)
    p = v[f]  # (F, 3, 3): the corners of each face
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    length = np.linalg.norm(n, axis=1)
    valid = length > 0.0
    n = n[valid] / length[valid, None]
    p, f = p[valid], f[valid]
    out = np.zeros_like(v)
    for k in range(3):
        a = p[:, (k + 1) % 3] - p[:, k]
        b = p[:, (k + 2) % 3] - p[:, k]
        a /= np.linalg.norm(a, axis=1, keepdims=True)
        b /= np.linalg.norm(b, axis=1, keepdims=True)
        angle = np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1.0, 1.0))
        for axis in range(3):  # bincount: one pass per component, no Python loop over faces
            out[:, axis] += np.bincount(f[:, k], weights=n[:, axis] * angle, minlength=len(v))
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
    return world @ m[:3, :3]  # rows n_wᵀ M = (Mᵀ n_w)ᵀ


__all__ = ["angle_weighted_normals", "world_space_vertex_normals"]
