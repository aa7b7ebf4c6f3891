"""EXR round trip with every channel, and the PNG preview encoder."""

from __future__ import annotations

import zlib

import numpy as np
import pytest

from mcocl.errors import InputError
from mcocl.render.image_io import decode_png, encode_png, read_exr, srgb_encode, write_exr, write_png


def test_exr_round_trip_all_channels(tmp_path):
    rng = np.random.default_rng(0)
    h, w = 17, 23
    mean = rng.uniform(0, 50, (h, w, 3)).astype(np.float32)
    mean[0, 0] = [0.0, 1e-30, 3e38]
    var = rng.uniform(0, 1, (h, w, 3)).astype(np.float32)
    samples = rng.integers(0, 2**32 - 1, (h, w), dtype=np.uint64)
    path = tmp_path / "img.exr"
    write_exr(path, mean, var, samples, {"spp": 64, "integrator": "mis", "seed": 3})
    back = read_exr(path)
    np.testing.assert_array_equal(back.mean, mean)  # float32 is stored exactly
    np.testing.assert_array_equal(back.variance, var)
    np.testing.assert_array_equal(back.samples, samples.astype(np.uint32))
    assert back.metadata == {"spp": "64", "integrator": "mis", "seed": "3"}
    assert [p.name for p in tmp_path.iterdir()] == ["img.exr"]  # no temporary file left behind


def test_exr_channel_names_follow_the_layout(tmp_path):
    import OpenEXR

    path = tmp_path / "img.exr"
    write_exr(path, np.ones((2, 3, 3)), np.zeros((2, 3, 3)), np.full((2, 3), 5))
    with OpenEXR.File(str(path), separate_channels=True) as f:
        names = set(f.channels())
        assert f.channels()["samples"].pixels.dtype == np.uint32
    assert names == {"R", "G", "B", "variance.R", "variance.G", "variance.B", "samples"}


def test_exr_mean_only_and_errors(tmp_path):
    path = tmp_path / "m.exr"
    write_exr(path, np.full((4, 4, 3), 0.5))
    back = read_exr(path)
    assert back.variance is None and back.samples is None
    np.testing.assert_array_equal(back.mean, 0.5)
    with pytest.raises(InputError, match="shape"):
        write_exr(path, np.zeros((4, 4)))
    with pytest.raises(InputError, match="variance"):
        write_exr(path, np.zeros((4, 4, 3)), np.zeros((4, 5, 3)))
    with pytest.raises(InputError, match="no such file"):
        read_exr(tmp_path / "missing.exr")
    (tmp_path / "junk.exr").write_bytes(b"not an exr")
    with pytest.raises(InputError, match="not a readable OpenEXR"):
        read_exr(tmp_path / "junk.exr")


def test_srgb_curve_and_png_written(tmp_path):
    lin = np.array([[[0.0, 0.0031308, 1.0], [0.5, 2.0, np.nan], [0.18, -1.0, np.inf]]], np.float32)
    s = srgb_encode(lin)
    assert s.dtype == np.uint8
    np.testing.assert_array_equal(s[0, 0], [0, 10, 255])  # 12.92 * 0.0031308 * 255 = 10.3
    np.testing.assert_array_equal(s[0, 1], [188, 255, 0])  # 1.055 * 0.5^(1/2.4) - 0.055 = 0.7354
    assert s[0, 2, 0] == 118 and s[0, 2, 1] == 0 and s[0, 2, 2] == 0
    img = np.random.default_rng(1).uniform(0, 1, (31, 45, 3)).astype(np.float32)
    path = tmp_path / "p.png"
    write_png(path, img)
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    np.testing.assert_array_equal(decode_png(data), srgb_encode(img))


def test_png_decoder_handles_every_filter():
    """The test decoder itself, on rows written with filters 1-4 (so it is a fair check of encode_png)."""
    rng = np.random.default_rng(2)
    img = rng.integers(0, 256, (4, 5, 3)).astype(np.int32)
    flat = img.reshape(4, 15)
    rows, prev = [], np.zeros(15, np.int32)
    for y, f in enumerate([1, 2, 3, 4]):
        cur = flat[y]
        out = np.zeros(15, np.int32)
        for x in range(15):
            a = cur[x - 3] if x >= 3 else 0
            b, c = prev[x], (prev[x - 3] if x >= 3 else 0)
            p = a + b - c
            pred = [0, a, b, (a + b) // 2,
                    a if abs(p - a) <= abs(p - b) and abs(p - a) <= abs(p - c) else (b if abs(p - b) <= abs(p - c) else c)][f]
            out[x] = (cur[x] - pred) & 0xFF
        rows.append(bytes([f]) + out.astype(np.uint8).tobytes())
        prev = cur
    good = encode_png(img.astype(np.uint8))
    # Replace the IDAT of a valid file with the filtered rows.
    import struct

    idat = zlib.compress(b"".join(rows))
    body = b"IDAT" + idat
    chunk = struct.pack(">I", len(idat)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)
    ihdr_end = 8 + 25
    data = good[:ihdr_end] + chunk + good[-12:]
    np.testing.assert_array_equal(decode_png(data), img.astype(np.uint8))
    grey = rng.integers(0, 256, (3, 7)).astype(np.uint8)
    np.testing.assert_array_equal(decode_png(encode_png(grey)), grey)
