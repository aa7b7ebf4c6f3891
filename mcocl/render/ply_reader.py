"""Stanford PLY parsing with whole-buffer NumPy operations (no Python loop over vertices or faces).

The header (``ply``, ``format ascii|binary_little_endian|binary_big_endian
1.0``, ``element NAME COUNT``, ``property TYPE NAME``, ``property list
COUNT_TYPE ITEM_TYPE NAME``, ``comment``/``obj_info``, ``end_header``) is read
line by line; the body is addressed by *positions*: bytes in a binary file,
numbers in an ASCII one (whose body is parsed once, by ``np.fromstring``, into
float64 — exact for every integer a PLY index type holds).

An element whose records all have the same layout (every vertex element, and a
face element whose lists all have the length of the first) is read as one
block: a NumPy structured dtype over the bytes (``np.frombuffer``), or a
reshape of the numbers.  Otherwise the record starts are found by a
vectorised scan: the end of a record that would start at *every* position is
computed at once, and the chain of records from the element's start is
followed by pointer doubling (about ``log2(count / 4096)`` gathers over the
positions, then at most 4096 gathers of the starts found so far).

Read: the ``vertex`` element's ``x``, ``y``, ``z`` (required), ``nx``, ``ny``,
``nz`` (kept when all three are present) and texture coordinates (``u``/``v``,
``s``/``t``, ``texture_u``/``texture_v`` or ``texture_s``/``texture_t``), the
``face`` element's ``vertex_indices`` (or ``vertex_index``) lists; polygons
become fans ``(0, k, k + 1)``.  Every other element and property is skipped.
Malformed files raise :class:`~mcocl.errors.InputError` naming the file.

An ASCII body whose elements each have one layout (the usual file), or whose
faces alone differ in length, is first read a chunk of whole lines at a time
(:class:`_AsciiStream`, from the open file through
:class:`~mcocl.render.file_window.FileWindow` when given one) straight into
the mesh's arrays, so that the read holds the mesh and one chunk (issue 13:
the whole-body parse held 3x the file, besides the file); anything else,
errors included, is left to the whole-body parse of the whole file, which
gives the same arrays and messages.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import BinaryIO

import numpy as np

from ..errors import InputError
from .file_window import FileWindow
from .obj_reader import fan_triangles, parse_numbers

# PLY's scalar types (both spellings of the 1.0 format) → NumPy type codes without byte order.
TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}
FORMATS = {"ascii": None, "binary_little_endian": "<", "binary_big_endian": ">"}
UV_NAMES = (("u", "v"), ("s", "t"), ("texture_u", "texture_v"), ("texture_s", "texture_t"))
INDEX_NAMES = ("vertex_indices", "vertex_index")
_MAX_CORNERS = 1 << 16  # a polygon of more corners is a corrupt count, not a face
_SCAN_STEPS = 4096  # at most this many gathers finish a scan after its doubling levels


@dataclass
class Prop:
    """One property of an element: a scalar (``count_type`` None) or a list."""

    name: str
    type: str  # NumPy code without byte order
    count_type: str | None = None


@dataclass
class Element:
    """One ``element`` of the header with its properties."""

    name: str
    count: int
    props: list[Prop]


@dataclass
class PlyMesh:
    """What a PLY file gives a shape: vertices (V, 3), triangles (T, 3) and optional per-vertex data."""

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None = None
    uvs: np.ndarray | None = None


def parse_header(data: bytes, label: str) -> tuple[str | None, list[Element], int]:
    """Byte order (None for ASCII), elements and the body's first byte of a PLY file."""
    if not (data.startswith(b"ply\n") or data.startswith(b"ply\r\n")):
        raise InputError(f"{label}: not a PLY file (it must begin with the line 'ply')")
    end = data.find(b"end_header")
    while end >= 0 and data[end - 1:end] != b"\n":
        end = data.find(b"end_header", end + 1)
    if end < 0:
        raise InputError(f"{label}: the PLY header has no 'end_header' line")
    body = data.find(b"\n", end)
    if body < 0 or data[end + 10:body].strip(b"\r \t"):
        raise InputError(f"{label}: the PLY header's 'end_header' line does not end")
    order, elements, seen_format = None, [], False
    for n, raw in enumerate(data[:end].decode("latin-1").splitlines()[1:], 2):
        words = raw.split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        at = f"{label}:{n}"
        if words[0] == "format":
            if len(words) != 3 or words[1] not in FORMATS or words[2] != "1.0":
                raise InputError(f"{at}: bad format line {raw.strip()!r} (expected 'format ascii|binary_little_endian|"
                                 "binary_big_endian 1.0')")
            order, seen_format = FORMATS[words[1]], True
        elif words[0] == "element":
            if len(words) != 3 or not (words[2].isascii() and words[2].isdigit()):
                raise InputError(f"{at}: bad element line {raw.strip()!r} (expected 'element NAME COUNT')")
            if any(e.name == words[1] for e in elements):
                raise InputError(f"{at}: a second element {words[1]!r}")
            elements.append(Element(words[1], int(words[2]), []))
        elif words[0] == "property":
            if not elements:
                raise InputError(f"{at}: a property before any element")
            elements[-1].props.append(_prop(words, raw, at))
        else:
            raise InputError(f"{at}: unknown header line {raw.strip()!r}")
    if not seen_format:
        raise InputError(f"{label}: the PLY header has no 'format' line")
    return order, elements, body + 1


