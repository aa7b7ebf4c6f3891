"""Shape geometry in local coordinates: rectangle, cube, disk, cylinder, sphere, triangle meshes, OBJ and PLY files.

Every triangle is counter-clockwise seen from its front side, so the front
normal is ``normalize(cross(v1 - v0, v2 - v0))`` (the convention of
:mod:`mcocl.render.compiled`).  The canonical shapes are Mitsuba 3's:

- ``rectangle``: the square [-1, 1]² in the z = 0 plane, normal +z, two triangles;
- ``cube``: [-1, 1]³, outward normals, twelve triangles;
- ``disk``: the unit disk in the z = 0 plane, normal +z, a fan of :data:`SEGMENTS` triangles;
- ``cylinder``: radius 1 about the z axis from z = 0 to z = 1, open ends, outward
  normals, :data:`SEGMENTS` quads of two triangles each;
- ``sphere``: an analytic primitive (``center``, ``radius``), outward normal.

The disk and the cylinder are tessellated because every primitive but the
sphere is a triangle: their polygons are inscribed in the circles, so the
disk's area is (N/2)·sin(2π/N) ≈ π(1 − (2π/N)²/6) and the cylinder's
2N·sin(π/N) ≈ 2π(1 − (π/N)²/6) for N segments (N = 128: 4.0e-4 and 1.0e-4 relative).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..datafile import open_regular_file
from ..errors import InputError
from ..host_memory import release_free_heap
from .obj_reader import parse_obj
from .ply_reader import PlyMesh, parse_ply
from .serialized_reader import SerializedMesh, parse_serialized

SEGMENTS = 128  # segments of the disk's and the cylinder's circles


def rectangle() -> tuple[np.ndarray, np.ndarray]:
    """Vertices (4, 3) and faces (2, 3) of the square [-1, 1]² at z = 0 facing +z."""
    v = np.array([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]])
    f = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int64)
    return v, f


def cube() -> tuple[np.ndarray, np.ndarray]:
    """Vertices (24, 3) and faces (12, 3) of the cube [-1, 1]³ with outward normals.

    Each face is a rectangle of its own four vertices (no shared vertices
    between faces), built by rotating the +z face of :func:`rectangle`.
    """
    rv, rf = rectangle()
    # Orthonormal frames (u, v, n) with u × v = n for the six outward normals.
    frames = [
        ((1, 0, 0), (0, 1, 0), (0, 0, 1)),
        ((-1, 0, 0), (0, 1, 0), (0, 0, -1)),
        ((0, 0, -1), (0, 1, 0), (1, 0, 0)),
        ((0, 0, 1), (0, 1, 0), (-1, 0, 0)),
        ((1, 0, 0), (0, 0, -1), (0, 1, 0)),
        ((1, 0, 0), (0, 0, 1), (0, -1, 0)),
    ]
    verts, faces = [], []
    for k, (u, v, n) in enumerate(frames):
        basis = np.array([u, v, n], dtype=np.float64)  # rows: images of x, y, z
        verts.append(rv[:, :2] @ basis[:2] + basis[2])
        faces.append(rf + 4 * k)
    return np.concatenate(verts), np.concatenate(faces)


def _circle(segments: int) -> np.ndarray:
    """Points (N, 3) of the unit circle at z = 0, counter-clockwise from (1, 0, 0)."""
    a = 2.0 * np.pi * np.arange(segments) / segments
    return np.stack([np.cos(a), np.sin(a), np.zeros(segments)], axis=1)


def disk(segments: int = SEGMENTS) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (N + 1, 3) and faces (N, 3) of the unit disk at z = 0 facing +z: a fan about the centre."""
    v = np.concatenate([np.zeros((1, 3)), _circle(segments)])
    i = np.arange(segments)
    return v, np.stack([np.zeros(segments, np.int64), 1 + i, 1 + (i + 1) % segments], axis=1)


