"""Wavefront OBJ parsing with whole-buffer NumPy operations (no Python loop over lines or faces).

Read: ``v`` (x y z), ``vt`` (u [v [w]]: v defaults to 0, w is dropped),
``vn`` (x y z) and ``f`` records; every other record (``g``, ``usemtl``,
``vp``, ...) is skipped.  The file is handled as byte arrays of a chunk of
whole lines each, read from the open file where one is given, so that its
bytes are never held whole (:func:`parse_obj`):

1. line breaks are normalised (``\\r\\n`` and ``\\r`` become ``\\n``, as
   :meth:`str.splitlines` reads them), other whitespace becomes a space and
   ``#`` comments are blanked;
2. each line's first token is read at its start (after any indentation),
   which classifies the line as a position, texture coordinate, normal, face
   or something else;
3. the lines of each kind in the chunk are gathered into one buffer; token boundaries
   found by byte comparisons give how many numbers each line holds; the
   records' numbers are parsed by one ``np.fromstring`` call per kind, the
   faces' indices by digit arithmetic at the start of each corner
   (:mod:`mcocl.render.obj_corners`).

Faces may be ``i``, ``i/t``, ``i//n`` or ``i/t/n``.  In a file with ``vt``
or ``vn`` records the whole corner is read (and must have one of these
forms); its texture (normal) index is used only when the file has ``vt``
(``vn``) records.  A file of ``v`` and ``f`` records reads only the number
before each corner's first slash, exactly as before texture coordinates and
normals were read.  A negative
index counts back from the last record of its kind before the face's line;
polygons become fans ``(0, k, k + 1)``.  :mod:`mcocl.render.obj_vertices`
turns the corners' (v, vt, vn) triples into the mesh's vertices, normals and
UVs.  Malformed records, an index of 0 and indices past their records raise
:class:`~mcocl.errors.InputError` naming the line.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from typing import BinaryIO

import numpy as np

from ..errors import InputError
from .obj_corners import corner_indices, vertex_indices
from .obj_vertices import KINDS, Chunk, ObjAttributeWarning, ObjMesh, assemble

_SPACE, _NL, _HASH = 32, 10, ord("#")
_PAD = np.full(8, _SPACE, np.uint8)
CHUNK_BYTES = 1 << 21  # text parsed at once (whole lines): see parse_obj


def _blank_comments(b: np.ndarray, line_end: np.ndarray) -> None:
    """Overwrite every ``#`` and the rest of its line with spaces, in place."""
    hashes = np.flatnonzero(b == _HASH)
    line = np.searchsorted(line_end, hashes)
    first = np.ones(len(hashes), bool)
    first[1:] = line[1:] != line[:-1]
    h, e = hashes[first], line_end[line[first]]
    lengths = e - h
    pos = np.repeat(h - np.cumsum(lengths) + lengths, lengths) + np.arange(int(lengths.sum()))
    b[pos] = _SPACE


def _select_lines(b: np.ndarray, start: np.ndarray, end: np.ndarray, tag: np.ndarray,
                  tag_len: int = 1) -> np.ndarray:
    """The chosen lines ``b[start[k]:end[k] + 1]`` (line breaks included), concatenated, tags blanked.

    Eight spaces follow, so that any eight bytes from a token's start can be read.

    Lines of one kind usually come in a few long runs, copied as slices;
    a file that interleaves them is gathered with a byte mask instead.
    """
    length = end + 1 - start
    new_run = np.ones(len(start), bool)
    new_run[1:] = start[1:] != end[:-1] + 1
    runs = np.flatnonzero(new_run)
    if len(runs) <= 256:
        run_end = np.append(runs[1:], len(start)) - 1
        blob = np.concatenate([b[start[r]:end[q] + 1] for r, q in zip(runs, run_end)] + [_PAD])
    else:
        mark = np.zeros(len(b) + 1, np.int8)
        mark[start] = 1
        mark[end + 1] -= 1
        blob = np.concatenate([b[np.cumsum(mark[:-1], dtype=np.int8).view(bool)], _PAD])
    at = np.cumsum(length) - length + (tag - start)
    for k in range(tag_len):
        blob[at + k] = _SPACE
    return blob


