"""Radiance RGBE files, built byte by byte from the format's description (mcocl/render/radiance_hdr.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mcocl.errors import InputError
from mcocl.render.envmap import load_envmap_image
from mcocl.render.radiance_hdr import read_hdr
from mcocl.render.textures import load_image

HEADER = b"#?RADIANCE\n# made by hand\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=1.0\n\n"


def _flat(rows: list[list[tuple[int, int, int, int]]]) -> bytes:
    h, w = len(rows), len(rows[0])
    return HEADER + f"-Y {h} +X {w}\n".encode() + bytes(b for row in rows for px in row for b in px)


def test_flat_pixels_are_mantissa_times_two_to_the_exponent(tmp_path: Path) -> None:
    # m * 2^(e - 136): (128, e 129) -> 1.0; (64, e 130) -> 1.0; (200, e 140) -> 3200; e = 0 -> 0
    p = tmp_path / "a.hdr"
    p.write_bytes(_flat([[(128, 64, 0, 129), (64, 128, 32, 130)], [(200, 1, 255, 140), (90, 90, 90, 0)]]))
    img = read_hdr(p)
    assert img.shape == (2, 2, 3) and img.dtype == np.float32
    np.testing.assert_array_equal(img[0, 0], [1.0, 0.5, 0.0])
    np.testing.assert_array_equal(img[0, 1], [1.0, 2.0, 0.5])
    np.testing.assert_array_equal(img[1, 0], [3200.0, 16.0, 4080.0])
    np.testing.assert_array_equal(img[1, 1], [0.0, 0.0, 0.0])


def test_run_length_scanlines(tmp_path: Path) -> None:
    """One 10-pixel row: R a run of 10 x 128, G literals 0..9, B a run of 4 then 6 literals, E all 129."""
    row = bytes([2, 2, 0, 10])
    row += bytes([128 + 10, 128])
    row += bytes([10, *range(10)])
    row += bytes([128 + 4, 7, 6, 1, 2, 3, 4, 5, 6])
    row += bytes([128 + 10, 129])
    p = tmp_path / "rle.hdr"
    p.write_bytes(HEADER + b"-Y 2 +X 10\n" + row + row)
    img = read_hdr(p)
    expect = np.zeros((10, 3))
    expect[:, 0] = 1.0
    expect[:, 1] = np.arange(10) / 128
    expect[:, 2] = np.array([7, 7, 7, 7, 1, 2, 3, 4, 5, 6]) / 128
    np.testing.assert_array_equal(img[0], expect)
    np.testing.assert_array_equal(img[1], expect)


def test_textures_and_environment_maps_read_hdr(tmp_path: Path) -> None:
    p = tmp_path / "sky.hdr"
    p.write_bytes(_flat([[(128, 64, 0, 129)] * 4] * 2))
    np.testing.assert_array_equal(load_image(p, raw=False, what="t"), read_hdr(p))  # linear: never sRGB-decoded
    np.testing.assert_array_equal(load_envmap_image(p, "environment.filename"), read_hdr(p))


@pytest.mark.parametrize(("data", "match"), [
    (b"P6\n2 2\n255\n", "not a Radiance RGBE file"),
    (b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n", "no end of the header"),
    (b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n\x80\x80\x80\x81", "xyze is not read"),
    (b"#?RADIANCE\n\n+Y 1 +X 1\n\x80\x80\x80\x81", "other orientations are not read"),
    (b"#?RADIANCE\n\n-Y 2 +X 1\n\x80\x80\x80\x81", "row 1: the file ends early"),
    (b"#?RADIANCE\n\n-Y 1 +X 2\n\x80\x80\x80\x81\x01\x01\x01\x02", "old run-length encoding"),
    (b"#?RADIANCE\n\n-Y 1 +X 8\n\x02\x02\x00\x09", "run-length scanline of 9 pixels"),
    (b"#?RADIANCE\n\n-Y 1 +X 8\n\x02\x02\x00\x08\x8a\x00", "a run past the end"),
])
def test_bad_files_are_named(tmp_path: Path, data: bytes, match: str) -> None:
    p = tmp_path / "bad.hdr"
    p.write_bytes(data)
    with pytest.raises(InputError, match=f"sky: bad.hdr: .*{match}"):
        read_hdr(p, "sky")
