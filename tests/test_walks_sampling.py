"""Goodness of fit of the walks' tabulated samplers (chi-square, as Mitsuba and pbrt test theirs).

The kernel's own sampling functions (``walk_transition``, ``walk_source_sample``)
are run through ``walk_sample_check`` with the engine's uniforms.  For an
unbiased walk what matters is that a move y is drawn with *exactly* the
density the weight divides by: the histogram of y over the table's bins
(split in two halves each, to check the position inside a bin as well) must
fit the table's masses, and the multiplier m = K/p must equal K(x, y) / p(y)
computed on the host from the table.
"""

from __future__ import annotations

import numpy as np
import pytest
from chi2 import Chi2Family

from mcocl import runtime
from mcocl.walks.codegen import generate
from mcocl.walks.job import WalkJob
from mcocl.walks.nystrom import ExpressionEvaluator
from mcocl.walks.tabulate import DEFENSIVE, Q_FLOOR, TOTAL, alias_words, build_tables, default_grid, mixture_counts


def _runner(kernel: str, source: str, dim: int, estimator: str = "nee"):
    code = generate(kernel, source, dim, estimator)
    job = WalkJob(code, np.full((1, dim), 0.5), seed=0, walk_limit=1)
    r = job.runner(runtime.device_context())
    grid = default_grid(dim)
    job.tables = build_tables(r.tabulate_kernel(grid), r.tabulate_source(grid) if estimator == "nee" else None, grid)
    return job, r


def _bin_index(pts: np.ndarray, bins: int, halves: bool) -> np.ndarray:
    """Row-major bin index (axis 0 most significant); with ``halves`` the last axis is split in two."""
    idx = np.zeros(len(pts), dtype=np.int64)
    for k in range(pts.shape[1]):
        c = np.minimum((pts[:, k] * bins).astype(np.int64), bins - 1)
        idx = idx * bins + c
    if halves:
        last = pts[:, -1] * bins
        half = ((last - np.floor(last)) >= 0.5).astype(np.int64)
        idx = idx * 2 + half
    return idx


def _check_fit(label: str, pts: np.ndarray, mass: np.ndarray, bins: int) -> None:
    """Chi-square of the points over the table's bins, each split in two halves, against the table's masses."""
    n = len(pts)
    obs = np.bincount(_bin_index(pts, bins, True), minlength=2 * len(mass))
    FAMILY.check(label, obs, np.repeat(mass, 2) / 2 * n)


K1 = "3.0f*exp(-(x[0]-y[0])*(x[0]-y[0])/0.01f) * (1.2f - y[0])"
K2 = "0.9f*exp(-4.0f*((x[0]-y[0])*(x[0]-y[0]) + (x[1]-y[1])*(x[1]-y[1]))) * sin(6.0f*y[0] + 1.0f)"
# the transition and the source sampler, each in 1-D and 2-D
FAMILY = Chi2Family("walk samplers", 4)


@pytest.mark.parametrize("case", [("1d", K1, "x[0]", 1, 0.37), ("2d", K2, "x[1] - 0.3f", 2, (0.8, 0.15))],
                         ids=lambda c: c[0])
def test_tabulated_transition_sampler_fits_its_density(case):
    _, k, g, dim, xv = case
    job, r = _runner(k, g, dim)
    x = np.atleast_1d(np.asarray(xv, dtype=np.float32))
    grid = job.tables.grid
    cell = int(_bin_index(x[None, :], grid.cells, False)[0])
    mass = job.tables.transition_mass(cell)
    n = 400_000
    s = r.sample_check(x, n, seed=3)
    assert np.all((s["y"] > 0) & (s["y"] < 1))
    _check_fit(f"transition {case[0]}", s["y"], mass, grid.bins)
    # every lane reports the survival probability of the cell
    assert np.all(s["q"] == np.float32(job.tables.survival(cell)))
    assert Q_FLOOR <= s["q"][0] <= 1.0
    # m = K(x, y) / p(y) with p from the table on the host
    ev = ExpressionEvaluator(k, g, dim)
    kxy = ev.kernel_grid(x[None, :], s["y"][:2000])[0]
    p = mass[_bin_index(s["y"][:2000].astype(np.float64), grid.bins, False)] * grid.nbins
    np.testing.assert_allclose(s["m"][:2000], kxy / p, rtol=2e-5, atol=1e-6)


@pytest.mark.parametrize("case", [("1d", "x[0]", "exp(-(x[0]-0.3f)*(x[0]-0.3f)/0.002f) - 0.2f", 1),
                                  ("2d", "0.3f", "x[0]*x[1] - 0.25f", 2)], ids=lambda c: c[0])
def test_tabulated_source_sampler_fits_its_density(case):
    _, k, g, dim = case
    job, r = _runner(k, g, dim)
    grid = job.tables.grid
    mass = job.tables.source_mass()
    s = r.sample_check(np.full(dim, 0.5), 400_000, seed=4)
    _check_fit(f"source {case[0]}", s["z"], mass, grid.bins)
    ev = ExpressionEvaluator(k, g, dim)
    gz = ev.source(s["z"][:2000])
    p = mass[_bin_index(s["z"][:2000].astype(np.float64), grid.bins, False)] * grid.nbins
    np.testing.assert_allclose(s["e"][:2000], gz / p, rtol=2e-5, atol=1e-6)


def test_tabulated_density_follows_the_kernel():
    # the table is the defensive mixture of |K(x, .)| averaged over the bins
    job, _ = _runner(K1, "x[0]", 1, "subcritical")
    grid = job.tables.grid
    cell = int(0.37 * grid.cells)
    y = (np.arange(grid.bins) + 0.5) / grid.bins
    x = (cell + 0.5) / grid.cells
    w = 3.0 * np.exp(-((x - y) ** 2) / 0.01) * (1.2 - y)
    want = (1 - DEFENSIVE) * w / w.sum() + DEFENSIVE / grid.bins
    np.testing.assert_allclose(job.tables.transition_mass(cell), want, rtol=0.03, atol=2e-6)
    # survival = the row integral, for a row integral below 1
    assert job.tables.survival(cell) == pytest.approx(np.mean(w), rel=0.01)


def test_alias_tables_are_exact():
    # the probability of every bin must be exactly counts / 2^23, for peaked,
    # flat and random rows, down to 1 bin and up to 4096
    rng = np.random.default_rng(7)
    for nb in (1, 2, 8, 256, 4096):
        w = np.vstack([rng.random(nb), np.ones(nb), np.eye(1, nb, nb // 2)[0], rng.random(nb) ** 8])
        counts = mixture_counts(w)
        assert np.all(counts.sum(axis=1) == TOTAL) and np.all(counts >= 1)
        words = alias_words(counts).astype(np.int64)
        thr, alias = words // nb, words % nb
        m = TOTAL // nb
        implied = thr.copy()
        for r in range(len(w)):
            np.add.at(implied[r], alias[r], m - thr[r])
        assert np.array_equal(implied, counts)
        assert np.all((thr >= 0) & (thr <= m))