def _prop(words: list[str], raw: str, at: str) -> Prop:
    if len(words) == 3 and words[1] in TYPES:
        return Prop(words[2], TYPES[words[1]])
    if len(words) == 5 and words[1] == "list" and words[2] in TYPES and words[3] in TYPES:
        if TYPES[words[2]][0] == "f":
            raise InputError(f"{at}: a list's count type must be an integer type, got {words[2]!r}")
        return Prop(words[4], TYPES[words[3]], TYPES[words[2]])
    raise InputError(f"{at}: bad property line {raw.strip()!r} (expected 'property TYPE NAME' or "
                     "'property list COUNT_TYPE ITEM_TYPE NAME' with TYPE one of " + ", ".join(TYPES) + ")")


def _integer_only(el: Element) -> bool:
    """Every value of the element (scalars, list counts and items) is of an integer type."""
    return all(p.type[0] in "iu" and (p.count_type is None or p.count_type[0] in "iu") for p in el.props)


def _part_numbers(blob: np.ndarray, integer: bool) -> np.ndarray | None:
    """The numbers of part of an ASCII body: int64 when ``integer`` and every token is one (else float64),
    or None if some token is not a number.  A part of whitespace alone holds none (``np.fromstring``
    would return one number, 0 or -1, for it)."""
    out = None
    if integer:
        with warnings.catch_warnings():
            warnings.simplefilter("error", DeprecationWarning)
            try:
                out = np.fromstring(blob.tobytes(), dtype=np.int64, sep=" ")
            except (DeprecationWarning, ValueError):
                pass
    if out is None:
        out = parse_numbers(blob)
    if out is not None and len(out) == 1 and not np.any((blob != 32) & ((blob < 9) | (blob > 13))):
        return np.zeros(0)
    return out


def _line_end(blob: np.ndarray, lines: int) -> int | None:
    """The position after the ``lines``-th newline of ``blob`` (0 for none), or None if it has fewer.

    Newlines are counted by ``bytes.count`` a chunk at a time and indexed only in the chunk that holds
    the last one: an index array of every line end of a big body costs more than parsing the faces."""
    raw = blob.data.cast("B") if lines else None
    return _nth_line_end(lambda pos, n: bytes(raw[pos:pos + n]), len(blob), lines)


def _nth_line_end(read: Callable[[int, int], bytes], length: int, lines: int) -> int | None:
    """:func:`_line_end` of ``length`` bytes given by ``read(pos, n)`` (the ``n`` bytes from ``pos``)."""
    pos, left, chunk = 0, lines, 1 << 22
    while left > 0:
        if pos >= length:
            return None
        part = read(pos, chunk)
        n = part.count(b"\n")
        if n >= left:
            return pos + int(np.flatnonzero(np.frombuffer(part, np.uint8) == 10)[left - 1]) + 1
        left -= n
        pos += chunk
    return pos


def ascii_numbers(blob: np.ndarray, elements: list[Element]) -> np.ndarray | None:
    """Every number of an ASCII body as float64, or None if some token is not a number.

    The trailing elements whose values are all integers (the faces, in the usual
    file) are parsed as int64, which ``np.fromstring`` does about four times faster
    than as float64, from the line after the records before them on (one record a
    line, as PLY writers do).  The numbers are the same wherever that split falls
    (it is at a line end, between two tokens): a body laid out otherwise, or an
    integer element holding a token such as ``1e3`` or ``2.0``, only makes that part
    fall back to the float64 parse.  Integers beyond int64 saturate, as the float64
    parse's did past 2^63 once cast: either way an index out of range, refused later.
    """
    k = len(elements)
    while k > 0 and _integer_only(elements[k - 1]):
        k -= 1
    lines_before = sum(e.count for e in elements[:k])
    if k == len(elements):
        return parse_numbers(blob)
    split = _line_end(blob, lines_before)
    if split is None:
        return parse_numbers(blob)
    head = _part_numbers(blob[:split], integer=False)
    tail = _part_numbers(blob[split:], integer=True)
    if head is None or tail is None:
        return None
    out = np.empty(len(head) + len(tail))
    out[:len(head)] = head
    out[len(head):] = tail
    return out


