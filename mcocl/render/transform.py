"""Affine transforms of scene shapes (4×4 homogeneous matrices, float64).

A scene's ``transform`` is a list of operations applied *in list order* to the
shape's local coordinates: ``[{"scale": 0.3}, {"rotate": ...}, {"translate": ...}]``
scales first, then rotates, then translates — the order in which Mitsuba 3's
``<transform>`` element and the issue's wording ("the cube scaled by 0.3,
rotated −17° about +y, translated to ...") compose them.  The composite matrix
is therefore ``M = M_last @ ... @ M_first``.

Rotations are right-handed (counter-clockwise when looking down the axis
towards the origin), as in Mitsuba's ``Transform4f.rotate``.
"""

from __future__ import annotations

import math

import numpy as np


def translate(v: np.ndarray | list[float]) -> np.ndarray:
    """The matrix of a translation by ``v``."""
    m = np.eye(4)
    m[:3, 3] = np.asarray(v, dtype=np.float64)
    return m


def scale(s: float | np.ndarray | list[float]) -> np.ndarray:
    """The matrix of a (uniform when ``s`` is a number) scale about the origin."""
    m = np.eye(4)
    m[:3, :3] = np.diag(np.broadcast_to(np.asarray(s, dtype=np.float64), (3,)))
    return m


def rotate(axis: np.ndarray | list[float], degrees: float, normalise: bool = True) -> np.ndarray:
    """The matrix of a right-handed rotation by ``degrees`` about ``axis`` (Rodrigues' formula
    c·I + s·[a]ₓ + (1 − c)·a aᵀ).  ``normalise=False`` takes the axis as given, as Mitsuba's
    ``<rotate>`` does: a non-unit axis then also scales and shears."""
    a = np.asarray(axis, dtype=np.float64)
    if normalise:
        a = a / np.linalg.norm(a)
    th = math.radians(degrees)
    c, s = math.cos(th), math.sin(th)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    m = np.eye(4)
    m[:3, :3] = c * np.eye(3) + s * k + (1.0 - c) * np.outer(a, a)
    return m


def compose(ops: list[np.ndarray]) -> np.ndarray:
    """The matrix applying ``ops`` in list order (the first op acts first)."""
    m = np.eye(4)
    for op in ops:
        m = op @ m
    return m


# Rows per block of rows_times.  OpenBLAS runs small products on one thread and starts its threads for big
# ones; on this loaded 2-core machine a (N, 3) @ (3, 3) product took 2 ms for 16384 rows against 85 ms for 65536,
# and 0.1-0.2 s for the 5 * 10^5 vertices of bench/ply_load.py's mesh, a hundred times the arithmetic.
_ROWS = 1 << 14


def rows_times(p: np.ndarray, a: np.ndarray) -> np.ndarray:
    """``p @ a`` for rows ``p`` (..., k), computed in blocks of at most :data:`_ROWS` rows when there are more.

    The same numbers as one product: OpenBLAS gives each row's entries the
    same operations whatever the number of rows around it, except for a
    single row (NumPy then calls a matrix-vector product, which may round
    differently), so the blocks are of equal size, half of :data:`_ROWS` or
    more (tests/test_render_scene.py checks the bits); only the threads that
    a single big product would start are spared.
    """
    p = np.asarray(p)
    if p.ndim != 2 or len(p) <= _ROWS:
        return p @ a
    out = np.empty((len(p), a.shape[1]), np.result_type(p, a))
    for s, e in row_blocks(len(p)):
        np.matmul(p[s:e], a, out=out[s:e])
    return out


def row_blocks(n: int) -> list[tuple[int, int]]:
    """The (start, stop) row ranges of :func:`rows_times`'s blocks for ``n`` rows: equal sizes of at most
    :data:`_ROWS` (one range of every row for ``n`` <= :data:`_ROWS`, as rows_times multiplies them)."""
    blocks = max(1, -(-n // _ROWS))
    edges = [n * i // blocks for i in range(blocks + 1)]
    return list(zip(edges[:-1], edges[1:]))


def apply_points(m: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Transform points ``p`` (..., 3) by the affine matrix ``m``."""
    out = rows_times(p, m[:3, :3].T)
    out += m[:3, 3]
    return out


def apply_points_float32(m: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``apply_points(m, p.astype(float64)).astype(float32)`` for rows ``p`` (n, 3), and which rows of that
    float64 product are finite (n,) bool: the same numbers, block by block.

    Each of :func:`rows_times`'s blocks is widened, multiplied, translated and rounded in turn (the same
    products of the same rows), so that a mesh's float64 points are a block's (384 KB), not two (n, 3)
    tables: 188 MB at the 3.9 * 10^6 vertices of bench/load_memory.py's serialized mesh (issue 13).
    """
    lin, shift = m[:3, :3].T, m[:3, 3]
    out = np.empty((len(p), 3), np.float32)
    finite = np.empty(len(p), bool)
    for s, e in row_blocks(len(p)):
        w = np.asarray(p[s:e], np.float64) @ lin  # what rows_times does with this block (or every row)
        w += shift
        finite[s:e] = np.isfinite(w).all(axis=1)
        out[s:e] = w
    return out, finite


def uniform_scale_of(m: np.ndarray, rtol: float = 1e-6) -> float | None:
    """The scale factor when the linear part of ``m`` is a similarity (rotation × uniform scale), else ``None``.

    Spheres stay spheres only under similarities, so a sphere's radius is
    multiplied by this factor and any other transform is rejected.
    """
    lin = m[:3, :3]
    g = lin.T @ lin
    s2 = float(np.trace(g)) / 3.0
    if s2 <= 0.0 or not np.allclose(g, s2 * np.eye(3), rtol=0.0, atol=rtol * s2):
        return None
    return math.sqrt(s2)


def is_orientation_reversing(m: np.ndarray) -> bool:
    """True when ``m`` mirrors space (negative determinant of its linear part).

    Transformed edge vectors of a triangle then turn the other way, so the
    triangle's vertices are swapped to keep its front side where the
    transformed normal (``inverse(M)ᵀ n``) points.
    """
    return bool(np.linalg.det(m[:3, :3]) < 0.0)


__all__ = [
    "apply_points",
    "rows_times",
    "compose",
    "is_orientation_reversing",
    "rotate",
    "scale",
    "translate",
    "uniform_scale_of",
]
