"""Image files: OpenEXR with the estimate and its statistics, and an sRGB PNG preview.

EXR layout (one scanline part, float32 unless said otherwise, ZIP compression):

- ``R``, ``G``, ``B``: the per-pixel mean radiance;
- ``variance.R``, ``variance.G``, ``variance.B``: a layer ``variance`` with
  the per-channel variance *of the mean* (the squared standard error);
- ``samples``: the number of samples that went into each pixel (UINT;
  non-finite samples are left out, so it may differ between pixels);
- header string attributes ``mcocl.<key>`` for the caller's metadata
  (spp, integrator, seed, ...).

The PNG writer is a small encoder of its own (zlib from the standard library,
filter 0 on every row) so that previews need no imaging dependency.
"""

from __future__ import annotations

import math
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..output_files import write_atomically

_META_PREFIX = "mcocl."


@dataclass
class ExrImage:
    """An image read back from :func:`write_exr`'s layout."""

    mean: np.ndarray  # float32 (H, W, 3)
    variance: np.ndarray | None = None  # float32 (H, W, 3)
    samples: np.ndarray | None = None  # uint32 (H, W)
    metadata: dict[str, str] = field(default_factory=dict)


def _check_rgb(a: np.ndarray, what: str) -> np.ndarray:
    a = np.asarray(a)
    if a.ndim != 3 or a.shape[2] != 3:
        raise InputError(f"{what} must have shape (height, width, 3), got {a.shape}")
    return np.ascontiguousarray(a, dtype=np.float32)


def write_exr(path: str | Path, mean: np.ndarray, variance: np.ndarray | None = None,
              samples: np.ndarray | None = None, metadata: dict | None = None) -> None:
    """Write an OpenEXR file with the mean (RGB), the variance layer and the sample counts.

    The file is written to a unique temporary name beside ``path`` and renamed, so
    an interrupted write never leaves a truncated image under ``path``.
    """
    import OpenEXR

    mean = _check_rgb(mean, "mean")
    h, w, _ = mean.shape
    channels = {"R": mean[:, :, 0].copy(), "G": mean[:, :, 1].copy(), "B": mean[:, :, 2].copy()}
    if variance is not None:
        var = _check_rgb(variance, "variance")
        if var.shape != mean.shape:
            raise InputError(f"variance shape {var.shape} differs from the mean's {mean.shape}")
        for k, c in enumerate("RGB"):
            channels[f"variance.{c}"] = var[:, :, k].copy()
    if samples is not None:
        s = np.asarray(samples)
        if s.shape != (h, w):
            raise InputError(f"samples must have shape {(h, w)}, got {s.shape}")
        if np.any(s < 0) or np.any(s > np.iinfo(np.uint32).max):
            raise InputError("samples must fit in uint32")
        channels["samples"] = np.ascontiguousarray(s, dtype=np.uint32)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    for k, v in (metadata or {}).items():
        header[_META_PREFIX + str(k)] = str(v)
    def write(tmp: Path) -> None:
        with OpenEXR.File(header, channels) as f:
            f.write(str(tmp))

    write_atomically(path, write)


def read_exr(path: str | Path) -> ExrImage:
    """Read an EXR written by :func:`write_exr` (any EXR with R, G, B channels works).

    Raises:
        InputError: the file is missing, not an EXR, or has no R, G, B channels.
    """
    import OpenEXR

    p = Path(path)
    if not p.is_file():
        raise InputError(f"{p}: no such file")
    try:
        with OpenEXR.File(str(p), separate_channels=True) as f:
            ch = {name: np.array(c.pixels) for name, c in f.channels().items()}
            hdr = dict(f.header())
    except Exception as e:  # the binding raises plain RuntimeErrors for corrupt files
        raise InputError(f"{p}: not a readable OpenEXR file ({e})") from None
    if not all(c in ch for c in "RGB"):
        raise InputError(f"{p}: the EXR has no R, G, B channels (has {', '.join(sorted(ch))})")
    mean = np.stack([ch["R"], ch["G"], ch["B"]], axis=-1).astype(np.float32)
    var = None
    if all(f"variance.{c}" in ch for c in "RGB"):
        var = np.stack([ch[f"variance.{c}"] for c in "RGB"], axis=-1).astype(np.float32)
    samples = ch["samples"].astype(np.uint32) if "samples" in ch else None
    meta = {k[len(_META_PREFIX):]: str(v) for k, v in hdr.items() if k.startswith(_META_PREFIX)}
    return ExrImage(mean, var, samples, meta)


# Exposure stops the PNG writer takes: 2^64 scales any radiance a float32 image
# holds to a finite value, and no useful exposure lies beyond (2^1e30 overflows).
EXPOSURE_LIMIT = 64.0