class _Body:
    """The body as positions: bytes of a binary file (``order`` '<' or '>') or numbers of an ASCII one."""

    def __init__(self, data: bytes, start: int, order: str | None, label: str, elements: list[Element]) -> None:
        self.order, self.label = order, label
        if order is None:
            nums = ascii_numbers(np.frombuffer(data, np.uint8, offset=start), elements)
            if nums is None:
                raise InputError(f"{label}: the ASCII PLY body holds something that is not a number")
            self.values = nums
        else:
            self.values = np.frombuffer(data, np.uint8, offset=start)
        self.length = len(self.values)

    def size(self, code: str) -> int:
        """Positions one value of type ``code`` takes."""
        return 1 if self.order is None else int(code[1])

    def read(self, pos: np.ndarray, code: str) -> np.ndarray:
        """Values of type ``code`` at positions ``pos`` (clipped into the body; callers check the range)."""
        if self.order is None:
            return self.values[np.clip(pos, 0, self.length - 1)]
        s = int(code[1])
        if s == 1:  # (u)char: the bytes themselves
            return self.values[np.clip(pos, 0, self.length - 1)].view(code)
        idx = np.clip(pos, 0, self.length - s)[:, None] + np.arange(s)
        return np.ascontiguousarray(self.values[idx]).view(self.order + code).ravel()

    def counts(self, pos: np.ndarray, code: str) -> np.ndarray:
        """List lengths at ``pos`` as int64; -1 where the value is no valid length."""
        c = self.read(pos, code)
        if self.order is None:
            ok = (c == np.floor(c)) & (c >= 0) & (c <= _MAX_CORNERS)
            return np.where(ok, c, -1).astype(np.int64)
        c = c.astype(np.int64)
        return np.where((c >= 0) & (c <= _MAX_CORNERS), c, -1)

    def record_ends(self, el: Element, pos: np.ndarray) -> np.ndarray:
        """End positions of records of ``el`` starting at ``pos``; ``length + 1`` where none fits."""
        q = pos.astype(np.int64)
        bad = np.zeros(len(q), bool)
        for p in el.props:
            if p.count_type is None:
                q = q + self.size(p.type)
            else:
                n = self.counts(q, p.count_type)
                bad |= (n < 0) | (q + self.size(p.count_type) > self.length)
                q = q + self.size(p.count_type) + np.maximum(n, 0) * self.size(p.type)
        bad |= q > self.length
        q[bad] = self.length + 1
        return q

    def block(self, el: Element, start: int, lengths: list[int]) -> dict[str, np.ndarray] | None:
        """Every record of ``el`` with list lengths ``lengths`` read as one block; None if they differ or it overruns."""
        fields, k = [], 0
        for i, p in enumerate(el.props):
            if p.count_type is not None:
                fields.append((f"c{i}", p.count_type, 1))
                fields.append((f"p{i}", p.type, lengths[k]))
                k += 1
            else:
                fields.append((f"p{i}", p.type, 1))
        width = sum(self.size(t) * m for _, t, m in fields)
        if start + el.count * width > self.length:
            return None
        if self.order is None:
            table = self.values[start:start + el.count * width].reshape(el.count, width)
            cols, at = {}, 0
            for name, _, m in fields:
                cols[name] = table[:, at:at + m]
                at += m
        else:
            dt = np.dtype([(name, self.order + t, (m,)) for name, t, m in fields])
            rec = np.frombuffer(self.values, dt, count=el.count, offset=start)
            cols = {name: rec[name] for name, _, _ in fields}
        k = 0
        for i, p in enumerate(el.props):
            if p.count_type is not None:
                if not np.all(cols[f"c{i}"].reshape(-1) == lengths[k]):
                    return None
                k += 1
        return {p.name: cols[f"p{i}"].reshape(el.count, -1) if p.count_type is not None else cols[f"p{i}"].reshape(-1)
                for i, p in enumerate(el.props)}

    def starts(self, el: Element, start: int) -> np.ndarray:
        """Start positions of the ``el.count`` records from ``start``: the vectorised scan (pointer doubling)."""
        # int32 where it fits: the doubling's gathers are bound by memory traffic
        nxt = np.empty(self.length - start + 2, np.int32 if self.length < 2**31 - 2 else np.int64)
        nxt[:-2] = self.record_ends(el, np.arange(start, self.length)) - start
        nxt[-2:] = self.length - start + 1  # no record starts at the body's end or beyond
        # Doubling: with `found` the first 2^k record starts and `jump` = next^(2^k), one gather extends
        # both.  Each level costs a pass over all positions, so it stops once the remaining
        # count / 2^k steps (a gather of 2^k starts each) are few; those steps finish the chain.
        found, jump = np.zeros(1, nxt.dtype), nxt
        while len(found) < el.count and len(found) * _SCAN_STEPS < el.count:
            found = np.concatenate([found, jump[found]])
            jump = jump[jump]
        blocks, have = [found], len(found)
        while have < el.count:
            blocks.append(jump[blocks[-1]])
            have += len(found)
        found = np.concatenate(blocks)[:el.count]
        if found[-1] >= self.length - start or nxt[found[-1]] > self.length - start:
            raise InputError(f"{self.label}: the '{el.name}' element's {el.count} records overrun the file "
                             "(truncated, or a count in the header or a list length is wrong)")
        return found.astype(np.int64) + start