def _token_starts(blob: np.ndarray) -> np.ndarray:
    """Positions in ``blob`` where a token starts: a byte above the space after one at most a space.

    (Tabs, carriage returns and the like are spaces by now; other control bytes also separate.)
    """
    word = blob > _SPACE
    first = np.empty(len(blob), bool)
    first[0] = word[0]
    np.greater(word[1:], word[:-1], out=first[1:])
    return np.flatnonzero(first)


def _per_line(pos: np.ndarray, line_end: np.ndarray) -> np.ndarray:
    """How many of the sorted positions ``pos`` fall in each line (lines end at sorted ``line_end``)."""
    return np.diff(np.searchsorted(pos, line_end), prepend=0)


def _token(blob: np.ndarray, at: int) -> str:
    """The whitespace-separated token of ``blob`` that starts at ``at`` (for error messages)."""
    end = at
    while end < len(blob) and blob[end] > _SPACE:
        end += 1
    return blob[at:end].tobytes().decode("utf-8", "replace")


def parse_obj(source: bytes | BinaryIO, label: str) -> ObjMesh:
    """The mesh of OBJ text: positions, triangles (0-based) and per-vertex normals and UVs where the faces give them.

    ``source`` is the file's bytes, or a binary file open at its start that is
    read a chunk at a time (issue 13: the file's bytes are then never held
    whole; the same chunks, and so the same mesh and messages, as its bytes).
    The text is handled in chunks of whole lines of about :data:`CHUNK_BYTES`
    (a loop over chunks, not lines): a chunk's temporaries are small enough
    for the allocator to reuse them, where whole-file temporaries would be
    fresh memory every time (10^7 triangles: 6 of 8.6 CPU-seconds were page
    faults before), and few next to the file and mesh (issue 13: 2 MB chunks
    hold less than 8 MB ones at no cost in time); each chunk keeps its indices
    and face lines as int32 where they fit.  Whether the file has ``vt`` or ``vn`` records decides
    how corners are read; a chunk's faces are read knowing the records of the
    chunks so far and of their own chunk, and in the rare file whose first
    ``vt`` or ``vn`` record comes a chunk after a face the chunks are read again.

    Raises:
        InputError: a malformed record or index; the message is ``"{label}:{line}: ..."``.
    """
    kinds = (False, False)
    while True:
        chunks = _parse_chunks(source, kinds, label)
        found = (kinds[0] or any(len(c.uvs) for c in chunks), kinds[1] or any(len(c.normals) for c in chunks))
        if all(c.kinds == found for c in chunks if len(c.per_face)):
            return assemble(chunks, label)
        kinds = found


def _parse_chunks(source: bytes | BinaryIO, kinds: tuple[bool, bool], label: str) -> list[Chunk]:
    """Every chunk of ``source`` (see :func:`parse_obj`), ``vt``/``vn`` corner indices read where ``kinds`` say or records were seen."""
    chunks = [Chunk(np.zeros((0, 3)), np.zeros((0, 2)), np.zeros((0, 3)), np.zeros((0, 3), np.int64), None, None,
                    np.zeros(0, np.int64), np.zeros(0, np.int64), kinds)]
    lines = 0
    before = np.zeros(3, np.int64)  # v, vt, vn records so far
    for data, pos, end in _byte_chunks(source) if isinstance(source, bytes) else _file_chunks(source):
        text, first, stop = _normalised(data, pos, end)
        chunk, n = _parse_chunk(text, first, stop, lines, before, chunks[-1].kinds, label)
        chunks.append(chunk)
        lines += n
        before += [len(chunk.vertices), len(chunk.uvs), len(chunk.normals)]
    return chunks


