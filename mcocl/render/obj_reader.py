"""Wavefront OBJ parsing with whole-buffer NumPy operations (no Python loop over lines or faces).

Only ``v`` and ``f`` records matter here (positions and polygons); every
other record (``vt``, ``vn``, ``g``, ``usemtl``, ...) is skipped.  The file
is handled as one byte array:

1. line breaks are normalised (``\\r\\n`` and ``\\r`` become ``\\n``, as
   :meth:`str.splitlines` reads them), other whitespace becomes a space and
   ``#`` comments are blanked;
2. each line's first token is read at its start (after any indentation),
   which classifies the line as a vertex, a face or something else;
3. the vertex lines, and the face lines, are gathered into two buffers;
   token boundaries found by byte comparisons give how many numbers each
   line holds; the vertices' numbers are parsed by one ``np.fromstring``
   call, the faces' vertex indices by digit arithmetic at the start of each
   corner (a loop over digit positions).

Faces may be ``i``, ``i/t``, ``i//n`` or ``i/t/n``: only the number before
a corner's first slash is read.  Negative indices count back from the last vertex
read before the face's line; polygons become fans ``(0, k, k + 1)``.
Malformed records raise :class:`~mcocl.errors.InputError` naming the line.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..errors import InputError

_SPACE, _NL = 32, 10
_SLASH, _HASH = ord("/"), ord("#")
_MAX_DIGITS = 18  # an index of more digits cannot be a vertex of a mesh that fits in memory
_PAD = np.full(8, _SPACE, np.uint8)
CHUNK_BYTES = 1 << 23  # text parsed at once (whole lines): see parse_obj


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


def _select_lines(b: np.ndarray, start: np.ndarray, end: np.ndarray, tag: np.ndarray) -> np.ndarray:
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
    offset = np.cumsum(length) - length
    blob[offset + (tag - start)] = _SPACE
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


def parse_obj(data: bytes, label: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) float64 and triangles (T, 3) int64 (0-based, not range-checked) of OBJ text.

    The text is handled in chunks of whole lines of about :data:`CHUNK_BYTES`
    (a loop over chunks, not lines): a chunk's temporaries are small enough
    for the allocator to reuse them, where whole-file temporaries would be
    fresh memory every time (10^7 triangles: 6 of 8.6 CPU-seconds were page
    faults before).

    Raises:
        InputError: a malformed ``v`` or ``f`` record; the message is
            ``"{label}:{line}: ..."``.
    """
    if b"\r" in data:
        data = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    if b"\t" in data or b"\v" in data or b"\f" in data:
        data = data.translate(bytes.maketrans(b"\t\v\f", b"   "))
    if not data.endswith(b"\n"):
        data += b"\n"  # a final break ends the last line
    vertices, faces = [np.zeros((0, 3))], [np.zeros((0, 3), np.int64)]
    pos = lines = verts = 0
    while pos < len(data):
        end = data.rfind(b"\n", pos, pos + CHUNK_BYTES)
        if end < 0:  # a line longer than a chunk
            end = data.find(b"\n", pos)
        v, f, n = _parse_chunk(data, pos, end + 1, lines, verts, label)
        vertices.append(v)
        faces.append(f)
        pos, lines, verts = end + 1, lines + n, verts + len(v)
    return np.concatenate(vertices), np.concatenate(faces)


def _parse_chunk(data: bytes, first: int, stop: int, lines_before: int, verts_before: int,
                 label: str) -> tuple[np.ndarray, np.ndarray, int]:
    """Vertices, triangles and line count of the whole lines ``data[first:stop]`` (after the given counts)."""
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
    after = b[tag + 1 - (b[tag] == _NL)]  # the byte after the tag (the break itself on an empty line)
    tag_alone = (after == _SPACE) | (after == _NL)
    is_v = (b[tag] == ord("v")) & tag_alone
    is_f = (b[tag] == ord("f")) & tag_alone
    vl, fl = np.flatnonzero(is_v), np.flatnonzero(is_f)
    vertices = _parse_vertices(b, start[vl], tag[vl], line_end[vl], lines_before + 1 + vl, label)
    faces = _parse_faces(b, start[fl], tag[fl], line_end[fl], lines_before + 1 + fl,
                         verts_before + np.cumsum(is_v)[fl], label)
    return vertices, faces, len(line_end)