def _element(body: _Body, el: Element, start: int, want: set[str]) -> tuple[dict, int]:
    """The wanted properties of ``el`` (scalars (N,), lists (lengths, flat values)) and the position after it."""
    if el.count == 0 or not el.props:
        return {}, start
    overrun = (f"{body.label}: the '{el.name}' element's {el.count} records overrun the file "
               "(truncated, or a count in the header or a list length is wrong)")
    # Every record takes at least its scalars and list counts: a count beyond that is refused before any
    # allocation of its size.
    least = sum(body.size(p.count_type or p.type) for p in el.props)
    if el.count > (body.length - start) // least:
        raise InputError(overrun)
    first_end = body.record_ends(el, np.array([start]))[0]
    if first_end > body.length:
        raise InputError(f"{body.label}: the '{el.name}' element's first record overruns the file "
                         "(truncated, or a count in the header is wrong)")
    lengths, q = [], start
    for p in el.props:  # list lengths of the first record
        if p.count_type is not None:
            lengths.append(int(body.counts(np.array([q]), p.count_type)[0]))
            q += body.size(p.count_type) + lengths[-1] * body.size(p.type)
        else:
            q += body.size(p.type)
    cols = body.block(el, start, lengths)
    if cols is not None:
        out = {}
        for p in el.props:
            if p.name in want:
                v = cols[p.name]
                # a list stays (count, length): the fan of triangles is then one copy of it (parse_ply);
                # the lengths, all equal, a broadcast scalar: no array of them
                out[p.name] = (np.broadcast_to(np.int64(v.shape[1]), (el.count,)), v) if p.count_type else v
        return out, start + el.count * (first_end - start)
    if not any(p.count_type is not None for p in el.props):
        raise InputError(overrun)  # a fixed layout reads as a block unless it overruns
    rec = body.starts(el, start)
    out, q = {}, rec.copy()
    for p in el.props:
        if p.count_type is None:
            if p.name in want:
                out[p.name] = body.read(q, p.type)
            q = q + body.size(p.type)
            continue
        n = body.counts(q, p.count_type)
        first = q + body.size(p.count_type)
        if p.name in want:
            item = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
            out[p.name] = (n, body.read(np.repeat(first, n) + item * body.size(p.type), p.type))
        q = first + n * body.size(p.type)
    return out, int(q[-1])


def _columns(values: dict[str, np.ndarray], names: tuple[str, ...]) -> np.ndarray:
    """The properties ``names`` side by side (N, len(names)), written straight into one array.

    float32 when every one is float32 (a binary file's usual ``float``: its values exactly, in half
    the memory of float64; :func:`mcocl.render.compiled.compile_scene` widens them, exactly, where it
    transforms them), else float64 (an ASCII file's numbers, doubles, integer types: all exact)."""
    dtype = np.float32 if all(values[n].dtype.kind == "f" and values[n].dtype.itemsize == 4 for n in names) else np.float64
    out = np.empty((len(values[names[0]]), len(names)), dtype)
    for k, name in enumerate(names):
        out[:, k] = values[name]
    return out


def _index_type(item: np.dtype) -> type:
    """The type of a binary file's triangles: int32 holds every index of a type up to 32 bits but
    ``uint`` (uint32: negatives do not occur), int64 the 64-bit ones (a PLY has none; kept general)."""
    if item.itemsize < 4 or (item.itemsize == 4 and item.kind == "i"):
        return np.int32
    return np.uint32 if item.itemsize == 4 else np.int64


ASCII_CHUNK_BYTES = 1 << 18  # ASCII body text parsed at once (whole lines): see _AsciiStream


class _UnstreamedError(Exception):
    """The streamed ASCII read met what it leaves to the whole-body parse: any error, or records of differing layouts."""


class _DifferingLengthsError(_UnstreamedError):
    """A list of an element's record has another length than the first record's (the faces of a mixed mesh)."""


def _chunk_numbers(blob: np.ndarray, integer: bool) -> np.ndarray:
    """The numbers of whole lines of an ASCII body as float64, parsed as :func:`ascii_numbers` parses its part.

    An integer part parses as int64 or not at all: where one token is not an integer, ``ascii_numbers``
    parses the *whole* tail as float64 (which differs from int64 past 2^63), so that case is left to it.
    """
    if not integer:
        out = _part_numbers(blob, integer=False)
        if out is None:
            raise _UnstreamedError
        return out
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        try:
            out = np.fromstring(blob.tobytes(), dtype=np.int64, sep=" ")
        except (DeprecationWarning, ValueError):
            raise _UnstreamedError from None
    if len(out) == 1 and not np.any((blob != 32) & ((blob < 9) | (blob > 13))):
        return np.zeros(0)
    return out.astype(np.float64)


