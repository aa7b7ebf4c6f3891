"""Mitsuba's ``serialized`` mesh files: zlib-compressed meshes, several per file, picked by ``shape_index``.

The format (Mitsuba's documentation of the ``serialized`` plugin; little-endian throughout):

- each mesh starts with the uncompressed uint16 format identifier ``0x041C``
  and a uint16 version (3 or 4), followed by one zlib stream holding
  - uint32 ``flags``: 0x0001 per-vertex normals, 0x0002 texture coordinates,
    0x0008 vertex colours, 0x0010 face normals (shade flat), 0x1000 single
    precision, 0x2000 double precision (exactly one of the last two);
  - version 4 only: the mesh's name, UTF-8, terminated by a zero byte;
  - uint64 vertex count V, uint64 triangle count T;
  - V × 3 positions, then V × 3 normals, V × 2 texture coordinates and V × 3
    colours when flagged, in the file's precision;
  - T × 3 vertex indices, uint32 (uint64 when V needs more than 32 bits);
- after the last mesh, a table of where each mesh starts (uint64 offsets in
  version 4, uint32 in version 3) and, in the file's last 4 bytes, the uint32
  number of meshes.

The decompression is bounded: the header is read first, and the body is
inflated only up to the size that V and T imply, which must also be within
deflate's largest ratio (1032:1) of the compressed bytes, so a corrupt count
or a zip bomb is refused before memory is spent on it.
"""

from __future__ import annotations

import os
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import BinaryIO

import numpy as np

from ..errors import InputError
from .ply_reader import PlyMesh

MAGIC = 0x041C
VERSIONS = (3, 4)
HAS_NORMALS, HAS_UVS, HAS_COLORS, FACE_NORMALS = 0x0001, 0x0002, 0x0008, 0x0010
SINGLE, DOUBLE = 0x1000, 0x2000
DEFLATE_MAX_RATIO = 1032  # the most bytes one compressed byte can inflate to
_HEAD_BYTES = 4 + 4096 + 16  # flags, a name of up to 4 KiB, the two counts


@dataclass
class SerializedMesh(PlyMesh):
    """A mesh of a serialized file: :class:`PlyMesh` plus its name and whether it asks for face normals."""

    name: str = ""
    face_normals: bool = False


def _reader(source: bytes | BinaryIO) -> tuple[int, Callable[[int, int], bytes | memoryview]]:
    """The size of ``source`` (a file's bytes, or a binary file open for reading) and a function giving its
    bytes ``first .. stop``: an open file is read only where the parse looks (the closing table, one mesh's
    compressed bytes a slice at a time), never whole (issue 13: the load holds the mesh, not the file too)."""
    if isinstance(source, bytes | bytearray | memoryview):
        view = memoryview(source).cast("B")
        return len(view), lambda first, stop: view[first:stop]

    def read(first: int, stop: int) -> bytes:
        source.seek(first)
        part = source.read(stop - first)
        if len(part) != stop - first:  # the file shrank since its size was taken
            raise OSError(f"the file ended before byte {stop}")
        return part

    return os.fstat(source.fileno()).st_size, read


def mesh_count(source: bytes | BinaryIO, label: str) -> int:
    """How many meshes the file (its bytes or the open file) holds (from its closing table)."""
    return len(_offsets(*_reader(source), label)) - 1


def _offsets(size: int, read: Callable[[int, int], bytes | memoryview], label: str) -> list[int]:
    """Where each mesh starts, then where the closing table starts (the last mesh's end)."""
    if size < 8:
        raise InputError(f"{label}: not a serialized mesh file (too short)")
    magic, version = np.frombuffer(read(0, 4), "<u2", 2)
    if magic != MAGIC or version not in VERSIONS:
        raise InputError(f"{label}: not a serialized mesh file (it must begin with 0x041C and version 3 or 4)")
    count = int(np.frombuffer(read(size - 4, size), "<u4", 1)[0])
    width = 8 if version == 4 else 4
    table = size - 4 - count * width
    if count < 1 or table < 4:
        raise InputError(f"{label}: the table of meshes at the end of the file is corrupt ({count} meshes)")
    offs = np.frombuffer(read(table, table + count * width), "<u8" if width == 8 else "<u4", count).astype(np.int64)
    ends = np.append(offs[1:], table)
    if offs[0] != 0 or np.any(ends - offs < 4):
        raise InputError(f"{label}: the table of meshes at the end of the file is corrupt (bad offsets)")
    return [*offs.tolist(), table]


