"""OBJ face corners (``i``, ``i/t``, ``i//n``, ``i/t/n``) read from a byte buffer, all corners at once.

:func:`parse_ints` converts the signed decimal integers that start at given
positions (SWAR: eight digits as one 64-bit word); :func:`vertex_indices`
reads only the number before each corner's first slash (files without ``vt``
and ``vn`` records, exactly as before they were read); :func:`corner_indices`
reads the whole corner grammar.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SPACE, SLASH = 32, ord("/")
MAX_DIGITS = 18  # an index of more digits cannot be a record of a mesh that fits in memory
_ASCII_ZEROS = np.uint64(0x3030303030303030)


def parse_ints(blob: np.ndarray, at: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The integers ``[+-]digits`` starting at positions ``at`` of ``blob``: (values, end positions, well formed).

    The eight bytes at each number's start are read as one little-endian 64-bit
    word and up to eight digits are converted at once (SWAR: digit pairs,
    then quadruples, then octets, as in Lemire's fast integer parsing);
    longer numbers continue digit by digit.  ``blob`` must end with at least
    eight separator bytes.  A number is well formed when it has 1 to
    :data:`MAX_DIGITS` digits; what follows it is the caller's to check.
    """
    c = blob[at]
    neg = c == ord("-")
    pos = at + (neg | (c == ord("+")))
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
    for _ in range(MAX_DIGITS - 8 + 1):
        d = blob[pos[going]] - np.uint8(ord("0"))
        more = d < 10
        going, d = going[more], d[more]
        if not len(going):
            break
        val[going] = val[going] * 10 + d
        ndig[going] += 1
        pos[going] += 1
    return np.where(neg, -val, val), pos, (ndig > 0) & (ndig <= MAX_DIGITS)


def vertex_indices(blob: np.ndarray, corner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The vertex index that begins each corner token (then a slash or the token's end); what follows is not read.

    Returns (indices, whether each corner is well formed).
    """
    val, pos, ok = parse_ints(blob, corner)
    stop = blob[pos]
    return val, ok & ((stop <= SPACE) | (stop == SLASH))


@dataclass
class Corners:
    """The indices of each corner as written (1-based or negative); ``has_t``/``has_n``: whether it gives one."""

    v: np.ndarray
    t: np.ndarray
    n: np.ndarray
    has_t: np.ndarray
    has_n: np.ndarray
    ok: np.ndarray  # the corner is exactly one of i, i/t, i//n, i/t/n


def corner_indices(blob: np.ndarray, corner: np.ndarray) -> Corners:
    """The position, texture and normal indices of each corner token (the four forms of the OBJ format).

    A corner is ``i``, ``i/t``, ``i//n`` or ``i/t/n``, each a signed integer;
    anything else (``i/``, ``i/t/``, ``i//``, a fourth part) is not well formed.
    Indices a corner does not give are 0 (no OBJ index is 0: the caller refuses 0).
    """
    count = len(corner)
    v, pos, ok = parse_ints(blob, corner)
    stop = blob[pos]
    ok &= (stop <= SPACE) | (stop == SLASH)
    t, n = np.zeros(count, np.int64), np.zeros(count, np.int64)
    has_t, has_n = np.zeros(count, bool), np.zeros(count, bool)
    slashed = np.flatnonzero(ok & (stop == SLASH))
    after = pos[slashed] + 1  # the byte after the first slash: a texture index, or the second slash
    no_t = blob[after] == SLASH
    with_t = slashed[~no_t]
    tv, tpos, tok = parse_ints(blob, after[~no_t])
    tstop = blob[tpos]
    ok[with_t] &= tok & ((tstop <= SPACE) | (tstop == SLASH))
    t[with_t], has_t[with_t] = tv, True
    second = tok & (tstop == SLASH)  # i/t/n
    with_n = np.concatenate([with_t[second], slashed[no_t]])
    nv, npos, nok = parse_ints(blob, np.concatenate([tpos[second] + 1, after[no_t] + 1]))
    ok[with_n] &= nok & (blob[npos] <= SPACE)
    n[with_n], has_n[with_n] = nv, True
    return Corners(v, t, n, has_t, has_n, ok)


__all__ = ["Corners", "MAX_DIGITS", "SLASH", "SPACE", "corner_indices", "parse_ints", "vertex_indices"]
