"""From an OBJ file's records and corner index triples to a mesh with per-vertex normals and UVs.

In OBJ a corner names a position (``v``), a texture coordinate (``vt``) and a
normal (``vn``) independently; a mesh for the renderer has one index per
corner.  So each distinct (v, vt, vn) triple the corners use becomes one
vertex (:func:`split_vertices`), in the order of (v, vt, vn) — the order of
the positions in the file when each position has one texture coordinate and
normal.  A kind of index is used only when every corner gives one: a file
where some corners give normals and others do not gets no normals (its mesh
shades with face normals, as before OBJ normals were read) and an
:class:`ObjAttributeWarning` naming the first line without; texture
coordinates likewise.  A file that gives neither keeps its positions and
triangles exactly as read, unused positions included.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..errors import InputError
from ..host_memory import release_free_heap

# (index kind, what its records are called) for v, vt, vn: the vertex kind keeps the messages it had before
KINDS = (("face", "vertices"), ("texture coordinate", "texture coordinates (vt)"), ("normal", "normals (vn)"))


class ObjAttributeWarning(UserWarning):
    """An OBJ file's faces give normals (or texture coordinates) at some corners only: the mesh gets none."""


class ObjMesh(NamedTuple):
    """Vertices (V, 3) float64, triangles (T, 3) int64 (0-based), normals (V, 3) and uvs (V, 2) float64 or None."""

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None
    uvs: np.ndarray | None


@dataclass
class Chunk:
    """What one chunk of lines holds: records, fan triangles' indices (-1: the corner gives none), its faces' lines."""

    vertices: np.ndarray  # (V, 3) positions
    uvs: np.ndarray  # (VT, 2) texture coordinates
    normals: np.ndarray  # (VN, 3)
    tri: np.ndarray  # (T, 3) position indices
    tri_t: np.ndarray | None  # (T, 3) texture indices, None when not read
    tri_n: np.ndarray | None  # (T, 3) normal indices, None when not read
    face_lines: np.ndarray  # (F,) line number of each face
    per_face: np.ndarray  # (F,) corners of each face
    kinds: tuple[bool, bool]  # whether texture and normal indices were read


def _line_of_triangle(chunks: list[Chunk], t: int) -> int:
    """The line of the face whose fan holds triangle ``t`` of the whole file (error paths only)."""
    for c in chunks:
        fans = np.cumsum(c.per_face - 2)
        if len(fans) and t < fans[-1]:
            return int(c.face_lines[np.searchsorted(fans, t, side="right")])
        t -= int(fans[-1]) if len(fans) else 0
    raise AssertionError("triangle beyond the file")


def _check_range(chunks: list[Chunk], tri: np.ndarray, count: int, kind: int, label: str) -> None:
    """Refuse a 0-based index at or past ``count`` records (negative ones were refused with their line already)."""
    if not tri.size or tri.max() < count:
        return
    t = int(np.flatnonzero((tri >= count).any(axis=1))[0])
    what, called = KINDS[kind]
    raise InputError(f"{label}:{_line_of_triangle(chunks, t)}: {what} index {tri[t].max()} is outside "
                     f"0..{count - 1} (0-based): the file has {count} {called}")