def _byte_chunks(data: bytes) -> Iterator[tuple[bytes, int, int]]:
    """The chunks of whole lines of ``data`` as (data, start, stop): up to the last line break within
    :data:`CHUNK_BYTES`, or a whole line longer than that, or the rest of the file."""
    data = data or b"\n"  # (an empty file is one empty line)
    pos = 0
    while pos < len(data):
        end = data.rfind(b"\n", pos, pos + CHUNK_BYTES)
        if end < 0:  # a line longer than a chunk (or the rest of a file whose lines end in \r alone)
            end = data.find(b"\n", pos)
            end = len(data) - 1 if end < 0 else end
        yield data, pos, end + 1
        pos = end + 1


def _file_chunks(f: BinaryIO) -> Iterator[tuple[bytes, int, int]]:
    """The chunks of :func:`_byte_chunks` of the file ``f``'s bytes, read from its start a block at a time.

    Only the chunk and the start of the next are held (issue 13): the file's bytes never are.
    """
    f.seek(0)
    buf, eof = b"", False
    while True:
        while not eof and len(buf) < CHUNK_BYTES:
            block = f.read(CHUNK_BYTES)
            eof = not block
            buf += block
        if not buf:
            if f.tell() == 0:  # (an empty file is one empty line)
                yield b"\n", 0, 1
            return
        end = buf.rfind(b"\n", 0, CHUNK_BYTES)
        scanned = CHUNK_BYTES
        while end < 0:  # a line longer than a chunk (or the rest of a file whose lines end in \r alone)
            end = buf.find(b"\n", scanned)
            scanned = len(buf)
            if end < 0 and eof:
                end = len(buf) - 1
            elif end < 0:
                block = f.read(CHUNK_BYTES)
                eof = not block
                buf += block
        yield buf, 0, end + 1
        buf = buf[end + 1:]


def _normalised(data: bytes, first: int, stop: int) -> tuple[bytes, int, int]:
    """The whole lines ``data[first:stop]`` with line breaks and whitespace normalised (bytes, start, stop).

    ``\r\n`` and ``\r`` become ``\n`` (as :meth:`str.splitlines` reads them), tabs, vertical tabs and
    form feeds spaces, and a final break ends the file's last line (the one chunk that ends without a
    ``\n``).  A chunk ends after a ``\n``, so no ``\r\n`` is cut.  Done a chunk at a time (issue 13):
    whole-file copies cost twice the file's size.  Lines that need none of it are returned in place, uncopied.
    """
    ends_line = data[stop - 1:stop] == b"\n"
    if not any(data.find(c, first, stop) >= 0 for c in (b"\r", b"\t", b"\v", b"\f")) and ends_line:
        return data, first, stop
    text = data[first:stop]
    if b"\r" in text:
        text = text.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    text = text.translate(bytes.maketrans(b"\t\v\f", b"   "))
    if not ends_line and not text.endswith(b"\n"):
        text += b"\n"
    return text, 0, len(text)


