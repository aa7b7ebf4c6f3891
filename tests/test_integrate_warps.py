"""Chi-square goodness of fit of every warp and tabulated density (as Mitsuba 3 and pbrt test theirs).

Points are drawn on the device exactly as the estimators draw them
(``sample_proposal``), histogrammed, and compared with the bin probabilities of
the density computed independently: the exact CDF of each family (math.erfc,
expm1, powers), the exact bin masses of a quantised table.  A fixed seed makes
the p-value deterministic; the family's significance level is the harness's
(tests/chi2.py), corrected for the number of tests here.
"""

from __future__ import annotations

import numpy as np
import pytest
from chi2 import Chi2Family

import mcocl
from mcocl.integration.proposals import factor_from_spec
from mcocl.integration.sampling import sample_proposal

N = 400_000
BINS = 80

WARPS = [
    "exponential:rate=3",
    "exponential:rate=-4",
    "exponential:rate=0.01",
    "exponential:rate=60",
    "power:a=-0.5",
    "power:a=2.5",
    "truncnorm:mu=0.3,sigma=0.1",
    "truncnorm:mu=-0.4,sigma=0.2",  # the mirrored branch (interval above the mean)
    "truncnorm:mu=1.3,sigma=0.3",
    "truncnorm:mu=0.5,sigma=5",
]


TABULATED_1D = [[1, 0, 3, 2], list(np.linspace(0.01, 5, 37)), [0, 0, 1e-6, 0, 1]]
# every warp, the analytic warp, each 1-D table and the 2-D table
FAMILY = Chi2Family("warps and tabulated densities", len(WARPS) + 1 + len(TABULATED_1D) + 1)


def _expected(counts: np.ndarray, probs: np.ndarray) -> np.ndarray:
    """Expected counts of the cells: the bin probabilities (normalised over [0,1]^d) times the samples."""
    return probs / probs.sum() * counts.sum()


@pytest.mark.parametrize("spec", WARPS)
def test_warp_chi_square(spec: str) -> None:
    f = factor_from_spec(spec)
    x, pw, pe = sample_proposal(spec, 1, N, seed=17)
    assert np.all((x > 0) & (x < 1))
    edges = np.linspace(0, 1, BINS + 1)
    counts, _ = np.histogram(x[:, 0], edges)
    probs = np.diff(f.cdf_np(edges))
    FAMILY.check(spec, counts, _expected(counts, probs))
    # the pdf the warp reports is the family's pdf at the point, and what MIS re-evaluates
    np.testing.assert_allclose(pw, f.pdf_np(x.astype(np.float64)), rtol=2e-5)
    np.testing.assert_allclose(pw, pe, rtol=1e-6)


def test_analytic_warp_chi_square() -> None:
    spec = {"type": "analytic", "pdf": "2*x", "inverse": "sqrt(u)"}
    x, pw, pe = sample_proposal(spec, 1, N, seed=18)
    edges = np.linspace(0, 1, BINS + 1)
    counts, _ = np.histogram(x[:, 0], edges)
    FAMILY.check("analytic 2x", counts, _expected(counts, np.diff(edges**2)))
    np.testing.assert_allclose(pw, 2 * x[:, 0], rtol=1e-5)


@pytest.mark.parametrize("weights", TABULATED_1D)
def test_tabulated_1d_chi_square(weights: list[float]) -> None:
    t = mcocl.tabulated(weights)
    x, pw, pe = sample_proposal(t, 1, N, seed=19)
    n = t.nbins
    # bin masses are exact (quantised CDF); positions inside a bin uniform: test on a 4x finer grid
    edges = np.linspace(0, 1, 4 * n + 1)
    counts, _ = np.histogram(x[:, 0], edges)
    probs = np.repeat(t.bin_mass() / 4, 4)
    FAMILY.check(f"tabulated, {len(weights)} weights", counts, _expected(counts, probs))
    assert np.all(pw > 0)  # a zero-weight bin is never sampled
    np.testing.assert_allclose(pw, pe, rtol=1e-6)
    # every positive weight keeps positive mass, however small
    assert np.all((t.bin_mass() > 0) == (np.asarray(weights) > 0))


def test_tabulated_2d_chi_square() -> None:
    rng = np.random.default_rng(3)
    w = rng.uniform(0, 1, size=(6, 9)) ** 3
    w[2, :] = 0  # an empty row
    w[4, 5] = 0
    t = mcocl.tabulated2d(w)
    x, pw, pe = sample_proposal(t, 2, N, seed=20)
    counts, _, _ = np.histogram2d(x[:, 0], x[:, 1], bins=[12, 18], range=[[0, 1], [0, 1]])
    probs = np.kron(t.cell_mass(), np.full((2, 2), 0.25))
    FAMILY.check("tabulated 6x9", counts, _expected(counts, probs))
    np.testing.assert_allclose(pw, t.pdf_np(x.astype(np.float64)), rtol=1e-5)
    np.testing.assert_allclose(pw, pe, rtol=1e-6)


def test_product_proposal_covers_dimensions_in_order() -> None:
    x, pw, _ = sample_proposal(["power:a=2", "uniform", "exponential:rate=5"], 3, N, seed=21)
    means = x.mean(axis=0)
    assert means[0] == pytest.approx(3 / 4, abs=3e-3)
    assert means[1] == pytest.approx(1 / 2, abs=3e-3)
    assert means[2] == pytest.approx(1 / 5 - np.exp(-5) / (1 - np.exp(-5)), abs=3e-3)