class _AsciiStream:
    """The numbers of an ASCII body, parsed about :data:`ASCII_CHUNK_BYTES` of whole lines at a time (issue 13).

    Only the numbers not yet consumed are held, so a read costs the file's bytes, its mesh and one
    chunk, where the whole-body parse held every number as float64 and a copy besides (3x the file).
    The body parses as float64 before byte ``split`` and as int64 after it, as :func:`ascii_numbers`
    splits it; a chunk never crosses ``split`` or ends inside a line, so no token is cut.
    """

    def __init__(self, data: bytes | FileWindow, start: int, split: int) -> None:
        self.data, self.pos, self.split = data, start, split
        self.buf, self.used = np.zeros(0), 0

    def _parse_next(self) -> bool:
        """Parse the next chunk onto the numbers not yet consumed; False at the body's end."""
        if self.pos >= len(self.data):
            return False
        limit = self.split if self.pos < self.split else len(self.data)
        stop = min(self.pos + ASCII_CHUNK_BYTES, limit)
        if stop < limit:
            nl = self.data.rfind(b"\n", self.pos, stop)
            if nl < 0:  # a line longer than a chunk
                nl = self.data.find(b"\n", stop, limit)
            stop = limit if nl < 0 else nl + 1
        blob = (np.frombuffer(self.data, np.uint8, stop - self.pos, self.pos) if isinstance(self.data, bytes)
                else self.data.bytes_view(self.pos, stop))
        nums = _chunk_numbers(blob, self.pos >= self.split)
        self.pos = stop
        self.buf = np.concatenate([self.buf[self.used:], nums]) if self.used < len(self.buf) else nums
        self.used = 0
        return True

    def mark(self) -> tuple:
        """The stream's place, to go back to with :meth:`rewind` (what it holds is not changed, only replaced)."""
        return self.pos, self.buf, self.used

    def rewind(self, place: tuple) -> None:
        """Go back to a place :meth:`mark` gave (a file's bytes from there are read again)."""
        self.pos, self.buf, self.used = place

    def available(self) -> np.ndarray:
        """The numbers parsed and not yet consumed."""
        return self.buf[self.used:]

    def peek(self, k: int) -> float:
        """The ``k``-th number after those consumed."""
        while self.used + k >= len(self.buf):
            if not self._parse_next():
                raise _UnstreamedError
        return float(self.buf[self.used + k])

    def records(self, count: int, width: int):
        """The next ``count`` records of ``width`` numbers, as (k, width) blocks of at most a chunk's numbers."""
        left = count
        while left > 0:
            k = min(left, (len(self.buf) - self.used) // width)
            if k == 0:
                if not self._parse_next():
                    raise _UnstreamedError
                continue
            yield self.buf[self.used:self.used + k * width].reshape(k, width)
            self.used += k * width
            left -= k

    def at_end(self) -> bool:
        """Whether every number of the body has been consumed."""
        while self.used == len(self.buf):
            if not self._parse_next():
                return True
        return False


def _ascii_split(data: bytes | FileWindow, start: int, elements: list[Element]) -> int:
    """The byte where :func:`ascii_numbers` starts parsing the body as int64 (``len(data)``: nowhere)."""
    k = len(elements)
    while k > 0 and _integer_only(elements[k - 1]):
        k -= 1
    if k == len(elements):
        return len(data)
    lines = sum(e.count for e in elements[:k])
    if isinstance(data, bytes):
        split = _line_end(np.frombuffer(data, np.uint8, offset=start), lines)
    else:  # read apart from the window: the body's lines counted a block at a time, never held
        fd = data.f.fileno()
        split = _nth_line_end(lambda pos, n: os.pread(fd, min(n, len(data) - start - pos), start + pos),
                              len(data) - start, lines)
    return len(data) if split is None else start + split


def _first_lengths(stream: _AsciiStream, el: Element) -> list[int]:
    """The list lengths of the next record of ``el`` (each a whole number in 0 .. _MAX_CORNERS)."""
    lengths, k = [], 0
    for p in el.props:
        if p.count_type is None:
            k += 1
            continue
        c = stream.peek(k)
        if not (c == np.floor(c) and 0 <= c <= _MAX_CORNERS):
            raise _UnstreamedError
        lengths.append(int(c))
        k += 1 + int(c)
    return lengths


def _stream_element(stream: _AsciiStream, el: Element, dest: dict[str, tuple[np.ndarray, int | None]]) -> None:
    """Consume the records of ``el``, all of the layout of the first, writing property ``name`` into ``dest[name]``.

    ``dest`` maps a scalar to (array, column) and a list to (array (count, length), None); the values are
    cast as :func:`parse_ply` casts them.  Records of another layout raise :class:`_UnstreamedError`.
    """
    if el.count == 0 or not el.props:
        return
    lengths = _first_lengths(stream, el)
    at, lists, col_of, k = 0, [], {}, 0
    for p in el.props:  # (the last of two properties of one name wins, as in _Body.block)
        if p.count_type is None:
            col_of[p.name] = (at, 1, False)
            at += 1
        else:
            lists.append((at, lengths[k]))
            col_of[p.name] = (at + 1, lengths[k], True)
            at += 1 + lengths[k]
            k += 1
    width, row = at, 0
    for block in stream.records(el.count, width):
        for c, n in lists:
            if not np.all(block[:, c] == n):
                raise _DifferingLengthsError
        for name, (array, column) in dest.items():
            c, n, is_list = col_of[name]
            if is_list != (column is None):  # a list and a scalar of one name: left to the whole-body parse
                raise _UnstreamedError
            if column is None:
                part = block[:, c:c + n]
                if not np.all(part == np.floor(part)):
                    raise _UnstreamedError
                with np.errstate(invalid="ignore"):
                    array[row:row + len(block)] = part
            else:
                array[row:row + len(block), column] = block[:, c]
        row += len(block)


def _stream_polygons(stream: _AsciiStream, count: int) -> np.ndarray:
    """The fan triangles (T, 3) int64 of ``count`` records ``n i_1 .. i_n`` of differing ``n``, as
    :func:`parse_ply` fans them, parsed a chunk at a time.

    A chunk's record starts are found as :meth:`_Body.starts` finds them: the end of a record that would
    start at every position, then the chain from the first start by pointer doubling.  A length below 3
    or above :data:`_MAX_CORNERS`, a number that is not a whole one, or too few numbers raise
    :class:`_UnstreamedError` (the whole-body parse then names the fault).
    """
    parts, left = [], count
    while left > 0:
        avail = stream.available()
        size = len(avail)
        if size:
            first = avail[0]  # (a bad first length would have the stream read on for its record)
            if not (first == np.floor(first) and 3 <= first <= _MAX_CORNERS):
                raise _UnstreamedError
            nxt = np.empty(size + 2, np.int64)  # position size: the chunk's end; size + 1: past it
            nxt[:size] = np.arange(1, size + 1) + np.clip(np.nan_to_num(avail, nan=size), 0, size).astype(np.int64)
            np.minimum(nxt, size + 1, out=nxt)
            nxt[size:] = (size, size + 1)
            found, jump = np.zeros(1, np.int64), nxt
            while len(found) < left and found[-1] < size:
                found = np.concatenate([found, jump[found]])
                jump = jump[jump]
            starts = found[found < size][:left]
            starts = starts[nxt[starts] <= size]  # whole records (an unfinished one is the last)
        if not size or not len(starts):
            if not stream._parse_next():
                raise _UnstreamedError
            continue
        n = avail[starts]
        if not np.all((n == np.floor(n)) & (n >= 3) & (n <= _MAX_CORNERS)):
            raise _UnstreamedError
        per_face = n.astype(np.int64)
        item = np.arange(int(per_face.sum())) - np.repeat(np.cumsum(per_face) - per_face, per_face)
        idx = avail[np.repeat(starts + 1, per_face) + item]
        if not np.all(idx == np.floor(idx)):
            raise _UnstreamedError
        with np.errstate(invalid="ignore"):  # an index beyond int64 becomes negative: refused by check_mesh
            parts.append(fan_triangles(idx.astype(np.int64), per_face))
        stream.used += int(nxt[starts[-1]])
        left -= len(starts)
    return np.concatenate(parts) if len(parts) > 1 else parts[0]


def _parse_ascii_streamed(data: bytes | FileWindow, start: int, elements: list[Element], want_v: set[str],
                          index_name: str | None) -> PlyMesh:
    """The mesh of a well-formed ASCII PLY body read by :class:`_AsciiStream`, as :func:`parse_ply` makes it.

    Anything else (a malformed body, faces of differing lengths) raises :class:`_UnstreamedError`: the
    whole-body parse then reads the file, with its errors.
    """
    # A number takes a byte and a separator: counts past that bound are refused (by the whole-body parse)
    # before any array of their size is allocated.
    if sum(e.count * len(e.props) for e in elements) > (len(data) - start + 1) // 2:
        raise _UnstreamedError
    stream = _AsciiStream(data, start, _ascii_split(data, start, elements))
    vertices = normals = uvs = corners = None
    for el in elements:
        dest: dict[str, tuple[np.ndarray, int | None]] = {}
        if el.name == "vertex" and el.count:
            have = want_v & {p.name for p in el.props}
            vertices = np.empty((el.count, 3))
            dest.update({n: (vertices, k) for k, n in enumerate("xyz")})
            if {"nx", "ny", "nz"} <= have:
                normals = np.empty((el.count, 3))
                dest.update({n: (normals, k) for k, n in enumerate(("nx", "ny", "nz"))})
            uv = next((pair for pair in UV_NAMES if set(pair) <= have), None)
            if uv:
                uvs = np.empty((el.count, 2))
                dest.update({n: (uvs, k) for k, n in enumerate(uv)})
        elif el.name == "face" and el.count and el.props:
            names = [p.name for p in el.props if p.count_type]
            # the last list of that name, as parse_ply's checks and _Body.block take it
            length = _first_lengths(stream, el)[len(names) - 1 - names[::-1].index(index_name)]
            if length < 3:
                raise _UnstreamedError
            corners = np.empty((el.count, length), np.int64)
            dest[index_name] = (corners, None)
            if len(el.props) == 1:  # faces of differing lengths are read by _stream_polygons
                place = stream.mark()
                try:
                    _stream_element(stream, el, dest)
                except _DifferingLengthsError:
                    stream.rewind(place)
                    corners = _stream_polygons(stream, el.count)
                continue
        _stream_element(stream, el, dest)
    if not stream.at_end():
        raise _UnstreamedError
    if vertices is None:
        return PlyMesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64))
    faces = np.zeros((0, 3), np.int64)
    if corners is not None:  # (the fan triangles already where the faces' lengths differ)
        faces = corners if corners.shape[1] == 3 else fan_triangles(
            corners.reshape(-1), np.broadcast_to(np.int64(corners.shape[1]), (len(corners),)))
    return PlyMesh(vertices, faces, normals, uvs)