def _parse_chunk(data: bytes, first: int, stop: int, lines_before: int, before: np.ndarray,
                 kinds: tuple[bool, bool], label: str) -> tuple[Chunk, int]:
    """The records and faces of the whole lines ``data[first:stop]`` (after the given counts), and its line count."""
    b = np.frombuffer(data, np.uint8, count=stop - first, offset=first)
    line_end = np.flatnonzero(b == _NL)
    if data.find(b"#", first, stop) >= 0:
        b = b.copy()
        _blank_comments(b, line_end)
    start = np.concatenate([[0], line_end[:-1] + 1])
    # Skip indentation: a loop over the indentation depth, each step over the still-indented lines.
    tag = start.copy()
    indented = np.flatnonzero(b[tag] == _SPACE)
    while len(indented):
        tag[indented] += 1
        indented = indented[b[tag[indented]] == _SPACE]
    head = b[tag]
    after = b[tag + 1 - (head == _NL)]  # the byte after the tag (the break itself on an empty line)
    tag_alone = (after == _SPACE) | (after == _NL)
    is_v = (head == ord("v")) & tag_alone
    is_f = (head == ord("f")) & tag_alone
    two = (head == ord("v")) & ((after == ord("t")) | (after == ord("n")))  # then tag + 2 is on the line
    third = b[np.where(two, tag + 2, tag)]
    two &= (third == _SPACE) | (third == _NL)
    is_vt, is_vn = two & (after == ord("t")), two & (after == ord("n"))
    kinds = (kinds[0] or bool(is_vt.any()), kinds[1] or bool(is_vn.any()))
    number = lines_before + 1 + np.arange(len(line_end))

    def records(mask: np.ndarray, width: int, need: int, message: str, tag_len: int) -> np.ndarray:
        k = np.flatnonzero(mask)
        return _parse_records(b, start[k], tag[k], line_end[k], number[k], width, need, tag_len, label, message)

    vertices = records(is_v, 3, 3, "a vertex needs three numbers", 1)
    uvs = records(is_vt, 2, 1, "a texture coordinate needs one to three numbers (u [v [w]])", 2)
    normals = records(is_vn, 3, 3, "a normal needs three numbers", 2)
    fl = np.flatnonzero(is_f)
    counts = [before[0] + np.cumsum(is_v)[fl]]
    counts += [before[k] + np.cumsum(mask)[fl] if used else None for k, mask, used in ((1, is_vt, kinds[0]),
                                                                                      (2, is_vn, kinds[1]))]
    faces = _parse_faces(b, start[fl], tag[fl], line_end[fl], number[fl], counts, kinds, label)
    return Chunk(vertices, uvs, normals, *map(_narrow, faces), kinds), len(line_end)


def _narrow(a: np.ndarray | None) -> np.ndarray | None:
    """``a`` as int32 where its values fit (a chunk's indices and line numbers, held until the file is read:
    half the memory, issue 13), else as it is; the values, and so the mesh and messages, are the same."""
    if a is None or not a.size or a.min() < -2**31 or a.max() >= 2**31:
        return a
    return a.astype(np.int32)


def _parse_records(b, start, tag, end, lines, width: int, need: int, tag_len: int, label: str,
                   message: str) -> np.ndarray:
    """The first ``width`` numbers of each chosen line, float64 (N, width); lines with fewer (but ``need``) get zeros.

    A line with fewer than ``need`` numbers, or a token that is not a number,
    raises ``InputError("{label}:{line}: {message}")``.
    """
    if not len(start):
        return np.zeros((0, width))
    blob = _select_lines(b, start, end, tag, tag_len)
    blob_nl = np.cumsum(end + 1 - start) - 1
    ts = _token_starts(blob)
    per_line = _per_line(ts, blob_nl)
    short = np.flatnonzero(per_line < need)
    if len(short):
        raise InputError(f"{label}:{lines[short[0]]}: {message}")
    nums = parse_numbers(blob)
    if nums is None or len(nums) != len(ts):
        raise InputError(f"{label}:{lines[_first_bad_line(blob, blob_nl)]}: {message}")
    if np.all(per_line == width):
        return nums.reshape(-1, width)
    at = (np.cumsum(per_line) - per_line)[:, None] + np.arange(width)
    if need == width:
        return nums[at]
    given = np.arange(width) < per_line[:, None]
    return np.where(given, nums[np.where(given, at, 0)], 0.0)