def _parse_vertices(b, start, tag, end, lines, label) -> np.ndarray:
    """The first three numbers of each ``v`` line, float64 (V, 3)."""
    if not len(start):
        return np.zeros((0, 3))
    blob = _select_lines(b, start, end, tag)
    blob_nl = np.cumsum(end + 1 - start) - 1
    ts = _token_starts(blob)
    per_line = _per_line(ts, blob_nl)
    short = np.flatnonzero(per_line < 3)
    if len(short):
        raise InputError(f"{label}:{lines[short[0]]}: a vertex needs three numbers")
    nums = parse_numbers(blob)
    if nums is None or len(nums) != len(ts):
        bad = _first_bad_line(blob, blob_nl)
        raise InputError(f"{label}:{lines[bad]}: a vertex needs three numbers")
    if np.all(per_line == 3):
        return nums.reshape(-1, 3)
    first_num = np.cumsum(per_line) - per_line
    return nums[first_num[:, None] + np.arange(3)]


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


def _parse_faces(b, start, tag, end, lines, verts_before, label) -> np.ndarray:
    """Fan triangles (T, 3) of the ``f`` lines, 0-based vertex indices."""
    if not len(start):
        return np.zeros((0, 3), np.int64)
    blob = _select_lines(b, start, end, tag)
    blob_nl = np.cumsum(end + 1 - start) - 1
    corner = _token_starts(blob)
    idx, ok = _parse_indices(blob, corner)
    if not ok.all():
        at = corner[np.argmin(ok)]
        line = lines[np.searchsorted(blob_nl, at)]
        raise InputError(f"{label}:{line}: bad face corner {_token(blob, at)!r}")
    per_face = _per_line(corner, blob_nl)
    few = np.flatnonzero(per_face < 3)
    if len(few):
        raise InputError(f"{label}:{lines[few[0]]}: a face needs at least three corners")
    zero = np.flatnonzero(idx == 0)
    if len(zero):
        raise InputError(f"{label}:{lines[np.searchsorted(blob_nl, corner[zero[0]])]}: OBJ indices start at 1, got 0")
    idx = np.where(idx > 0, idx - 1, np.repeat(verts_before, per_face) + idx)
    return fan_triangles(idx, per_face)


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


_ASCII_ZEROS = np.uint64(0x3030303030303030)


def _parse_indices(blob: np.ndarray, corner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The vertex index that begins each corner token (``[+-]digits``, then a slash or the token's end).

    What follows a slash (texture and normal indices) is not read.  The
    eight bytes at each number's start are read as one little-endian 64-bit
    word and up to eight digits are converted at once (SWAR: digit pairs,
    then quadruples, then octets, as in Lemire's fast integer parsing);
    longer numbers continue digit by digit.  ``blob`` must end with at least
    eight separator bytes.  Returns (indices, whether each corner is well formed).
    """
    c = blob[corner]
    neg = c == ord("-")
    pos = corner + (neg | (c == ord("+")))
    window = np.lib.stride_tricks.as_strided(blob, shape=(len(blob) - 7, 8), strides=(1, 1), writeable=False)
    chars = window[pos]  # (C, 8) uint8, contiguous
    # Operations in place: on a fresh process every new large array costs page faults.
    # Leading digits: below the lowest set byte of the "not a digit" mask; with w = that byte's
    # bit, the popcount of w - 1 is 8 x its index (64 when no byte is set: eight digits).
    other = np.subtract(chars, np.uint8(ord("0")))
    np.greater_equal(other, 10, out=other.view(bool))
    other = other.view("<u8").ravel()
    low = np.invert(other)
    low += np.uint64(1)
    low &= other
    low -= np.uint64(1)
    ndig = (np.bitwise_count(low) >> 3).astype(np.int64)
    del other, low
    x = chars.view("<u8").ravel()
    x -= _ASCII_ZEROS
    x <<= (8 * (8 - np.maximum(ndig, 1))).astype(np.uint64)  # keep the digits, as the top of 8 with leading zeros
    y = np.empty_like(x)
    for shift, mul, mask in ((8, 10, 0x00FF00FF00FF00FF), (16, 100, 0x0000FFFF0000FFFF), (32, 10000, 0xFFFFFFFF)):
        np.right_shift(x, np.uint64(shift), out=y)
        x *= np.uint64(mul)
        x += y
        x &= np.uint64(mask)
    del y
    val = x.view(np.int64)
    val[ndig == 0] = 0
    pos += ndig
    going = np.flatnonzero(ndig == 8)  # more than eight digits: rare
    for _ in range(_MAX_DIGITS - 8 + 1):
        d = blob[pos[going]] - np.uint8(ord("0"))
        more = d < 10
        going, d = going[more], d[more]
        if not len(going):
            break
        val[going] = val[going] * 10 + d
        ndig[going] += 1
        pos[going] += 1
    stop = blob[pos]
    ok = (ndig > 0) & (ndig <= _MAX_DIGITS) & ((stop <= _SPACE) | (stop == _SLASH))
    return np.where(neg, -val, val), ok


__all__ = ["CHUNK_BYTES", "fan_triangles", "parse_numbers", "parse_obj"]