def parse_ply(source: bytes | BinaryIO, label: str) -> PlyMesh:
    """The mesh of a PLY file: vertices, fan triangles (0-based, not range-checked), normals, UVs.

    ``source`` is the file's bytes or a binary file open for reading.  An open file's ASCII body is
    streamed from it (:class:`~mcocl.render.file_window.FileWindow`), its bytes never held whole
    (issue 13), and a binary body read a piece of an element at a time (:func:`_parse_binary_streamed`);
    a file either leaves to the whole-file parse (a malformed one, records of differing sizes) is read
    whole and parsed as its bytes are, with the same arrays and messages.

    The arrays hold the file's values exactly in the narrowest type that does (issue 13: a binary
    mesh costs about its file's size in memory): per-vertex data float32 when the file's properties are all
    ``float`` in a binary file, else float64 (:func:`_columns`); the triangles int32 when a binary
    file's index type fits in it (uint32 for ``uint``), else int64 (an ASCII file's).

    Raises:
        InputError: a malformed header or body; the message starts with ``label``.
    """
    streamed = False
    if not isinstance(source, bytes):
        head = _header_bytes(source)
        if head is not None:
            order, elements, body_start = parse_header(head, label)
            want_v, index_name = _wanted(elements, label)
            streamed = order is None
            try:
                if order is None:
                    return _parse_ascii_streamed(FileWindow(source), body_start, elements, want_v, index_name)
                return _parse_binary_streamed(source, order, elements, body_start, want_v, index_name)
            except _UnstreamedError:
                pass
        source.seek(0)
        source = source.read()
    return _parse_ply_bytes(source, label, try_stream=not streamed)


