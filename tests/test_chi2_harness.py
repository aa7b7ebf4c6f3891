"""The chi-square harness itself (tests/chi2.py): it accepts a right density, rejects a wrong one,
pools sparse cells as documented, applies the Šidák correction and reports clearly.

The samples come from NumPy with fixed seeds, so every p-value here is deterministic.
"""

from __future__ import annotations

import numpy as np
import pytest
from chi2 import Chi2Family, chi2_test, pool_cells, sidak_alpha
from scipy import stats

EDGES = np.linspace(0.0, 1.0, 41)


def _linear_samples(n: int, seed: int) -> np.ndarray:
    """Samples of the density 2x on [0, 1] (inverse CDF sqrt(u))."""
    return np.sqrt(np.random.default_rng(seed).random(n))


def test_accepts_the_right_density_and_rejects_a_wrong_one() -> None:
    n = 200_000
    counts, _ = np.histogram(_linear_samples(n, seed=11), EDGES)
    right = chi2_test(counts, np.diff(EDGES**2) * n)
    assert right.pvalue > 1e-3, right.report()
    assert right.dof == len(EDGES) - 2
    # a density off by a few percent: 2x mixed with 5 % of the uniform density
    slightly_wrong = np.diff(0.95 * EDGES**2 + 0.05 * EDGES) * n
    assert chi2_test(counts, slightly_wrong).pvalue < 1e-6
    assert chi2_test(counts, np.full(40, n / 40)).pvalue < 1e-100


def test_statistic_is_pearsons_when_nothing_is_pooled() -> None:
    obs = np.array([48.0, 61.0, 39.0, 52.0])
    exp = np.array([50.0, 55.0, 45.0, 50.0])
    res = chi2_test(obs, exp)
    ref = stats.chisquare(obs, exp)
    assert res.statistic == pytest.approx(ref.statistic, rel=1e-12)
    assert res.pvalue == pytest.approx(ref.pvalue, rel=1e-12)
    assert res.dof == 3 and res.pooled == 0


def test_sparse_cells_pool_in_order_of_expected_count() -> None:
    # cells 0, 2 and 4 expect fewer than 5: together they hold 6, enough for one pool
    cells = pool_cells(np.array([1, 40, 3, 60, 2.0]), np.array([1.0, 44.0, 3.0, 55.0, 2.0]))
    assert [c.members for c in cells] == [(1,), (3,), (0, 2, 4)]
    assert cells[-1].observed == 6 and cells[-1].expected == 6
    # sparse cells holding less than 5 together take in the next smallest cell
    cells = pool_cells(np.array([1, 1, 90, 210.0]), np.array([1.0, 1.5, 100.0, 200.0]))
    assert [c.members for c in cells] == [(3,), (0, 1, 2)]
    assert cells[-1].expected == pytest.approx(102.5)
    # cells without expectation (and without samples) are left out
    cells = pool_cells(np.array([0, 30, 70.0]), np.array([0.0, 30.0, 70.0]))
    assert [c.members for c in cells] == [(1,), (2,)]


def test_pooling_keeps_a_right_density_right_and_a_wrong_tail_wrong() -> None:
    n = 100_000
    x = np.random.default_rng(5).exponential(1 / 12, n)
    edges = np.linspace(0, 1, 81)
    counts, _ = np.histogram(x, edges)
    counts = np.append(counts, np.sum(x >= 1))
    tail = np.exp(-12 * edges)
    right = np.append(-np.diff(tail), tail[-1]) * n
    res = chi2_test(counts, right)
    assert res.pooled > 10 and res.pvalue > 1e-3, res.report()
    # a sampler that never reaches the sparse tail fails even though those cells are pooled
    cut = counts.copy()
    cut[-50:] = 0
    cut[0] += counts[-50:].sum()
    assert chi2_test(cut, right).pvalue < 1e-6


def test_a_sample_where_the_density_is_zero_fails_outright() -> None:
    res = chi2_test([100, 1, 99], [100.0, 0.0, 100.0])
    assert res.pvalue == 0.0
    assert "no mass" in res.report() and "cell 1: 1" in res.report()


def test_expected_counts_must_add_up_to_the_samples() -> None:
    res = chi2_test([50, 50], [60.0, 60.0])
    assert res.pvalue == 0.0 and "does not integrate to one" in res.report()
    # a quadrature error inside the tolerance is renormalised away
    assert chi2_test([500, 500], [500.5, 501.0]).pvalue > 0.9


def test_a_test_without_power_is_an_error() -> None:
    with pytest.raises(ValueError, match="no power"):
        chi2_test([3, 1], [2.0, 2.0])
    with pytest.raises(ValueError, match="cells"):
        chi2_test([1, 2, 3], [1.0, 2.0])


def test_sidak_level() -> None:
    assert sidak_alpha(0.01, 1) == pytest.approx(0.01, rel=1e-12)
    a = sidak_alpha(0.01, 15)
    assert (1 - a) ** 15 == pytest.approx(0.99, rel=1e-12)
    assert 0.01 / 15 < a < 0.01 / 14
    with pytest.raises(ValueError):
        sidak_alpha(0.0, 3)


def test_family_reports_the_worst_cells_on_failure() -> None:
    fam = Chi2Family("demo", tests=2)
    n = 200_000
    counts, _ = np.histogram(_linear_samples(n, seed=12), EDGES)
    assert fam.check("right", counts, np.diff(EDGES**2) * n).pvalue > fam.alpha_per_test
    with pytest.raises(AssertionError) as err:
        fam.check("uniform", counts, np.full(40, n / 40))
    msg = str(err.value)
    assert "demo, uniform" in msg and "degrees of freedom" in msg and "p = " in msg
    assert "Šidák level of 0.01 over 2 tests" in msg
    # the worst cells of 2x against the uniform density are the two ends (observed ~ 0 and ~ 2 * expected)
    worst = msg.splitlines()[2:4]
    assert any("cell 0: observed" in w for w in worst) and any("cell 39: observed" in w for w in worst), msg


def test_family_refuses_more_tests_than_declared() -> None:
    fam = Chi2Family("demo", tests=1)
    fam.check("one", [100, 100], [100.0, 100.0])
    fam.check("one", [100, 100], [100.0, 100.0])  # the same test again is not another test
    with pytest.raises(AssertionError, match="declares 1 tests but ran 2"):
        fam.check("two", [100, 100], [100.0, 100.0])
