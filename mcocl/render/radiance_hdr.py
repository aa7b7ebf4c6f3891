"""Radiance RGBE (``.hdr``) images: the environment maps and textures many scenes ship.

No maintained library in our dependencies reads them (Pillow does not; imageio
needs the FreeImage binary fetched at run time), and the format is small:
Greg Ward's RGBE, "Real Pixels", Graphics Gems II (1991), and the Radiance
file-format notes.  A text header (``#?RADIANCE`` or ``#?RGBE``, variables such
as ``FORMAT=32-bit_rle_rgbe``, an empty line), a resolution line (``-Y H +X
W``: rows top to bottom, pixels left to right), then H scanlines, each either
flat (4 bytes per pixel) or run-length encoded per channel (the "new" RLE:
``2 2 W/256 W%256``, then for each of R, G, B, E runs of a byte: a count
above 128 repeats the next byte count - 128 times, otherwise count literal
bytes follow).  A pixel is ``m * 2^(e - 136)`` per channel, 0 where e = 0
(the conversion of Bruce Walter's rgbe.c, which Mitsuba and stb_image use).
The old RLE (repeat markers 1 1 1 n) and XYZE files are refused with a clear
error.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError

_MAGIC = (b"#?RADIANCE", b"#?RGBE")
_MAX_HEADER = 1 << 16  # bytes of header before the resolution line


def read_hdr(path: str | Path, what: str = "image") -> np.ndarray:
    """float32 (H, W, 3) linear RGB of a Radiance ``.hdr`` file.

    Raises:
        InputError: not an RGBE file, an orientation other than ``-Y H +X W``,
            XYZE data, the old run-length encoding, or a truncated scanline;
            ``what`` names the scene key.
    """
    p = Path(path)
    try:
        data = p.read_bytes()
    except OSError as e:
        raise InputError(f"{what}: {p.name}: cannot read it ({e.strerror})") from None
    name = f"{what}: {p.name}"
    pos, width, height = _header(data, name)
    rgbe = np.empty((height, width, 4), np.uint8)
    for y in range(height):
        pos = _scanline(data, pos, width, rgbe[y], f"{name}: row {y}")
    e = rgbe[..., 3].astype(np.int32)
    scale = np.where(e > 0, np.ldexp(1.0, e - 136), 0.0)
    return (rgbe[..., :3].astype(np.float64) * scale[..., None]).astype(np.float32)


def _header(data: bytes, name: str) -> tuple[int, int, int]:
    """Check the header; return (offset of the first scanline, width, height)."""
    if not data.startswith(_MAGIC):
        raise InputError(f"{name}: not a Radiance RGBE file (it does not start with #?RADIANCE or #?RGBE)")
    end = data.find(b"\n\n", 0, _MAX_HEADER)
    if end < 0:
        raise InputError(f"{name}: no end of the header (an empty line) in its first {_MAX_HEADER} bytes")
    for line in data[:end].split(b"\n")[1:]:
        if line.startswith(b"FORMAT=") and line.strip() != b"FORMAT=32-bit_rle_rgbe":
            raise InputError(f"{name}: {line.decode('latin-1').strip()} is not read (only 32-bit_rle_rgbe)")
    eol = data.find(b"\n", end + 2)
    if eol < 0:
        raise InputError(f"{name}: no resolution line after the header")
    words = data[end + 2:eol].split()
    if len(words) != 4 or words[0] != b"-Y" or words[2] != b"+X" or not (words[1].isdigit() and words[3].isdigit()):
        raise InputError(f"{name}: resolution line {data[end + 2:eol][:40].decode('latin-1')!r} is not "
                         "'-Y <height> +X <width>' (other orientations are not read)")
    height, width = int(words[1]), int(words[3])
    if width < 1 or height < 1:
        raise InputError(f"{name}: an empty image ({width} x {height})")
    return eol + 1, width, height


def _scanline(data: bytes, pos: int, width: int, out: np.ndarray, where: str) -> int:
    """Decode one scanline into ``out`` ((W, 4) uint8); return the offset after it."""
    head = data[pos:pos + 4]
    if len(head) < 4:
        raise InputError(f"{where}: the file ends early")
    if not (8 <= width < 32768 and head[0] == 2 and head[1] == 2 and head[2] < 128):
        flat = np.frombuffer(data, np.uint8, width * 4, pos) if pos + 4 * width <= len(data) else None
        if flat is None:
            raise InputError(f"{where}: the file ends early")
        if np.any((flat[0::4] == 1) & (flat[1::4] == 1) & (flat[2::4] == 1)):
            raise InputError(f"{where}: the old run-length encoding (repeat markers 1 1 1 n) is not read")
        out[:] = flat.reshape(width, 4)
        return pos + 4 * width
    if (head[2] << 8 | head[3]) != width:
        raise InputError(f"{where}: a run-length scanline of {head[2] << 8 | head[3]} pixels in an image "
                         f"{width} wide")
    pos += 4
    for c in range(4):
        x = 0
        while x < width:
            if pos >= len(data):
                raise InputError(f"{where}: the file ends early")
            count = data[pos]
            if count > 128:
                count -= 128
                if x + count > width or pos + 1 >= len(data):
                    raise InputError(f"{where}: a run past the end of the scanline")
                out[x:x + count, c] = data[pos + 1]
                pos += 2
            else:
                if count == 0 or x + count > width or pos + 1 + count > len(data):
                    raise InputError(f"{where}: a bad run of {count} bytes")
                out[x:x + count, c] = np.frombuffer(data, np.uint8, count, pos + 1)
                pos += 1 + count
            x += count
    return pos


__all__ = ["read_hdr"]
