"""A JSON scene's inline mesh arrays read by NumPy straight from the file's bytes, a block at a time.

``json.loads`` turns an inline ``"vertices": [[x, y, z], ...]`` into a Python
list of lists of Python floats (about 100 bytes a number, 10x the file) and the
checker then walks them number by number; issue 13 asks that a 100 MB scene
hold at most twice its size.  :func:`read_json_with_arrays` reads the file a
block at a time, parses the value of each ``"vertices"``/``"faces"`` key that
is a list of equal-width rows of JSON numbers with NumPy into one growing
array, and hands ``json.loads`` the rest of the text with a small placeholder
object in each array's place; the placeholder comes back as an
:class:`InlineArray`, which :meth:`InlineArray.checked` validates vectorised.

The fast path only ever accepts what the exact path (``json.loads`` and the
checker's list walk) accepts, with the same numbers: each number must match
JSON's number grammar (RFC 8259 §6) before NumPy parses it, and NumPy parses
decimal text with the same correctly rounded conversion as ``float()``.  Where
it cannot vouch for the file (any malformed or unusual array, invalid JSON,
an array where the checker does not expect one) it raises
:class:`ExactReadNeededError`, and the caller reads the file the exact way, which then
words the error (key path, row, line and column) as it always has.
"""

from __future__ import annotations

import functools
import re
import secrets
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from ..datafile import loads_json, open_regular_file

# The keys whose values are read as arrays, and the dtype each becomes (the checker's: vertices float64,
# faces int64, mcocl/render/shape_registry.py's mesh).
ARRAY_KEYS: dict[bytes, type] = {b'"vertices"': np.float64, b'"faces"': np.int64}

BLOCK = 1 << 18  # bytes read and parsed at once: what the load holds besides the arrays is a few of these
MARGIN = 1 << 16  # bytes kept ahead of a row's start: a longer row, or a longer run of blanks, is not fast-path
MAX_WIDTH = 64  # numbers per row the fast path takes (a mesh needs 3)
EXACT_INT = 2**53  # float64 holds every integer below this exactly, so a parsed integer is the written one

_WS = rb"[ \t\n\r]*+"  # JSON's whitespace (RFC 8259 §2), no other
# RFC 8259 §6: no leading zeros, no '+', no bare '.', no NaN/Infinity (json.loads takes those as constants,
# which load_scene refuses)
_NUM = rb"-?+(?:0|[1-9][0-9]*+)(?:\.[0-9]++)?+(?:[eE][+-]?+[0-9]++)?+"
_NEXT = re.compile(rb'["\[]')  # outside strings, only a string or a list can hold what matters
_STRING = re.compile(rb'"[^"\\]*+(?:\\.[^"\\]*+)*+"', re.DOTALL)
_KEY_COLON = re.compile(_WS + rb":" + _WS)
_ROWS_OPEN = re.compile(rb"\[" + _WS + rb"(?=\[)")
_ANY_ROW = re.compile(rb"\[" + _WS + _NUM + rb"(?:" + _WS + rb"," + _WS + _NUM + rb")*+" + _WS + rb"\]")
_ROW_SEP = re.compile(_WS + rb"," + _WS + rb"(?=\[)")
_ROWS_CLOSE = re.compile(_WS + rb"\]")
# "-0" written as an integer: json.loads makes it int 0, which becomes +0.0, where strtod gives -0.0 (the
# literal first, the character before it checked after: sre then skips to each "-0" at memchr speed)
_INT_MINUS_ZERO = re.compile(rb"-0(?=[ \t\n\r,\]])(?<=[\[, \t\n\r]-0)")
_BRACKETS_TO_BLANKS = bytes.maketrans(b"[]", b"  ")


class ExactReadNeededError(Exception):
    """The fast reader cannot vouch for the file: read it the exact way (which words any error)."""


@dataclass
class InlineArray:
    """An inline array read by :func:`read_json_with_arrays`, standing where ``json.loads`` would put a list.

    ``values`` holds the rows as the exact path's ``np.array(rows, dtype)`` would: float64 for a
    float key, int64 (every number written as a JSON integer) for an integer key.
    """

    key: str
    values: np.ndarray

    def checked(self, width: int, integer: bool, limit: float) -> np.ndarray:
        """The array, when the exact path would accept it: ``width`` numbers a row, integers if ``integer``,
        none beyond ``limit`` in magnitude (the checker's rules, mcocl/render/scene.py ``_Checker.array``).

        Raises:
            ExactReadNeededError: the exact path would refuse it (it words the error) or read it another way.
        """
        a = self.values
        if a.shape[1] != width or a.dtype != (np.int64 if integer else np.float64):
            raise ExactReadNeededError(f"{self.key}: {a.shape[1]} numbers a row as {a.dtype}")
        # from the least and greatest value: no temporary of the array's size
        if a.size and not (-limit <= a.min() and a.max() <= limit):
            raise ExactReadNeededError(f"{self.key}: a number beyond {limit:g}")
        return a