def _header_bytes(f: BinaryIO) -> bytes | None:
    """The first bytes of ``f`` up to and with its ``end_header`` line (enough for :func:`parse_header`
    to read as it reads the whole file), or None where the first MB holds no such line."""
    f.seek(0)
    head = b""
    while len(head) < 1 << 20:
        block = f.read(1 << 16)
        if not block:
            return None
        head += block
        end = head.find(b"\nend_header")
        if end >= 0 and head.find(b"\n", end + 1) >= 0:
            return head
    return None


def _wanted(elements: list[Element], label: str) -> tuple[set[str], str | None]:
    """The vertex properties read and the face's index list name, after the header's checks."""
    names = [e.name for e in elements]
    if "vertex" not in names:
        raise InputError(f"{label}: the PLY header declares no 'vertex' element")
    vert = elements[names.index("vertex")]
    vprops = {p.name: p for p in vert.props}
    for k in ("x", "y", "z"):
        if k not in vprops or vprops[k].count_type is not None:
            raise InputError(f"{label}: the 'vertex' element needs scalar properties x, y and z (missing {k!r})")
    # a list property named like a coordinate is skipped (x, y, z were checked to be scalars)
    want_v = ({"x", "y", "z", "nx", "ny", "nz"} | {n for pair in UV_NAMES for n in pair}) & {
        p.name for p in vert.props if p.count_type is None}
    index_name = None
    if "face" in names:
        fprops = {p.name: p for p in elements[names.index("face")].props}
        index_name = next((n for n in INDEX_NAMES if n in fprops), None)
        if index_name is None or fprops[index_name].count_type is None:
            raise InputError(f"{label}: the 'face' element needs a list property vertex_indices (or vertex_index)")
        if fprops[index_name].type[0] == "f":
            raise InputError(f"{label}: the face's {index_name} must be an integer type")
    return want_v, index_name


def _parse_ply_bytes(data: bytes, label: str, try_stream: bool = True) -> PlyMesh:
    """:func:`parse_ply` of the file's bytes (``try_stream``: an ASCII body is streamed first)."""
    order, elements, body_start = parse_header(data, label)
    want_v, index_name = _wanted(elements, label)
    names = [e.name for e in elements]
    vert = elements[names.index("vertex")]
    if order is None and try_stream:
        try:
            return _parse_ascii_streamed(data, body_start, elements, want_v, index_name)
        except _UnstreamedError:
            pass  # the whole-body parse below reads it, or names what is wrong with it
    body = _Body(data, body_start, order, label, elements)
    pos, got = 0, {}
    for el in elements:
        want = want_v if el.name == "vertex" else {index_name} if el.name == "face" else set()
        got[el.name], pos = _element(body, el, pos, want)
    if pos != body.length:
        what = "numbers" if order is None else "bytes"
        raise InputError(f"{label}: {body.length - pos} {what} after the last element the header declares "
                         "(a count in the header is wrong)")
    if vert.count == 0:
        return PlyMesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64))
    faces = _face_array(got["face"], index_name, order, label) if got.get("face") else np.zeros((0, 3), np.int64)
    vertices, normals, uvs = _vertex_arrays(got["vertex"])
    return PlyMesh(vertices, faces, normals, uvs)


