"""Per-triangle vertex normals for shading (kernels/render/shading_normal.cl).

A mesh shape whose file gives vertex normals (PLY, serialized) shades with
normals interpolated across each triangle unless its ``face_normals`` is set
(Mitsuba's behaviour).  :func:`vertex_normal_table` lays them out for the
device: three float4 per triangle, in the order of the compiled scene's
``tri_vertices`` (the corners reordered as :func:`~mcocl.render.compiled.compile_scene`
reorders them for a mirroring transform or ``flip_normals``), transformed to
world space by the inverse transpose of the shape's matrix, normalised, and
turned to the face's front side (the side whose normal the triangle's winding
gives, where emission and ``twosided`` look): a corner normal set whose sum
points behind the face is negated.  w = 1 marks a triangle with normals.

Scenes without any such triangle have no table, and their kernels are built
without -DSHADING_NORMALS: they render bit for bit as before.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from . import transform as tf
from .shape_registry import SHAPES

# What the kernels read for vertex_normals when the scene has none (OpenCL has no empty buffers).
VERTEX_NORMALS_ABSENT = {"vertex_normals": np.zeros((1, 4), np.float32)}


_CHUNK = 1 << 15  # triangles per step of vertex_normal_table: its float64 temporaries stay small


def _world_normals(shape) -> np.ndarray:
    """The shape's vertex normals in world space, unit length (zero rows stay zero), float64.

    :data:`_CHUNK` vertices at a time (a last chunk of one row joins the one before: a single row's product
    may round differently, mcocl/render/transform.py's rows_times), so that the float64 temporaries of a big
    mesh are a chunk's, not four tables of every vertex (for 10^6 vertices 24 MB each).
    """
    inv = np.linalg.inv(np.asarray(shape.matrix, np.float64)[:3, :3])
    normals = np.asarray(shape.normals)
    out = np.empty((len(normals), 3), np.float64)
    edges = list(range(0, len(normals), _CHUNK)) + [len(normals)]
    if len(edges) > 2 and edges[-1] - edges[-2] == 1:
        del edges[-2]
    for a, b in zip(edges[:-1], edges[1:]):
        n = tf.rows_times(np.asarray(normals[a:b], np.float64), inv)  # rows times M^-1: (M^-T n) as rows
        # np.linalg.norm(n, axis=1, keepdims=True)'s operations (the squares summed along the row)
        length = np.sqrt(np.add.reduce(n * n, axis=1, keepdims=True))
        unit = length > 0
        np.divide(n, length, out=n, where=unit)
        n[~unit[:, 0]] = 0.0  # +0, as the zeros a division into np.zeros leaves
        out[a:b] = n
    return out


def facing_dot(corner: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Float64 dot product of each triangle's corner-normal sum with its face normal, (n,).

    ``corner`` (n, 3, 3) float64 normals, ``triangles`` (n, 3, 3) float32
    vertices.  The same numbers as
    ``np.einsum("ij,ij->i", corner.sum(axis=1), np.cross(v1 - v0, v2 - v0))``
    in float64, in flat elementwise passes (5x faster): the cross product's
    two rounded products and a difference per component, and the dot
    product's terms summed in einsum's order for three terms, x + z first,
    then y (tests/test_render_shading_normals.py checks both against NumPy's, bit for bit).
    """
    v0 = triangles[:, 0].astype(np.float64)
    e1, e2 = triangles[:, 1] - v0, triangles[:, 2] - v0
    n = [e1[:, a] * e2[:, b] - e1[:, b] * e2[:, a] for a, b in ((1, 2), (2, 0), (0, 1))]
    total = corner[:, 0] + corner[:, 1]
    total += corner[:, 2]
    dot = total[:, 0] * n[0]
    dot += total[:, 2] * n[2]
    dot += total[:, 1] * n[1]
    return dot


def vertex_normal_table(shapes: list, world_triangles: np.ndarray) -> np.ndarray | None:
    """(T, 3, 4) float32 corner normals for the compiled triangles, or None when no shape has any.

    ``shapes`` are the scene's shapes in order; ``world_triangles`` (T, 3, 3)
    the compiled triangles (to orient the normals to each face's front).
    """
    if not any(sh.normals is not None and not SHAPES[sh.kind].sphere for sh in shapes):
        return None
    table = np.zeros((len(world_triangles), 3, 4), np.float32)
    start = 0
    for sh in shapes:
        if SHAPES[sh.kind].sphere:
            continue
        count = len(sh.faces)
        if sh.normals is not None:
            faces = sh.faces
            if tf.is_orientation_reversing(sh.matrix) != sh.flip_normals:
                faces = faces[:, [0, 2, 1]]  # as compiled.py's _shape_triangles
            world = _world_normals(sh)
            # a chunk of triangles at a time: the float64 corners and faces of a big mesh are never all
            # held (each triangle's numbers are the same whatever the chunk)
            for s in range(0, count, _CHUNK):
                rows = slice(start + s, start + min(s + _CHUNK, count))
                corner = np.take(world, faces[s:s + _CHUNK], axis=0)  # (chunk, 3, 3)
                behind = facing_dot(corner, world_triangles[rows]) < 0.0
                corner[behind] *= -1.0
                table[rows, :, :3] = corner
                table[rows, :, 3] = 1.0
        start += count
    return table


def require_face_normals(tables: dict) -> None:
    """Refuse shading normals in bidirectional path tracing (its adjoint corrections are not written yet)."""
    if "vertex_normals" in tables:
        raise InputError("bdpt does not support shading normals yet: set face_normals to true on the meshes with "
                         "vertex normals (JSON \"face_normals\": true, XML <boolean name=\"face_normals\" "
                         "value=\"true\"/>), or render with mis or lt")


def shading_defines(tables: dict) -> list[str]:
    """The build option of a scene with vertex normals (none otherwise)."""
    return ["-DSHADING_NORMALS"] if "vertex_normals" in tables else []


__all__ = ["VERTEX_NORMALS_ABSENT", "facing_dot", "require_face_normals", "shading_defines", "vertex_normal_table"]
