"""Reading the user's text data files (scenes, problem files, meshes) without a raw exception.

A data file may be anything: binary, another encoding, JSON nested 100,000
levels deep.  These helpers turn each of those into an
:class:`~mcocl.errors.InputError` that names the file and, where there is one,
the line, so loaders need only handle the format itself.
"""

from __future__ import annotations

import errno
import json
import os
import stat
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, BinaryIO

from .errors import InputError


def decode_utf8(raw: bytes, where: str) -> str:
    """``raw`` as UTF-8 text.

    Raises:
        InputError: not UTF-8; the message names the line and byte offset of
            the first bad byte.
    """
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as e:
        line = raw.count(b"\n", 0, e.start) + 1
        raise InputError(f"{where}: not UTF-8 text (byte 0x{raw[e.start]:02x} at line {line}, "
                         f"offset {e.start}); is it the right file?") from None


UTF8_BLOCK = 1 << 20  # bytes checked at once by check_utf8_file


def check_utf8_file(path: str | Path, where: str) -> None:
    """Refuse a file that is not UTF-8 text with :func:`decode_utf8`'s message for its bytes, reading it a
    block at a time (issue 13: a 100 MB OBJ's check held its bytes and their text at once, 2x the file).

    A multi-byte character cut by a block's end is carried into the next block; any other decoding
    error is the whole file's first one, so the byte, line and offset named are the same.

    Raises:
        InputError: not UTF-8.  OSError: the file cannot be read (the caller's parser reports it).
    """
    at, line, carry = 0, 1, b""  # the file offset of ``carry``'s first byte, its line
    with open_regular_file(path) as f:
        while True:
            block = f.read(UTF8_BLOCK)
            data = carry + block
            try:
                data.decode("utf-8")
                carry = b""
            except UnicodeDecodeError as e:
                if block and e.reason == "unexpected end of data" and e.end == len(data):
                    carry = data[e.start:]  # a character the next block ends
                else:
                    line += data.count(b"\n", 0, e.start)
                    raise InputError(f"{where}: not UTF-8 text (byte 0x{data[e.start]:02x} at line {line}, "
                                     f"offset {at + e.start}); is it the right file?") from None
            if not block:
                return
            done = len(data) - len(carry)
            line += data.count(b"\n", 0, done)
            at += done


def read_regular_file(path: str | Path) -> bytes:
    """The bytes of ``path``, refusing a device, pipe or socket with an :class:`OSError`.

    ``/dev/zero`` given as a scene would otherwise be read until memory runs
    out, and a named pipe would block for ever; callers already turn an
    ``OSError`` into an :class:`InputError` that quotes its ``strerror``.
    """
    with open_regular_file(path) as f:
        return f.read()


def open_regular_file(path: str | Path) -> BinaryIO:
    """``path`` open for reading bytes, with :func:`read_regular_file`'s refusals, for a reader that streams it.

    A device, pipe or socket is refused before it is opened, as there, and again
    by the open file's own status (the path may have been replaced in between);
    it is opened without blocking, so a named pipe put there cannot hang the
    open.  A folder raises the :class:`IsADirectoryError` that reading it would.
    """
    p = Path(path)
    mode = p.stat().st_mode
    if not stat.S_ISREG(mode) and not stat.S_ISDIR(mode):
        raise OSError(errno.EINVAL, "not a regular file (a device, pipe or socket)", str(p))
    fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    try:
        mode = os.fstat(fd).st_mode
        if stat.S_ISDIR(mode):
            raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), str(p))
        if not stat.S_ISREG(mode):
            raise OSError(errno.EINVAL, "not a regular file (a device, pipe or socket)", str(p))
        return os.fdopen(fd, "rb", buffering=0)
    except BaseException:
        os.close(fd)
        raise


def read_utf8(path: str | Path, where: str) -> str:
    """The text of ``path``, which must be UTF-8 (``where`` names it in messages).

    Raises:
        InputError: it cannot be read (the reason), or it is not UTF-8.
    """
    try:
        raw = read_regular_file(path)
    except OSError as e:
        raise InputError(f"{where}: cannot read it: {e.strerror or e}") from None
    return decode_utf8(raw, where)


def loads_json(text: str, where: str, parse_constant: Callable[[str], Any] | None = None,
               placeholders: tuple[str, Sequence[Any]] | None = None) -> Any:
    """``json.loads(text)``, refusing nesting too deep for Python's recursive decoder and repeated keys.

    :class:`json.JSONDecodeError` and ``parse_constant``'s errors pass through
    (the callers word them); a :class:`RecursionError` becomes an
    :class:`InputError`.  With ``placeholders`` ``(key, values)``, an object
    ``{key: k}`` stands for ``values[k]`` (mcocl/render/json_arrays.py puts
    them where it parsed an array itself).
    """
    def unique_keys(pairs: list[tuple[str, Any]]) -> Any:
        if placeholders is not None and len(pairs) == 1 and pairs[0][0] == placeholders[0]:
            return placeholders[1][pairs[0][1]]
        obj = dict(pairs)
        if len(obj) != len(pairs):
            seen: set[str] = set()
            twice = next(k for k, _ in pairs if k in seen or seen.add(k))  # type: ignore[func-returns-value]
            # json.loads would keep the last value and drop the first without a word
            raise InputError(f"{where}: the key {twice!r} appears twice in one object; a data file must say "
                             "each thing once")
        return obj

    try:
        return json.loads(text, parse_constant=parse_constant, object_pairs_hook=unique_keys)
    except RecursionError:
        raise InputError(f"{where}: the JSON is nested too deeply to be a data file") from None


__all__ = ["check_utf8_file", "decode_utf8", "loads_json", "open_regular_file", "read_regular_file", "read_utf8"]