def parse_serialized(source: bytes | BinaryIO, shape_index: int, label: str) -> SerializedMesh:
    """Mesh ``shape_index`` (0-based) of a serialized file: its bytes, or the file open for reading bytes
    (read only where needed: :func:`_reader`).

    Raises:
        InputError: not a serialized file, an index out of range, or a corrupt mesh (named by ``label``).
    """
    size, read = _reader(source)
    bounds = _offsets(size, read, label)
    n = len(bounds) - 1
    if not 0 <= shape_index < n:
        raise InputError(f"{label}: shape_index {shape_index} is out of range (the file holds {n} meshes: 0..{n - 1})")
    start, end = bounds[shape_index], bounds[shape_index + 1]
    at = f"{label}: mesh {shape_index}"
    magic, version = np.frombuffer(read(start, start + 4), "<u2", 2)
    if magic != MAGIC or version not in VERSIONS:
        raise InputError(f"{at}: does not begin with 0x041C and version 3 or 4")
    packed = _Slices(read, start + 4, end)  # the compressed bytes, a slice at a time: never copied whole
    inflate = zlib.decompressobj()
    try:
        # one slice of the compressed bytes: it inflates to far more than the header (deflate data
        # inflate to at least about their own size unless the stream ends); the rest is never copied whole
        head = inflate.decompress(packed.slice(0), _HEAD_BYTES)
    except zlib.error as e:
        raise InputError(f"{at}: corrupt zlib data ({e})") from None
    flags, name, nv, nt, pos = _header(head, int(version), at)
    real = 8 if flags & DOUBLE else 4
    per_vertex = 3 + 3 * bool(flags & HAS_NORMALS) + 2 * bool(flags & HAS_UVS) + 3 * bool(flags & HAS_COLORS)
    index = 8 if nv > 0xFFFFFFFF else 4
    need = nv * per_vertex * real + nt * 3 * index
    if need > DEFLATE_MAX_RATIO * packed.size + _HEAD_BYTES:
        raise InputError(f"{at}: {nv} vertices and {nt} triangles cannot come from {packed.size} compressed bytes")
    # the vertex colours (unused) lie between the UVs and the faces: inflated and let go, not kept in the body
    colors_at = nv * (per_vertex - 3 * bool(flags & HAS_COLORS)) * real
    colors = (colors_at, colors_at + (nv * 3 * real if flags & HAS_COLORS else 0))
    body = _inflate_body(inflate, head[pos:], packed, need, colors, at)
    ftype = "<f8" if real == 8 else "<f4"
    off = 0

    def take(count: int, dtype: str) -> np.ndarray:
        nonlocal off
        a = body[off:off + count * np.dtype(dtype).itemsize].view(dtype)
        off += count * np.dtype(dtype).itemsize
        return a

    # The arrays are views of the inflated body, in the file's precision (float32 or float64, exact;
    # compile_scene widens where it transforms) and uint32 indices: the mesh costs its body's size once
    # (issue 13: memory near the data's own size).  Vertex colours, unused, are not in the body.
    vertices = take(nv * 3, ftype).reshape(nv, 3)
    normals = take(nv * 3, ftype).reshape(nv, 3) if flags & HAS_NORMALS else None
    uvs = take(nv * 2, ftype).reshape(nv, 2) if flags & HAS_UVS else None
    faces = take(nt * 3, "<u8" if index == 8 else "<u4").reshape(nt, 3)
    if nt and int(faces.max()) >= nv:
        raise InputError(f"{at}: a triangle's vertex index {int(faces.max())} is outside 0..{nv - 1}")
    if index == 8:
        faces = faces.astype(np.int64)
    return SerializedMesh(vertices, faces, normals, uvs, name, bool(flags & FACE_NORMALS))