def _vertex_arrays(v: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """Vertices, normals (when nx, ny, nz are all read) and UVs of the vertex element's read properties."""
    with np.errstate(invalid="ignore", over="ignore"):  # non-finite coordinates are refused by check_mesh
        vertices = _columns(v, ("x", "y", "z"))
    normals = _columns(v, ("nx", "ny", "nz")) if {"nx", "ny", "nz"} <= v.keys() else None
    uv = next((pair for pair in UV_NAMES if set(pair) <= v.keys()), None)
    return vertices, normals, _columns(v, uv) if uv else None


def _face_array(got: dict, index_name: str, order: str | None, label: str) -> np.ndarray:
    """The fan triangles of the face element's read index lists (:func:`_element`'s (lengths, values))."""
    per_face, idx = got[index_name]
    if order is None and not np.all(idx == np.floor(idx)):
        raise InputError(f"{label}: a face's vertex index is not an integer")
    few = np.flatnonzero(per_face < 3)
    if len(few):
        raise InputError(f"{label}: face {int(few[0])} has {int(per_face[few[0]])} corners (at least 3 needed)")
    index_type = np.int64 if order is None else _index_type(idx.dtype)
    if idx.ndim == 2 and idx.shape[1] == 3:  # a block of triangles (_element): one copy, no fan
        faces = np.empty(idx.shape, index_type)
        with np.errstate(invalid="ignore"):  # an ASCII index beyond int64 becomes negative: refused by check_mesh
            faces[...] = idx
        return faces
    with np.errstate(invalid="ignore"):
        return fan_triangles(np.ascontiguousarray(idx, index_type).reshape(-1), per_face)


BINARY_PIECE_BYTES = 1 << 20  # a binary element's bytes read and parsed at once: see _parse_binary_streamed


def _parse_binary_streamed(f: BinaryIO, order: str, elements: list[Element], start: int, want_v: set[str],
                           index_name: str | None) -> PlyMesh:
    """The mesh of a well-formed binary PLY read from the open file a piece of an element at a time, as
    :func:`_parse_ply_bytes` makes it from the whole file's bytes.

    An element's records all have the size of its first (every vertex element, and a face element whose
    lists all have one length): it is read :data:`BINARY_PIECE_BYTES` at a time, each piece parsed by
    :func:`_element` as the whole-file parse does, its vertex arrays or fan triangles written into the
    mesh's arrays, so that the read holds the mesh and one piece rather than the whole file besides the
    mesh (issue 13: a 100 MB binary PLY's load peaked at 2.0x the file).  Anything else (records of
    differing sizes, an empty vertex element, a malformed body) raises :class:`_UnstreamedError`: the
    whole-file parse then reads it, with its messages.
    """
    size = os.fstat(f.fileno()).st_size
    vertex = faces = None
    pos = start
    for el in elements:
        if el.count == 0 or not el.props:
            if el.name == "vertex":
                raise _UnstreamedError
            continue
        f.seek(pos)
        first = _Body(f.read(min(1 << 16, size - pos)), 0, order, "", [el])
        width = int(first.record_ends(el, np.array([0]))[0])
        if width > first.length or pos + el.count * width > size:
            raise _UnstreamedError
        want = want_v if el.name == "vertex" else {index_name} if el.name == "face" else set()
        per_piece = max(1, BINARY_PIECE_BYTES // width)
        out: list[np.ndarray | None] | None = None  # the element's arrays, filled piece by piece
        filled: list[int] = []
        for at in range(0, el.count, per_piece):
            k = min(per_piece, el.count - at)
            buf = np.empty(k * width, np.uint8)
            f.seek(pos + at * width)
            if f.readinto(buf) != len(buf):
                raise _UnstreamedError
            try:
                got, end = _element(_Body(buf, 0, order, "", [el]), Element(el.name, k, el.props), 0, want)
                if end != len(buf):
                    raise _UnstreamedError
                parts = (_vertex_arrays(got) if el.name == "vertex" else
                         (_face_array(got, index_name, order, ""),) if el.name == "face" else ())
            except InputError:
                raise _UnstreamedError from None
            if out is None:  # rows per record are fixed (a fan of equal polygons): the whole element's arrays
                out = [None if a is None else np.empty((len(a) * el.count // k, *a.shape[1:]), a.dtype) for a in parts]
                filled = [0] * len(parts)
            for j, a in enumerate(parts):
                if a is not None:
                    if filled[j] + len(a) > len(out[j]) or a.dtype != out[j].dtype:
                        raise _UnstreamedError
                    out[j][filled[j]:filled[j] + len(a)] = a
                    filled[j] += len(a)
        if out is None or any(a is not None and n != len(a) for a, n in zip(out, filled)):
            raise _UnstreamedError
        if el.name == "vertex":
            vertex = out
        elif el.name == "face":
            faces = out[0]
        pos += el.count * width
    if pos != size or vertex is None:
        raise _UnstreamedError
    vertices, normals, uvs = vertex
    return PlyMesh(vertices, np.zeros((0, 3), np.int64) if faces is None else faces, normals, uvs)


__all__ = ["PlyMesh", "parse_header", "parse_ply"]