def _unique_inverse(key: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(a position of each distinct value in increasing order, the rank of every value): ``np.unique`` by hand.

    One argsort and a scatter: ``np.unique(key, return_inverse=True)`` took
    8x as long on 3·10^6 int64 keys (NumPy 2.4).  ``key`` (int64) is
    overwritten by the ranks, which are returned in it, and the sorted keys'
    array then holds their running count: two corner-sized arrays fewer at
    the peak (issue 13's memory bound).
    """
    order = np.argsort(key)
    s = key[order]
    new = np.empty(len(s), bool)
    new[:1] = True
    np.not_equal(s[1:], s[:-1], out=new[1:])
    np.cumsum(new, out=s)
    s -= 1
    first = order[new]
    key[order] = s
    return first, key


def _split_equal_indices(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`split_vertices` where every corner gives one index for all kinds (an exporter's ``i/i/i``).

    The tuples then order as their position index ``v`` (0-based, in range), so they rank by a table
    over the positions rather than by a sort of the corners: a few position-sized arrays instead of
    three corner-sized ones (issue 13's memory bound), and no sort.  The corner given for each tuple
    may be another than the sort's, but it holds the same indices, so the mesh is the same.
    """
    used = np.zeros(int(v.max()) + 1, bool)
    used[v] = True
    rank = np.cumsum(used)
    rank -= 1
    where = np.empty(len(used), np.int64)
    block = 1 << 20  # corners at a time: no corner-sized arange
    for s in range(0, len(v), block):
        where[v[s:s + block]] = np.arange(s, min(s + block, len(v)))
    return rank[v].reshape(-1, 3), where[used]


def split_vertices(columns: list[np.ndarray], counts: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """Triangles over the distinct index tuples of the corners, and a corner of each tuple, in the tuples' order.

    ``columns`` are (T, 3) index arrays (position first), ``counts`` how many
    records each indexes.  The tuples are packed into one int64 key
    (position-major); where the product of the counts would overflow, the key
    so far is replaced by its rank first.
    """
    # The ranking's arrays come from the heap, whose freed chunk temporaries glibc keeps resident unless
    # given back first (issue 13: a 109 MB file's peak 235 -> 170 MB; a heap walk, ms).
    release_free_heap()
    if columns[0].size and all(np.array_equal(c, columns[0]) for c in columns[1:]):
        return _split_equal_indices(columns[0].ravel())
    key = columns[0].ravel().astype(np.int64)
    span = counts[0]
    for col, count in zip(columns[1:], counts[1:]):
        if span * count >= 2**63:
            first, key = _unique_inverse(key)
            span = len(first)
        key *= count  # in place: a corner-sized array fewer
        key += col.ravel()
        span *= count
    release_free_heap()  # (the key's arrays freed too, before the sort's three corner-sized ones)
    first, inverse = _unique_inverse(key)
    return inverse.reshape(-1, 3), first


def _take(chunks: list[Chunk], name: str) -> np.ndarray:
    """The chunks' arrays ``name`` (those not None) joined, each chunk's dropped: they are not held twice."""
    parts = [getattr(c, name) for c in chunks]
    for c in chunks:
        setattr(c, name, None)
    parts = [x for x in parts if x is not None]
    # (an empty part, such as the first chunk's, would widen int32 parts to its int64)
    return np.concatenate([x for x in parts if x.size] or parts)


def assemble(chunks: list[Chunk], label: str) -> ObjMesh:
    """The mesh of the chunks of one file (see the module docstring); indices past their records are refused here.

    The chunks' records and indices are taken from them as they are joined (:func:`_take`)."""
    vertices = _take(chunks, "vertices")
    tri = _take(chunks, "tri")
    _check_range(chunks, tri, len(vertices), 0, label)
    used: list[tuple[int, np.ndarray, np.ndarray]] = []
    for kind, name in ((1, "uvs"), (2, "normals")):
        if not chunks[-1].kinds[kind - 1]:
            continue
        col = _take(chunks, "tri_t" if kind == 1 else "tri_n")
        given = col >= 0
        if not given.any():
            continue
        if not given.all():
            t = int(np.flatnonzero(~given.all(axis=1))[0])
            warnings.warn(f"{label}:{_line_of_triangle(chunks, t)}: a face corner without a {KINDS[kind][0]} index "
                          f"where others have one: the mesh gets no {KINDS[kind][1]}"
                          + (" and shades with face normals" if kind == 2 else ""), ObjAttributeWarning, stacklevel=4)
            continue
        records = _take(chunks, name)
        _check_range(chunks, col, len(records), kind, label)
        used.append((kind, col, records))
    if not used:
        return ObjMesh(vertices, tri.astype(np.int64, copy=False), None, None)
    faces, first = split_vertices([tri] + [col for _, col, _ in used], [len(vertices)] + [len(r) for _, _, r in used])
    # each tuple's indices, then the corner-sized index columns dropped before the records are gathered
    picked = [(kind, col.ravel()[first], records) for kind, col, records in used]
    positions = tri.ravel()[first]
    del used, tri, col, given
    out = {kind: records[at] for kind, at, records in picked}
    return ObjMesh(vertices[positions], faces, out.get(2), out.get(1))


__all__ = ["Chunk", "KINDS", "ObjAttributeWarning", "ObjMesh", "assemble", "split_vertices"]
