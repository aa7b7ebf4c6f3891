"""Texture coordinates (u, v) of every shape, Mitsuba 3's parameterisations (kernels/render/texture.cl).

Measured on Mitsuba 3.9's scalar_rgb variant (ray hits at chosen points;
tests/test_render_textures.py checks the same points here), in each shape's
local coordinates (x, y, z):

- rectangle: u = (x + 1) / 2, v = (y + 1) / 2;
- cube: per face, u and v affine in the two in-face coordinates (:data:`CUBE_FACES`);
- disk: u = r, v = φ / 2π with φ = atan2(y, x) in [0, 2π);
- cylinder: u = φ / 2π, v = z;
- sphere: u = φ / 2π, v = θ / π with θ = acos(z) (the kernel computes it at the hit
  from the rotation rows :func:`sphere_frames` gives);
- meshes: their files' per-vertex UVs, interpolated by the hit's barycentrics;
  an OBJ's v is flipped (1 − v) on reading, as Mitsuba's OBJ reader does, so
  that v = 0 of an OBJ is the image's bottom row; PLY and serialized UVs are
  taken as they are.  A mesh without UVs has (0, 0) everywhere (Mitsuba
  has no UVs there either and textures it with its value at (0, 0)).

Triangulated disks and cylinders carry their vertices' (u, v) and interpolate
linearly across each triangle (φ unwrapped across the seam, the disk's centre
at its triangle's mean φ): exact at the vertices, within the tessellation's
error between them.
"""

from __future__ import annotations

import numpy as np

from . import transform as tf
from .shape_registry import SHAPES

# Cube faces: outward normal axis and sign -> (u, v) as ((axis, sign), (axis, sign)) with u = (sign * x[axis] + 1) / 2.
CUBE_FACES = {
    (2, 1): ((1, 1), (0, 1)), (2, -1): ((1, -1), (0, 1)),
    (0, 1): ((1, 1), (2, -1)), (0, -1): ((1, 1), (2, 1)),
    (1, 1): ((0, -1), (2, -1)), (1, -1): ((2, 1), (0, 1)),
}


def _polar(p: np.ndarray) -> np.ndarray:
    """φ / 2π in [0, 1) of points (..., 2)."""
    a = np.arctan2(p[..., 1], p[..., 0]) / (2.0 * np.pi)
    return np.where(a < 0.0, a + 1.0, a)


def _unwrap(phi: np.ndarray, known: np.ndarray) -> np.ndarray:
    """Per triangle (T, 3): corners' φ / 2π shifted by 1 where the triangle straddles the seam."""
    lo = np.where(known, phi, np.inf).min(axis=1, keepdims=True)
    return np.where(known & (phi - lo > 0.5), phi - 1.0, phi)


def _corner_uvs(shape, faces: np.ndarray) -> np.ndarray:
    """(T, 3, 2) (u, v) of the corners of ``faces`` (local vertices of ``shape``): float64, or a mesh
    file's float32 UVs as they are (exact either way: :func:`triangle_uvs` rounds to float32 once)."""
    if shape.kind not in ("rectangle", "cube", "disk", "cylinder"):  # a mesh: its own UVs, no positions needed
        if shape.uvs is None:
            return np.zeros(faces.shape + (2,))
        return np.asarray(shape.uvs)[faces]
    p = np.asarray(shape.vertices, np.float64)[faces]
    if shape.kind == "rectangle":
        return (p[..., :2] + 1.0) / 2.0
    if shape.kind == "cube":
        n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        out = np.zeros(p.shape[:2] + (2,))
        for (axis, sign), ((ua, us), (va, vs)) in CUBE_FACES.items():
            sel = (np.argmax(np.abs(n), axis=1) == axis) & (np.sign(n[np.arange(len(n)), axis]) == sign)
            out[sel, :, 0] = (us * p[sel][..., ua] + 1.0) / 2.0
            out[sel, :, 1] = (vs * p[sel][..., va] + 1.0) / 2.0
        return out
    if shape.kind == "disk":
        r = np.linalg.norm(p[..., :2], axis=-1)
        known = r > 1e-12
        phi = _unwrap(_polar(p[..., :2]), known)
        mean = np.where(known, phi, 0.0).sum(axis=1, keepdims=True) / np.maximum(known.sum(axis=1, keepdims=True), 1)
        return np.stack([r, np.where(known, phi, mean)], axis=-1)
    phi = _unwrap(_polar(p[..., :2]), np.ones(p.shape[:2], bool))  # the cylinder
    return np.stack([phi, p[..., 2]], axis=-1)


def triangle_uvs(shapes: list) -> np.ndarray:
    """(T, 3, 2) float32 corner (u, v) of the compiled triangles (the order and corner order of
    :func:`mcocl.render.compiled.compile_scene`'s ``tri_vertices``)."""
    out = []
    for sh in shapes:
        if SHAPES[sh.kind].sphere:
            continue
        faces = np.asarray(sh.faces)
        if tf.is_orientation_reversing(sh.matrix) != sh.flip_normals:
            faces = faces[:, [0, 2, 1]]  # as compiled.py's _shape_triangles
        out.append(_corner_uvs(sh, faces))
    return np.concatenate(out).astype(np.float32) if out else np.zeros((0, 3, 2), np.float32)


def sphere_frames(shapes: list) -> np.ndarray:
    """(S, 3, 3) float32 per sphere: the unit rows of the inverse of its transform's linear part (world -> local
    directions), so that the hit's local direction is R (p − centre)."""
    out = []
    for sh in shapes:
        if SHAPES[sh.kind].sphere:
            inv = np.linalg.inv(np.asarray(sh.matrix, np.float64)[:3, :3])
            out.append(inv / np.linalg.norm(inv, axis=1, keepdims=True))
    return np.array(out, np.float32).reshape(-1, 3, 3)


__all__ = ["CUBE_FACES", "sphere_frames", "triangle_uvs"]