_INFLATE_STEP = 1 << 16  # compressed bytes fed per step: at most 1032 times that inflate at once


class _Slices:
    """One mesh's compressed bytes (``first .. stop`` of the file) in slices of :data:`_INFLATE_STEP`."""

    def __init__(self, read: Callable[[int, int], bytes | memoryview], first: int, stop: int) -> None:
        self.read, self.first, self.size = read, first, stop - first

    def slice(self, at: int) -> bytes | memoryview:
        """The compressed bytes ``at .. at + _INFLATE_STEP`` (fewer at the end; none past it)."""
        return self.read(self.first + at, self.first + min(at + _INFLATE_STEP, self.size))


def _inflate_body(inflate, start: bytes, packed: _Slices, need: int, skip: tuple[int, int], at: str) -> np.ndarray:
    """The ``need`` bytes of a mesh's body (``start`` already inflated from the first slice of ``packed``),
    inflated step by step into one buffer, less bytes ``skip[0] .. skip[1]`` of them (inflated, not kept).

    The compressed bytes are fed a slice at a time, so neither they nor the body are ever copied whole.

    Raises:
        InputError: corrupt zlib data, or the stream ends before ``need`` bytes.
    """
    lo, hi = skip
    body = np.empty(need - (hi - lo), np.uint8)
    got = 0

    def put(part: bytes) -> None:
        """The next inflated bytes: those before ``lo`` and from ``hi`` on go to the body."""
        nonlocal got
        end = got + len(part)
        if got < lo:
            k = min(end, lo)
            body[got:k] = np.frombuffer(part, np.uint8, k - got)
        if end > hi:
            k = max(got, hi)
            body[k - (hi - lo):end - (hi - lo)] = np.frombuffer(part, np.uint8, end - k, k - got)
        got = end

    put(start[:need])
    fed, tail = _INFLATE_STEP, inflate.unconsumed_tail
    try:
        while got < need and not inflate.eof:
            if not tail:
                if fed >= packed.size:
                    break
                tail, fed = packed.slice(fed), fed + _INFLATE_STEP
            part = inflate.decompress(tail, need - got)
            tail = inflate.unconsumed_tail
            put(part)
    except zlib.error as e:
        raise InputError(f"{at}: corrupt zlib data ({e})") from None
    if got < need:
        raise InputError(f"{at}: the data ends early ({got} of {need} bytes)")
    return body


def _header(head: bytes, version: int, at: str) -> tuple[int, str, int, int, int]:
    """(flags, name, vertex count, triangle count, where the arrays start) of an inflated mesh."""
    if len(head) < 4:
        raise InputError(f"{at}: the compressed mesh is empty")
    flags = int(np.frombuffer(head, "<u4", 1)[0])
    if bool(flags & SINGLE) == bool(flags & DOUBLE):
        raise InputError(f"{at}: flags 0x{flags:04x} must give exactly one of single (0x1000) or double (0x2000)")
    pos, name = 4, ""
    if version == 4:
        z = head.find(b"\0", pos)
        if z < 0:
            raise InputError(f"{at}: the mesh name has no terminating zero byte within {_HEAD_BYTES - 20} bytes")
        name = head[pos:z].decode("utf-8", "replace")
        pos = z + 1
    if len(head) < pos + 16:
        raise InputError(f"{at}: the data ends inside the header")
    nv, nt = (int(x) for x in np.frombuffer(head, "<u8", 2, pos))
    if nv < 3 or nt < 1 or nv >= 1 << 40 or nt >= 1 << 40:
        raise InputError(f"{at}: implausible counts ({nv} vertices, {nt} triangles)")
    return flags, name, nv, nt, pos + 16


__all__ = ["SerializedMesh", "mesh_count", "parse_serialized"]
