"""Stratified and N-rooks designs have the structure the lecture defines, computed on the device."""

from __future__ import annotations

import numpy as np
import pytest

from mcocl.integration.sampling import design_points


@pytest.mark.parametrize("n", [1, 2, 3, 7, 64, 1000, 1025, 4096])
@pytest.mark.parametrize("dim", [1, 3, 6])
def test_nrooks_puts_one_point_in_every_slab_of_every_axis(n: int, dim: int) -> None:
    x = design_points("nrooks", dim, n, design=3, seed=11).astype(np.float64)
    assert np.all((x > 0) & (x < 1))
    slabs = np.floor(x * n).astype(np.int64)
    for j in range(dim):
        assert np.array_equal(np.sort(slabs[:, j]), np.arange(n))  # a permutation: one rook per row


def test_nrooks_permutations_differ_between_axes_and_designs() -> None:
    n = 1000
    a = np.floor(design_points("nrooks", 2, n, design=0, seed=1) * n)
    b = np.floor(design_points("nrooks", 2, n, design=1, seed=1) * n)
    # independent random permutations agree in about one place
    assert np.sum(a[:, 0] == a[:, 1]) < 10
    assert np.sum(a[:, 0] == b[:, 0]) < 10
    # and the pairing across axes looks random: Spearman correlation near 0
    assert abs(np.corrcoef(a[:, 0], a[:, 1])[0, 1]) < 0.15


@pytest.mark.parametrize(("m", "dim"), [(1, 1), (10, 1), (7, 2), (4, 3)])
def test_stratified_puts_two_points_in_every_stratum(m: int, dim: int) -> None:
    x = design_points("stratified", dim, m, design=2, seed=5).astype(np.float64)
    cells = np.floor(x * m).astype(np.int64)
    h = np.zeros(len(x), np.int64)
    for j in reversed(range(dim)):
        h = h * m + cells[:, j]
    assert np.array_equal(h, np.repeat(np.arange(m**dim), 2))


@pytest.mark.parametrize("sampler", ["nrooks", "stratified"])
def test_the_estimator_uses_exactly_these_points(sampler: str) -> None:
    import mcocl

    f = "x[0] + 2.0f*x[1]*x[1] - x[2]"
    size = 5000 if sampler == "nrooks" else 9
    per_design = size if sampler == "nrooks" else 2 * size**3
    r = mcocl.integrate(f, dim=3, samples=2 * per_design, sampler=sampler, design_samples=per_design, seed=21)
    pts = np.concatenate([design_points(sampler, 3, size, design=d, seed=21) for d in (0, 1)]).astype(np.float64)
    mine = np.mean(pts[:, 0] + 2 * pts[:, 1] ** 2 - pts[:, 2])
    assert r.samples == 2 * per_design
    assert r.estimate == pytest.approx(mine, rel=1e-6)
