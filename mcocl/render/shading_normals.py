"""Vertex normals for shading (kernels/render/shading_normal.cl).

A mesh shape whose file gives vertex normals (PLY, serialized) shades with
normals interpolated across each triangle unless its ``face_normals`` is set
(Mitsuba's behaviour).  Each vertex normal is transformed to world space by
the inverse transpose of the shape's matrix and normalised; a triangle's
corners, in the order of the compiled scene's ``tri_vertices`` (reordered as
:func:`~mcocl.render.compiled.compile_scene` reorders them for a mirroring
transform or ``flip_normals``), are turned to the face's front side (the
side whose normal the triangle's winding gives, where emission and
``twosided`` look): a triangle whose corner normals' sum points behind the
face takes them negated.

:func:`vertex_normal_table` lays them out for the device as one float32
table of T + V float4 rows: row t < T is triangle t's record, the rows of its
three corners' normals as uint bits in x, y, z and in w +1 (the normals as
they are), -1 (negated) or 0 (the triangle has none: it shades with its face
normal); rows T .. T + V - 1 hold the V vertex normals of the meshes that
have them (xyz, w 0), each once.  That is 16 bytes a triangle and 16 a
vertex, against the 48 a triangle of three corner normals apiece (a
10^6-triangle mesh of 5·10^5 vertices: 24 MB instead of 48), and the same
numbers: a negation is exact, so the kernel's blend of the negated
normals is the negation of its blend (:func:`corner_normals` expands the
table to those corners).

Scenes without any such triangle have no table, and their kernels are built
without -DSHADING_NORMALS: they render bit for bit as before.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..host_memory import release_free_heap
from . import transform as tf
from .shape_registry import SHAPES

# What the kernels read for vertex_normals when the scene has none (OpenCL has no empty buffers).
VERTEX_NORMALS_ABSENT = {"vertex_normals": np.zeros((1, 4), np.float32)}


_CHUNK = 1 << 15  # triangles per step of vertex_normal_table: its float64 temporaries stay small
# The largest float64 table of a mesh's world vertex normals that vertex_normal_table holds (10^6 vertices);
# a bigger mesh's corners are computed again, chunk by chunk.
_WORLD_TABLE_BYTES = 24 << 20


def _unit_world_rows(normals: np.ndarray, inv: np.ndarray) -> np.ndarray:
    """Normals (float64 rows (n, 3)) in world space, unit length (zero rows stay zero): rows times ``inv``, M^-1.

    Each row's numbers are the same whatever rows come with it, given two or more (a single row's product is a
    matrix-vector one, which may round differently: mcocl/render/transform.py's rows_times).
    """
    n = tf.rows_times(normals, inv)  # rows times M^-1: (M^-T n) as rows
    # np.linalg.norm(n, axis=1, keepdims=True)'s operations (the squares summed along the row)
    length = np.sqrt(np.add.reduce(n * n, axis=1, keepdims=True))
    unit = length > 0
    np.divide(n, length, out=n, where=unit)
    n[~unit[:, 0]] = 0.0  # +0, as the zeros a division into np.zeros leaves
    return n


def _inverse_linear(shape) -> np.ndarray:
    """M^-1 of the shape's matrix's linear part, float64 (3, 3)."""
    return np.linalg.inv(np.asarray(shape.matrix, np.float64)[:3, :3])


def _write_world_normals(shape, out: np.ndarray) -> None:
    """Write the shape's vertex normals in world space, unit length (zero rows stay zero), into ``out`` (V, 3).

    :data:`_CHUNK` vertices at a time (a last chunk of one row joins the one before: a single row's product
    may round differently, mcocl/render/transform.py's rows_times), so that the float64 temporaries of a big
    mesh are a chunk's, not four tables of every vertex (for 10^6 vertices 24 MB each).
    """
    inv = _inverse_linear(shape)
    normals = np.asarray(shape.normals)
    edges = list(range(0, len(normals), _CHUNK)) + [len(normals)]
    if len(edges) > 2 and edges[-1] - edges[-2] == 1:
        del edges[-2]
    for a, b in zip(edges[:-1], edges[1:]):
        out[a:b] = _unit_world_rows(np.asarray(normals[a:b], np.float64), inv)


def _world_normals(shape) -> np.ndarray:
    """The shape's vertex normals in world space, unit length (zero rows stay zero), float64 (V, 3)."""
    out = np.empty((len(shape.normals), 3), np.float64)
    _write_world_normals(shape, out)
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
    """The indexed shading-normal table (see the module docstring), float32 (T + V, 4), or None when no shape
    has vertex normals.

    ``shapes`` are the scene's shapes in order; ``world_triangles`` (T, 3, 3)
    the compiled triangles (to orient the normals to each face's front).

    Raises:
        InputError: the table would need row numbers beyond 32 bits.
    """
    with_normals = [sh for sh in shapes if sh.normals is not None and not SHAPES[sh.kind].sphere]
    if not with_normals:
        return None
    nt = len(world_triangles)
    rows_needed = nt + sum(len(sh.normals) for sh in with_normals)
    if rows_needed >= 2**32:
        raise InputError(f"the scene's vertex normals need {rows_needed} table rows, beyond the kernels' 32-bit rows")
    table = np.zeros((rows_needed, 4), np.float32)
    corners = table[:nt].view(np.uint32)
    start, row = 0, nt
    for sh in shapes:
        if SHAPES[sh.kind].sphere:
            continue
        count = len(sh.faces)
        if sh.normals is not None:
            reverse = tf.is_orientation_reversing(sh.matrix) != sh.flip_normals
            nv = len(sh.normals)
            release_free_heap()  # what compiling freed before, not kept resident beside the normals (host_memory.py)
            # The corners' float64 world normals: those of the vertices, taken at the corners, or for a mesh
            # whose float64 vertex normals would exceed _WORLD_TABLE_BYTES, computed again a chunk of triangles
            # at a time, with the same numbers (_unit_world_rows of two rows or more) and no such table (for
            # 10^7 triangles 120 MB at the compile stage's peak, bench/scene_memory.py; 3x the arithmetic).
            # A mesh of one vertex keeps its table: a single row's product may round apart.
            world = _world_normals(sh) if nv == 1 or 24 * nv <= _WORLD_TABLE_BYTES else None
            if world is not None:
                table[row:row + nv, :3] = world  # float64 to float32, once per vertex
            else:
                _write_world_normals(sh, table[row:row + nv, :3])
            inv = _inverse_linear(sh)
            normals = np.asarray(sh.normals)
            for s in range(0, count, _CHUNK):
                faces = sh.faces[s:s + _CHUNK]
                if reverse:
                    faces = faces[:, [0, 2, 1]]  # as compiled.py's _shape_triangles
                rows = slice(start + s, start + s + len(faces))
                if world is None:
                    corner = _unit_world_rows(normals[np.ravel(faces)].astype(np.float64), inv).reshape(-1, 3, 3)
                else:
                    corner = np.take(world, faces, axis=0)  # (chunk, 3, 3)
                behind = facing_dot(corner, world_triangles[rows]) < 0.0
                corners[rows, :3] = faces + row
                table[rows, 3] = np.where(behind, np.float32(-1.0), np.float32(1.0))
            release_free_heap()  # and its chunks' float64 temporaries
            row += nv
        start += count
    return table


def corner_normals(table: np.ndarray | None, num_triangles: int) -> np.ndarray | None:
    """The (T, 3, 4) float32 corner normals an indexed ``table`` of :func:`vertex_normal_table` stands for: each
    triangle's three vertex normals, negated where it is marked so, w = 1 (zeros for a triangle without them).

    The numbers the kernels blend (kernels/render/shading_normal.cl); made on demand, 48 bytes a triangle.
    """
    if table is None:
        return None
    head = table[:num_triangles]
    sign = head[:, 3]
    out = table[head.view(np.uint32)[:, :3]]  # (T, 3, 4): rows of the vertices' normals (w 0)
    out[:, :, :3] *= sign[:, None, None]  # exact: the sign is +-1
    out[sign == 0] = 0.0  # a triangle without normals (its rows point at row 0)
    out[:, :, 3] = np.abs(sign)[:, None]
    return out


def require_face_normals(tables: dict) -> None:
    """Refuse shading normals in bidirectional path tracing (its adjoint corrections are not written yet)."""
    if "vertex_normals" in tables:
        raise InputError("bdpt does not support shading normals yet: set face_normals to true on the meshes with "
                         "vertex normals (JSON \"face_normals\": true, XML <boolean name=\"face_normals\" "
                         "value=\"true\"/>), or render with mis or lt")


def shading_defines(tables: dict) -> list[str]:
    """The build option of a scene with vertex normals (none otherwise)."""
    return ["-DSHADING_NORMALS"] if "vertex_normals" in tables else []


__all__ = ["VERTEX_NORMALS_ABSENT", "corner_normals", "facing_dot", "require_face_normals", "shading_defines", "vertex_normal_table"]
