"""Shape geometry in local coordinates: rectangle, cube, sphere, triangle meshes, OBJ files.

Every triangle is counter-clockwise seen from its front side, so the front
normal is ``normalize(cross(v1 - v0, v2 - v0))`` (the convention of
:mod:`mcocl.render.compiled`).  The canonical shapes are Mitsuba 3's:

- ``rectangle``: the square [-1, 1]² in the z = 0 plane, normal +z, two triangles;
- ``cube``: [-1, 1]³, outward normals, twelve triangles;
- ``sphere``: an analytic primitive (``center``, ``radius``), outward normal.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from .obj_reader import parse_obj


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


def check_mesh(vertices: np.ndarray, faces: np.ndarray, where: str) -> None:
    """Reject non-finite vertices and out-of-range face indices, naming ``where``."""
    if vertices.ndim != 2 or vertices.shape[1] != 3:
        raise InputError(f"{where}: vertices must be a list of [x, y, z] triples")
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise InputError(f"{where}: faces must be a list of [i, j, k] index triples")
    if not np.all(np.isfinite(vertices)):
        raise InputError(f"{where}: vertices contain a non-finite number")
    if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
        bad = int(faces.min()) if faces.min() < 0 else int(faces.max())
        raise InputError(f"{where}: face index {bad} is outside 0..{len(vertices) - 1}")


def read_obj(path: Path, where: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of a Wavefront OBJ file.

    Reads ``v`` and ``f`` records (``f`` entries may be ``i``, ``i/t``,
    ``i//n`` or ``i/t/n``, with negative indices counting back from the last
    vertex read); polygons with more than three corners are split into a fan.
    Texture coordinates, normals, groups and materials are ignored: shading
    here uses geometric normals.  The parsing is vectorised
    (:mod:`mcocl.render.obj_reader`): 10^6 triangles in well under a second.

    Raises:
        InputError: the file is missing or malformed; the message names the
            scene key ``where`` and the OBJ line.
    """
    try:
        data = path.read_bytes()
    except OSError as e:
        raise InputError(f"{where}: cannot read OBJ file {path}: {e.strerror or e}") from None
    v, f = parse_obj(data, f"{where}: {path}")
    check_mesh(v, f, f"{where}: {path}")
    return v, f


__all__ = ["check_mesh", "cube", "read_obj", "rectangle"]