def cylinder(segments: int = SEGMENTS) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (2N, 3) and faces (2N, 3) of the open cylinder of radius 1, z in [0, 1], normals outward.

    Bottom ring vertices 0..N-1, top ring N..2N-1; the quad between angles
    i and i + 1 is (b_i, b_i+1, t_i+1) and (b_i, t_i+1, t_i), counter-clockwise seen from outside.
    """
    ring = _circle(segments)
    v = np.concatenate([ring, ring + [0.0, 0.0, 1.0]])
    i = np.arange(segments)
    j = (i + 1) % segments
    f = np.concatenate([np.stack([i, j, segments + j], axis=1), np.stack([i, segments + j, segments + i], axis=1)])
    return v, f.astype(np.int64)


def all_finite(a: np.ndarray) -> bool:
    """Whether every number of ``a`` is finite, from its least and greatest (a NaN makes both NaN, an
    infinity is one of them): no temporary array of ``a``'s size (issue 13: a load's peak memory)."""
    return a.size == 0 or bool(np.isfinite(a.min()) and np.isfinite(a.max()))


def check_mesh(vertices: np.ndarray, faces: np.ndarray, where: str) -> None:
    """Reject non-finite vertices and out-of-range face indices, naming ``where``."""
    if vertices.ndim != 2 or vertices.shape[1] != 3:
        raise InputError(f"{where}: vertices must be a list of [x, y, z] triples")
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise InputError(f"{where}: faces must be a list of [i, j, k] index triples")
    if not all_finite(vertices):
        raise InputError(f"{where}: vertices contain a non-finite number")
    if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
        bad = int(faces.min()) if faces.min() < 0 else int(faces.max())
        raise InputError(f"{where}: face index {bad} is outside 0..{len(vertices) - 1}")


def read_obj(path: Path, where: str) -> PlyMesh:
    """Vertices, triangles and any per-vertex normals and UVs of a Wavefront OBJ file.

    Reads ``v``, ``vt``, ``vn`` and ``f`` records (``f`` corners ``i``,
    ``i/t``, ``i//n`` or ``i/t/n``, negative indices counting back from the
    last record of their kind); polygons become triangle fans.  Where the
    faces give texture or normal indices, each distinct (v, vt, vn) triple
    becomes a vertex (:mod:`mcocl.render.obj_vertices`); groups and materials
    are ignored.  The parsing is vectorised (:mod:`mcocl.render.obj_reader`):
    10^6 triangles in well under a second.

    Raises:
        InputError: the file is missing or malformed; the message names the
            scene key ``where`` and the OBJ line.
    """
    try:  # read a chunk at a time, never held whole (issue 13: under twice the file's size in memory)
        with open_regular_file(path) as f:
            mesh = PlyMesh(*parse_obj(f, f"{where}: {path}"))
    except OSError as e:
        raise InputError(f"{where}: cannot read OBJ file {path}: {e.strerror or e}") from None
    finally:
        # the chunks' freed temporaries, which glibc keeps resident (host_memory.py): a 118 MB OBJ's
        # load held 145 MB after, 62 MB of it the mesh
        release_free_heap()
    _check_vertex_data(mesh, f"{where}: {path}")
    return mesh


def _check_vertex_data(mesh: PlyMesh, label: str) -> None:
    """Refuse bad indices or a non-finite position, normal or texture coordinate."""
    check_mesh(mesh.vertices, mesh.faces, label)
    for name, a in (("normals", mesh.normals), ("texture coordinates", mesh.uvs)):
        if a is not None and not all_finite(a):
            raise InputError(f"{label}: the vertex {name} contain a non-finite number")


def read_ply(path: Path, where: str) -> PlyMesh:
    """Vertices, triangles and any per-vertex normals and UVs of a PLY file (ASCII or binary).

    Parsing is vectorised (:mod:`mcocl.render.ply_reader`); polygons become
    triangle fans.  An ASCII body is streamed from the open file, a binary one
    read a piece of an element at a time (:func:`~mcocl.render.ply_reader.parse_ply`).

    Raises:
        InputError: the file is missing or malformed; the message names the
            scene key ``where`` and the file.
    """
    try:  # the body is streamed, never held whole (issue 13: under twice the file's size in memory)
        with open_regular_file(path) as f:
            mesh = parse_ply(f, f"{where}: {path}")
    except OSError as e:
        raise InputError(f"{where}: cannot read PLY file {path}: {e.strerror or e}") from None
    finally:
        release_free_heap()  # the pieces' and chunks' freed temporaries (host_memory.py)
    _check_vertex_data(mesh, f"{where}: {path}")
    return mesh


def read_serialized(path: Path, shape_index: int, where: str) -> SerializedMesh:
    """Mesh ``shape_index`` of a Mitsuba serialized file (:mod:`mcocl.render.serialized_reader`).

    Raises:
        InputError: the file is missing or malformed, or holds no such mesh; the
            message names the scene key ``where`` and the file.
    """
    try:  # read where the parse looks, never whole (issue 13: the load holds the mesh, not the file too)
        with open_regular_file(path) as f:
            mesh = parse_serialized(f, shape_index, f"{where}: {path}")
    except OSError as e:
        raise InputError(f"{where}: cannot read serialized file {path}: {e.strerror or e}") from None
    _check_vertex_data(mesh, f"{where}: {path}")
    return mesh


__all__ = ["SEGMENTS", "all_finite", "check_mesh", "cube", "cylinder", "disk", "read_obj", "read_ply", "read_serialized",
           "rectangle"]