def check_exposure(exposure: object) -> float:
    """``exposure`` as a float of stops, refused unless it is a finite number within +-EXPOSURE_LIMIT."""
    if isinstance(exposure, bool) or not isinstance(exposure, (int, float, np.integer, np.floating)) \
            or not math.isfinite(float(exposure)) or abs(float(exposure)) > EXPOSURE_LIMIT:
        raise InputError(f"exposure must be a finite number of stops between {-EXPOSURE_LIMIT:g} and "
                         f"{EXPOSURE_LIMIT:g}, got {exposure!r}")
    return float(exposure)


def srgb_encode(linear: np.ndarray, exposure: float = 0.0) -> np.ndarray:
    """Linear RGB → 8-bit sRGB (IEC 61966-2-1 transfer curve), after scaling by 2^exposure and clamping.

    Non-finite values become 0.

    Raises:
        InputError: ``exposure`` is not a finite number within +-EXPOSURE_LIMIT stops.
    """
    scale = 2.0 ** check_exposure(exposure)
    x = np.nan_to_num(np.asarray(linear, np.float64) * scale, nan=0.0, posinf=0.0, neginf=0.0)
    x = np.clip(x, 0.0, 1.0)
    s = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)
    return np.round(s * 255.0).astype(np.uint8)


def _chunk(tag: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)


def encode_png(rgb8: np.ndarray) -> bytes:
    """A PNG file (8-bit RGB, or grey for a 2-D array) as bytes (PNG spec, ISO/IEC 15948)."""
    a = np.ascontiguousarray(rgb8, dtype=np.uint8)
    if a.ndim == 2:
        color = 0
        a = a[:, :, None]
    elif a.ndim == 3 and a.shape[2] == 3:
        color = 2
    else:
        raise InputError(f"a PNG image must be (H, W) or (H, W, 3), got {a.shape}")
    h, w, c = a.shape
    raw = np.zeros((h, 1 + w * c), np.uint8)  # filter byte 0 ("None") then the row
    raw[:, 1:] = a.reshape(h, w * c)
    ihdr = struct.pack(">IIBBBBB", w, h, 8, color, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", ihdr) + _chunk(b"IDAT", zlib.compress(raw.tobytes(), 6))
            + _chunk(b"IEND", b""))


def write_png(path: str | Path, linear_rgb: np.ndarray, exposure: float = 0.0) -> None:
    """Write an sRGB preview of a linear RGB image (H, W, 3)."""
    data = encode_png(srgb_encode(_check_rgb(linear_rgb, "image"), exposure))
    write_atomically(path, lambda tmp: tmp.write_bytes(data))


def decode_png(data: bytes) -> np.ndarray:
    """Decode an 8-bit, non-interlaced grey or RGB PNG (the kind :func:`encode_png` writes; all five filters).

    Used to check written previews; not a general PNG reader.
    """
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise InputError("not a PNG file")
    pos, idat, ihdr = 8, b"", None
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos:pos + 4])
        tag, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        if zlib.crc32(tag + body) & 0xFFFFFFFF != struct.unpack(">I", data[pos + 8 + n:pos + 12 + n])[0]:
            raise InputError(f"PNG chunk {tag!r} has a bad CRC")
        if tag == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif tag == b"IDAT":
            idat += body
        pos += 12 + n
    if ihdr is None:
        raise InputError("PNG without IHDR")
    w, h, depth, color, _, _, interlace = ihdr
    if depth != 8 or color not in (0, 2) or interlace:
        raise InputError("only 8-bit grey/RGB non-interlaced PNGs are supported")
    c = 3 if color == 2 else 1
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(h, 1 + w * c)
    out = np.zeros((h, w * c), np.int32)
    prev = np.zeros(w * c, np.int32)
    for y in range(h):
        f, row = raw[y, 0], raw[y, 1:].astype(np.int32)
        if f in (0, 2):  # None / Up need no left neighbour: vectorised
            cur = (row + (prev if f == 2 else 0)) & 0xFF
            out[y], prev = cur, cur
            continue
        cur = np.zeros(w * c, np.int32)
        for x in range(w * c):  # small previews only: a plain loop keeps the filters readable
            a = cur[x - c] if x >= c else 0
            b = prev[x]
            cc = prev[x - c] if x >= c else 0
            if f == 0:
                pred = 0
            elif f == 1:
                pred = a
            elif f == 2:
                pred = b
            elif f == 3:
                pred = (a + b) // 2
            else:
                p = a + b - cc
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - cc)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else cc)
            cur[x] = (row[x] + pred) & 0xFF
        out[y], prev = cur, cur
    return out.reshape(h, w, c).astype(np.uint8).squeeze(-1 if c == 1 else ())


__all__ = ["ExrImage", "decode_png", "encode_png", "read_exr", "srgb_encode", "write_exr", "write_png"]