class _GrowingRows:
    """Rows appended a chunk at a time into one array that grows in place.

    ``ndarray.resize`` reallocates, which for a large block moves pages rather
    than copying them, so the rows are never held twice; growing by a quarter
    keeps the unused tail small.
    """

    def __init__(self, width: int, dtype: type) -> None:
        self.rows = np.empty((1024, width), dtype)
        self.n = 0

    def append(self, chunk: np.ndarray) -> None:
        """Add the rows of ``chunk`` (already of the array's width)."""
        need = self.n + len(chunk)
        if need > len(self.rows):
            self.rows.resize((max(need, len(self.rows) * 5 // 4), self.rows.shape[1]), refcheck=False)
        self.rows[self.n:need] = chunk
        self.n = need

    def result(self) -> np.ndarray:
        """The rows appended, trimmed to their number."""
        self.rows.resize((self.n, self.rows.shape[1]), refcheck=False)
        return self.rows


@functools.lru_cache(maxsize=8)
def _rows_of_width(width: int) -> re.Pattern[bytes]:
    """Rows of ``width`` numbers separated by commas, as many as the text holds (possessive: no backtracking)."""
    row = rb"\[" + _WS + _NUM + (_WS + rb"," + _WS + _NUM) * (width - 1) + _WS + rb"\]"
    return re.compile(row + rb"(?:" + _WS + rb"," + _WS + row + rb")*+")


def _parse_rows(text: bytes, width: int, dtype: type) -> np.ndarray:
    """The numbers of ``text`` (complete rows, checked against the grammar) as rows of ``dtype``.

    Raises:
        ExactReadNeededError: an integer key holds a number not written as an integer, or one too big to be exact.
    """
    count = text.count(b"[") * width
    if dtype is np.int64:
        flat = _parse_integers(text)
    else:
        if b"-0" in text and _INT_MINUS_ZERO.search(text):
            text = _INT_MINUS_ZERO.sub(b" 0", text)
        # np.fromstring with a separator parses each number with Python's correctly rounded strtod, as float()
        flat = np.fromstring(text.translate(_BRACKETS_TO_BLANKS), dtype=np.float64, sep=",")
    if flat.size != count:  # the grammar was checked: a mismatch would be a bug, so be safe
        raise ExactReadNeededError("numbers miscounted")
    return flat.reshape(-1, width)


def _parse_integers(text: bytes) -> np.ndarray:
    """The numbers of ``text``, every one written as a JSON integer, as int64 equal to Python's ``int()``.

    Raises:
        ExactReadNeededError: a number not written as an integer, or one beyond float64's exact integers.
    """
    if b"." in text or b"e" in text or b"E" in text:
        raise ExactReadNeededError("a number not written as an integer")
    blanks = text.translate(_BRACKETS_TO_BLANKS)
    # Parsing as int64 takes half the time of float64, but an overflowing number is clamped, not refused: take
    # that way only where no token (the bytes between two commas) is longer than 18 bytes, so no number has
    # more than 18 digits and every one fits.  ("-0" is int 0 either way.)
    commas = np.flatnonzero(np.frombuffer(blanks, np.uint8) == ord(","))
    gaps = np.diff(commas, prepend=-1, append=len(blanks))
    if gaps.max() <= 19:
        return np.fromstring(blanks, dtype=np.int64, sep=",")
    flat = np.fromstring(blanks, dtype=np.float64, sep=",")
    if flat.size and not (-EXACT_INT < flat.min() and flat.max() < EXACT_INT):
        raise ExactReadNeededError("an integer beyond float64's exact range")
    return flat.astype(np.int64)


class _Scanner:
    """The file's bytes a block at a time: the text outside the arrays kept, each array parsed."""

    def __init__(self, f: BinaryIO) -> None:
        self.f = f
        self.buf, self.pos, self.eof = b"", 0, False
        self.out = bytearray()  # the text json.loads reads: the file with placeholders for the arrays
        self.arrays: list[InlineArray] = []
        self.nonce = secrets.token_hex(16)  # the placeholders' key: no file can hold it by chance

    def _more(self) -> bool:
        """Read on, keeping the bytes from ``pos``; False at the end of the file.

        Reads at least as much as is kept, so a long token read again after each block costs O(its size).
        """
        if self.eof:
            return False
        kept = self.buf[self.pos:]
        block = self.f.read(max(BLOCK, len(kept)))
        self.eof = not block
        self.buf, self.pos = kept + block, 0
        return not self.eof

    def _ensure(self, n: int) -> None:
        """Hold at least ``n`` bytes from ``pos`` (fewer only at the end of the file)."""
        while len(self.buf) - self.pos < n and self._more():
            pass

    def scan(self) -> None:
        """Copy the file to ``out``, replacing each array value of an :data:`ARRAY_KEYS` key."""
        key, key_end = b"", -1  # the last string read and where it ends in ``out``
        while True:
            m = _NEXT.search(self.buf, self.pos)
            if m is None:
                self.out += self.buf[self.pos:]
                self.pos = len(self.buf)
                if not self._more():
                    return
                continue
            i = m.start()
            self.out += self.buf[self.pos:i]
            self.pos = i
            if self.buf[i] == ord('"'):
                s = _STRING.match(self.buf, i)
                if s is None:  # the string goes on past the bytes held (or never ends: json.loads says so)
                    if self._more():
                        continue
                    self.out += self.buf[self.pos:]
                    return
                self.out += s.group()
                self.pos = s.end()
                key, key_end = (s.group() if s.end() - i <= 16 else b""), len(self.out)
                continue
            dtype = ARRAY_KEYS.get(key)
            if dtype is not None and _KEY_COLON.fullmatch(self.out, key_end):
                array = self._rows(key.decode().strip('"'), dtype)
                if array is not None:
                    self.out += b'{"%s": %d}' % (self.nonce.encode(), len(self.arrays))
                    self.arrays.append(array)
                    key = b""
                    continue
            self.out += b"["
            self.pos = i + 1
            key = b""

    def _rows(self, key: str, dtype: type) -> InlineArray | None:
        """The list of rows starting at ``pos`` (a ``[``), parsed; None (nothing consumed) if it does not
        start as a list of lists.

        Raises:
            ExactReadNeededError: it starts as one but is not a list of equal rows of JSON numbers.
        """
        self._ensure(MARGIN)
        m = _ROWS_OPEN.match(self.buf, self.pos)
        if m is None:
            return None
        self.pos = m.end()
        first = _ANY_ROW.match(self.buf, self.pos)
        if first is None:
            raise ExactReadNeededError(f"{key}: its first row is not a list of JSON numbers")
        width = first.group().count(b",") + 1
        if width > MAX_WIDTH:
            raise ExactReadNeededError(f"{key}: {width} numbers a row")
        rows, pattern = _GrowingRows(width, dtype), _rows_of_width(width)
        while True:
            self._ensure(MARGIN)
            m = pattern.match(self.buf, self.pos)
            if m is None:
                raise ExactReadNeededError(f"{key}: a row that is not {width} JSON numbers")
            rows.append(_parse_rows(self.buf[self.pos:m.end()], width, dtype))
            self.pos = m.end()
            self._ensure(MARGIN)  # the separator and the next row's '[' (a partial row waits for more)
            sep = _ROW_SEP.match(self.buf, self.pos)
            if sep is not None:
                self.pos = sep.end()
                continue
            close = _ROWS_CLOSE.match(self.buf, self.pos)
            if close is None:
                raise ExactReadNeededError(f"{key}: a row list that does not end with ']'")
            self.pos = close.end()
            return InlineArray(key, rows.result())


def read_json_with_arrays(path: str | Path, where: str, parse_constant: Any = None) -> tuple[Any, list[InlineArray]]:
    """The JSON document of ``path``, each inline array an :class:`InlineArray`, and the list of those.

    ``where`` and ``parse_constant`` are :func:`mcocl.datafile.loads_json`'s.

    Raises:
        ExactReadNeededError: the file cannot be read, is not UTF-8 JSON, or holds an array the fast path does not
            take; the exact reader words the error (or reads it).
    """
    try:
        with open_regular_file(path) as f:
            scanner = _Scanner(f)
            scanner.scan()
    except OSError as e:
        raise ExactReadNeededError(f"cannot read: {e}") from None
    arrays = scanner.arrays
    if scanner.out.count(scanner.nonce.encode()) != len(arrays):
        raise ExactReadNeededError("the placeholder's key is in the file")
    try:
        text = scanner.out.decode("utf-8")
        del scanner.out
        return loads_json(text, where, parse_constant, placeholders=(scanner.nonce, arrays)), arrays
    except Exception as e:  # any error the exact reader reports with the file's own line and column
        raise ExactReadNeededError(f"{type(e).__name__}: {e}") from None


__all__ = ["ARRAY_KEYS", "InlineArray", "ExactReadNeededError", "read_json_with_arrays"]
