"""Reading the user's text data files (scenes, problem files, meshes) without a raw exception.

A data file may be anything: binary, another encoding, JSON nested 100,000
levels deep.  These helpers turn each of those into an
:class:`~mcocl.errors.InputError` that names the file and, where there is one,
the line, so loaders need only handle the format itself.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

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


def read_utf8(path: str | Path, where: str) -> str:
    """The text of ``path``, which must be UTF-8 (``where`` names it in messages).

    Raises:
        InputError: it cannot be read (the reason), or it is not UTF-8.
    """
    try:
        raw = Path(path).read_bytes()
    except OSError as e:
        raise InputError(f"{where}: cannot read it: {e.strerror or e}") from None
    return decode_utf8(raw, where)


def loads_json(text: str, where: str, parse_constant: Callable[[str], Any] | None = None) -> Any:
    """``json.loads(text)``, refusing nesting too deep for Python's recursive decoder.

    :class:`json.JSONDecodeError` and ``parse_constant``'s errors pass through
    (the callers word them); a :class:`RecursionError` becomes an
    :class:`InputError`.
    """
    try:
        return json.loads(text, parse_constant=parse_constant)
    except RecursionError:
        raise InputError(f"{where}: the JSON is nested too deeply to be a data file") from None


__all__ = ["decode_utf8", "loads_json", "read_utf8"]