def parse_numbers(blob: np.ndarray) -> np.ndarray | None:
    """All whitespace-separated numbers of the bytes ``blob`` as float64, or None if some token is not a number."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        try:
            return np.fromstring(blob.tobytes(), dtype=np.float64, sep=" ")
        except (DeprecationWarning, ValueError):
            return None


def _first_bad_line(blob: np.ndarray, blob_nl: np.ndarray) -> int:
    """Index of the first line of ``blob`` whose tokens do not all parse as numbers (error path only)."""
    lo, hi = 0, len(blob_nl) - 1  # bisection: the lines before `lo` parse, some line up to `hi` does not
    while lo < hi:
        mid = (lo + hi) // 2
        if parse_numbers(blob[:blob_nl[mid] + 1]) is None:
            hi = mid
        else:
            lo = mid + 1
    return lo


def _parse_faces(b, start, tag, end, lines, counts: list[np.ndarray], kinds: tuple[bool, bool], label: str):
    """Fan triangles of the ``f`` lines: vertex (T, 3), texture and normal (T, 3) or None, face lines, corners per face.

    ``counts`` are the v, vt and vn records before each face line (for
    negative indices).  With either of ``kinds`` the corners are read whole
    (:func:`~mcocl.render.obj_corners.corner_indices`), and the texture
    (normal) indices are kept where ``kinds`` says so: 0-based, -1 where a
    corner gives none.  Without, only the vertex indices are read, as before
    texture coordinates and normals were read.
    """
    if not len(start):
        none = np.zeros((0, 3), np.int64)
        return none, none if kinds[0] else None, none if kinds[1] else None, lines, np.zeros(0, np.int64)
    blob = _select_lines(b, start, end, tag)
    blob_nl = np.cumsum(end + 1 - start) - 1
    corner = _token_starts(blob)
    if any(kinds):
        c = corner_indices(blob, corner)
        columns, ok = [(c.v, None), (c.t, c.has_t) if kinds[0] else None, (c.n, c.has_n) if kinds[1] else None], c.ok
    else:
        idx, ok = vertex_indices(blob, corner)
        columns = [(idx, None), None, None]

    def line_of(k: int) -> int:
        return int(lines[np.searchsorted(blob_nl, corner[k])])

    if not ok.all():
        at = np.argmin(ok)
        raise InputError(f"{label}:{line_of(at)}: bad face corner {_token(blob, corner[at])!r}")
    per_face = _per_line(corner, blob_nl)
    few = np.flatnonzero(per_face < 3)
    if len(few):
        raise InputError(f"{label}:{lines[few[0]]}: a face needs at least three corners")
    out = []
    for column, count, (what, called) in zip(columns, counts, KINDS):
        if column is None:
            out.append(None)
            continue
        idx, has = column
        zero = np.flatnonzero(idx == 0 if has is None else has & (idx == 0))
        if len(zero):
            raise InputError(f"{label}:{line_of(zero[0])}: OBJ indices start at 1, got 0")
        idx = np.where(idx > 0, idx - 1, np.repeat(count, per_face) + idx)
        bad = np.flatnonzero(idx < 0)  # (a corner without this index has 0: `count` here)
        if len(bad):
            k = bad[0]
            n = int(np.repeat(count, per_face)[k])
            raise InputError(f"{label}:{line_of(k)}: {what} index {idx[k]} is outside 0..{n - 1} (0-based): corner "
                             f"{_token(blob, corner[k])!r} counts back past the first of the {n} {called} before it")
        if has is not None:
            idx[~has] = -1
        out.append(fan_triangles(idx, per_face))
    return out[0], out[1], out[2], lines, per_face


def fan_triangles(idx: np.ndarray, per_face: np.ndarray) -> np.ndarray:
    """Triangles (T, 3) of polygons given as their corners ``idx`` back to back, ``per_face[i]`` (>= 3) each.

    Face i becomes the fan (c0, ck, ck+1), k = 1 .. m-2, of its m corners.
    """
    if np.all(per_face == 3):
        return idx.reshape(-1, 3)
    first_corner = np.cumsum(per_face) - per_face
    ntri = per_face - 2
    face = np.repeat(np.arange(len(per_face)), ntri)
    k = np.arange(int(ntri.sum())) - np.repeat(np.cumsum(ntri) - ntri, ntri) + 1
    c0 = first_corner[face]
    return np.stack([idx[c0], idx[c0 + k], idx[c0 + k + 1]], axis=1)


__all__ = ["CHUNK_BYTES", "ObjAttributeWarning", "ObjMesh", "fan_triangles", "parse_numbers", "parse_obj"]
