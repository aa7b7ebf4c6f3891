"""Philox4x32-10 against Random123's known answers, and the engine's uniforms."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mcocl import rng
from mcocl.errors import InputError

# Random123's known-answer vectors for Philox4x32-10 (its tests/kat_vectors file)
KAT = Path(__file__).resolve().parent / "data" / "random123-philox4x32-10-kat.txt"


def _kat_vectors() -> list[list[int]]:
    lines = KAT.read_text().splitlines()
    out = []
    for line in lines:
        f = line.split()
        if not f or f[0].startswith("#"):
            continue
        out.append([int(v, 16) for v in f[2:12]])
    return out


def test_known_answer_vectors() -> None:
    vecs = np.array(_kat_vectors(), dtype=np.uint64)
    assert len(vecs) >= 3
    got = rng.philox4x32_10(vecs[:, 0:4], vecs[:, 4:6])
    np.testing.assert_array_equal(got, vecs[:, 6:10].astype(np.uint32))


def _numpy_u01(bits: np.ndarray) -> np.ndarray:
    return ((bits >> 9).astype(np.float64) + 0.5) * 2.0**-23


def test_uniform_addressing_matches_philox_words() -> None:
    # u(seed, i, j) = convert(Philox(ctr=(lo(i), hi(i), j//4, stream), key=(lo(s), hi(s)))[j % 4])
    seed, first, count, dims = 0x1234_5678_9ABC_DEF0, 2**32 - 3, 7, 6
    u = rng.uniforms(seed, first, count, dims, stream=rng.STREAM_SAMPLE)
    for k in range(count):
        i = first + k
        for j in range(dims):
            ctr = np.array([i & 0xFFFFFFFF, i >> 32, j // 4, rng.STREAM_SAMPLE], np.uint64)
            key = np.array([seed & 0xFFFFFFFF, seed >> 32], np.uint64)
            word = rng.philox4x32_10(ctr, key)[j % 4]
            assert u[k, j] == np.float32(_numpy_u01(np.array([word], np.uint64))[0])


def test_conversion_is_open_interval_and_centred() -> None:
    bits = np.array([0, 1, 511, 512, 2**31, 2**32 - 512, 2**32 - 1], dtype=np.uint32)
    u = rng.to_unit_float(bits)
    assert u.min() > 0.0 and u.max() < 1.0
    assert u[0] == np.float32(2.0**-24) and u[-1] == np.float32(1 - 2.0**-24)
    np.testing.assert_array_equal(u.astype(np.float64), _numpy_u01(bits.astype(np.uint64)))
    # Every one of the 2^23 cells maps to its centre, so the mean over a full
    # period of the top bits is exactly 1/2 (truncation would give 1/2 - 2^-24).
    cells = (np.arange(2**23, dtype=np.uint64) << 9).astype(np.uint32)
    assert np.mean(rng.to_unit_float(cells).astype(np.float64)) == 0.5


def test_streams_and_seeds_differ() -> None:
    a = rng.uniforms(1, 0, 1000, 4)
    b = rng.uniforms(2, 0, 1000, 4)
    c = rng.uniforms(1, 0, 1000, 4, stream=rng.STREAM_AUX)
    assert not np.any(a == b) or np.mean(a == b) < 1e-3
    assert np.mean(a == c) < 1e-3
    # and a sample's numbers do not depend on which range they were computed in
    np.testing.assert_array_equal(rng.uniforms(1, 500, 10, 4), a[500:510])


def test_bad_shapes() -> None:
    with pytest.raises(InputError):
        rng.philox4x32_10(np.zeros((2, 3)), np.zeros((2, 2)))


@pytest.mark.parametrize("start", [0, 1, 2, 3, 4, 5])
def test_sampler_group_draws_match_one_by_one(start: int) -> None:
    # next_2d and next_nd take fast paths on aligned dimension counters and
    # fall back otherwise; either way they must hand out the same numbers as
    # the engine's addressing, dimension by dimension.
    seed, first = 0xDEAD_BEEF_0123_4567, 2**32 - 2
    u = rng.uniforms(seed, first, 5, start + 6, stream=rng.STREAM_AUX)[:, start:]
    d = rng.sampler_draws(seed, first, 5, start, stream=rng.STREAM_AUX)
    for g in range(3):
        np.testing.assert_array_equal(d[:, g], u)
