"""The one chi-square goodness-of-fit harness of the test suite.

Every sampling routine (warps, tabulated densities, BSDF and light sampling,
the walks' transition tables, primitive sampling) is tested the same way, as
Mitsuba 3's ``ChiSquareTest`` and pbrt-v4's ``Chi2Test`` do it: histogram many
samples drawn on the device, integrate the density the sampler claims over the
same cells, and compare.

- Cells whose expected count is below :data:`MIN_EXPECTED` (5, the usual rule
  for the chi-square approximation of Pearson's statistic) are merged: cells
  are taken in order of increasing expected count and pooled until the pool
  reaches 5, so sparse cells merge with their neighbours in that order.
- A cell the density gives (almost) no mass but that received samples fails
  the test outright: no amount of pooling excuses an impossible sample.
- The expected counts must add up to the number of samples (within
  ``total_rtol``): a density that does not integrate to one is reported as
  such, not hidden by a rescaling.
- The tests of one family (one file's parametrised cases) share one
  family-wise significance level through the Šidák correction: each test runs
  at ``1 - (1 - alpha_family) ** (1 / m)`` so that, were every sampler right,
  the whole family would fail with probability ``alpha_family``.
- A failure reports the statistic, the degrees of freedom, the p-value, the
  threshold, and the cells that contribute most, observed against expected.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats

MIN_EXPECTED = 5.0
# The family-wise significance level every family uses unless it says otherwise
# (Mitsuba's ChiSquareTest default is 1 %).
FAMILY_ALPHA = 0.01
# A cell whose expected count is below this fraction of the total is treated as
# having none (a quadrature of a pdf that is exactly zero there leaves crumbs).
ZERO_FRACTION = 1e-9


@dataclass(frozen=True)
class Cell:
    """One cell of the test after pooling: the original cells it holds and its counts."""

    members: tuple[int, ...]
    observed: float
    expected: float

    @property
    def contribution(self) -> float:
        """This cell's term (o - e)^2 / e of Pearson's statistic."""
        return (self.observed - self.expected) ** 2 / self.expected

    def describe(self) -> str:
        """``cell 17`` or ``cells 3, 5, 9 (pooled)``, with observed and expected counts."""
        if len(self.members) == 1:
            name = f"cell {self.members[0]}"
        else:
            shown = ", ".join(str(m) for m in self.members[:6]) + (", ..." if len(self.members) > 6 else "")
            name = f"cells {shown} ({len(self.members)} pooled)"
        return f"{name}: observed {self.observed:.0f}, expected {self.expected:.1f} (term {self.contribution:.1f})"


@dataclass(frozen=True)
class Chi2Result:
    """The outcome of one goodness-of-fit test."""

    statistic: float
    dof: int
    pvalue: float
    cells: tuple[Cell, ...]
    problem: str = ""  # set when the test failed before any statistic (impossible samples, wrong total)
    pooled: int = field(default=0)  # how many original cells went into pools

    def report(self, worst: int = 5) -> str:
        """A readable account: the statistic, dof, p-value and the ``worst`` cells."""
        if self.problem:
            return self.problem
        lines = [f"chi-square {self.statistic:.2f} on {self.dof} degrees of freedom, p = {self.pvalue:.3g} "
                 f"({len(self.cells)} cells, {self.pooled} original cells pooled)"]
        for c in sorted(self.cells, key=lambda c: -c.contribution)[:worst]:
            lines.append("  " + c.describe())
        return "\n".join(lines)


def pool_cells(observed: np.ndarray, expected: np.ndarray, min_expected: float = MIN_EXPECTED) -> list[Cell]:
    """Merge sparse cells: in order of increasing expected count, pool until the pool holds ``min_expected``.

    Cells without expectation (and without samples) are dropped; the caller
    checks the impossible ones first.  The result keeps the remaining cells in
    index order, the pool (if any) last.
    """
    order = np.argsort(expected, kind="stable")
    pool_members: list[int] = []
    pool_o = pool_e = 0.0
    own: list[Cell] = []
    for i in order:
        e = float(expected[i])
        if e <= 0.0:
            continue
        if e < min_expected or (pool_members and pool_e < min_expected):
            pool_members.append(int(i))
            pool_o += float(observed[i])
            pool_e += e
        else:
            own.append(Cell((int(i),), float(observed[i]), e))
    own.sort(key=lambda c: c.members[0])
    if pool_members:
        own.append(Cell(tuple(sorted(pool_members)), pool_o, pool_e))
    return own


def chi2_test(observed, expected, min_expected: float = MIN_EXPECTED, total_rtol: float = 5e-3) -> Chi2Result:
    """Pearson's chi-square test of ``observed`` counts against ``expected`` counts.

    Args:
        observed: samples per cell (any shape; flattened).
        expected: the number of samples the claimed density puts in each cell
            (same shape): N times the integral of the pdf over the cell.
        min_expected: cells expecting fewer samples are pooled (see :func:`pool_cells`).
        total_rtol: how far the expected counts may add up away from the
            number of samples (quadrature error) before the test fails.

    Returns:
        The result; ``pvalue`` is 0 when a sample fell where the density has no
        mass or when the totals disagree, and ``problem`` says which.

    Raises:
        ValueError: the shapes differ, a count is negative or not finite, or
            fewer than two cells remain after pooling (a test without power).
    """
    obs = np.asarray(observed, dtype=np.float64).ravel()
    exp = np.asarray(expected, dtype=np.float64).ravel()
    if obs.shape != exp.shape:
        raise ValueError(f"observed has {obs.size} cells but expected has {exp.size}")
    if not (np.all(np.isfinite(obs)) and np.all(np.isfinite(exp)) and np.all(obs >= 0) and np.all(exp >= 0)):
        raise ValueError("counts must be finite and non-negative")
    n, e_total = obs.sum(), exp.sum()
    empty = exp <= ZERO_FRACTION * e_total
    impossible = empty & (obs > 0)
    if impossible.any():
        cells = np.flatnonzero(impossible)
        listed = ", ".join(f"cell {k}: {obs[k]:.0f}" for k in cells[:5])
        return Chi2Result(np.inf, 0, 0.0, (), f"{obs[impossible].sum():.0f} samples in {len(cells)} cells "
                          f"the density gives no mass ({listed}{', ...' if len(cells) > 5 else ''})")
    if abs(e_total - n) > total_rtol * n:
        return Chi2Result(np.inf, 0, 0.0, (), f"the expected counts add up to {e_total:.1f} but {n:.0f} samples "
                          f"were drawn (relative gap {(e_total - n) / n:.2e} > {total_rtol:g}): the density does "
                          "not integrate to one over the cells")
    exp = np.where(empty, 0.0, exp)
    exp *= n / exp.sum()  # the remaining quadrature error, within total_rtol, must not bias the statistic
    cells = pool_cells(obs, exp, min_expected)
    if len(cells) < 2:
        raise ValueError(f"{len(cells)} cell(s) left after pooling cells below {min_expected:g} expected samples: "
                         "the test has no power; draw more samples or use fewer cells")
    stat = float(sum(c.contribution for c in cells))
    dof = len(cells) - 1
    pooled = sum(len(c.members) for c in cells if len(c.members) > 1)
    return Chi2Result(stat, dof, float(stats.chi2.sf(stat, dof)), tuple(cells), pooled=pooled)


def sidak_alpha(family_alpha: float, tests: int) -> float:
    """Per-test significance level so that ``tests`` independent tests fail together with ``family_alpha``."""
    if not 0.0 < family_alpha < 1.0 or tests < 1:
        raise ValueError(f"need 0 < family_alpha < 1 and tests >= 1, got {family_alpha}, {tests}")
    return -np.expm1(np.log1p(-family_alpha) / tests)


class Chi2Family:
    """The chi-square tests of one family, sharing a family-wise significance level.

    Args:
        name: what the family tests (shown in failure messages).
        tests: how many distinct tests (labels) the family runs; each runs at the
            Šidák level :func:`sidak_alpha` (``alpha``, ``tests``).
        alpha: the family-wise significance level.

    Running more distinct labels than declared fails, since the correction
    would then be too lenient.
    """

    def __init__(self, name: str, tests: int, alpha: float = FAMILY_ALPHA) -> None:
        self.name = name
        self.tests = int(tests)
        self.alpha = float(alpha)
        self.alpha_per_test = sidak_alpha(self.alpha, self.tests)
        self._labels: set[str] = set()

    def check(self, label: str, observed, expected, min_expected: float = MIN_EXPECTED,
              total_rtol: float = 5e-3) -> Chi2Result:
        """Run :func:`chi2_test`; raise ``AssertionError`` with the report unless p > the per-test level."""
        self._labels.add(label)
        if len(self._labels) > self.tests:
            raise AssertionError(f"chi-square family {self.name!r} declares {self.tests} tests but ran "
                                 f"{len(self._labels)} ({label!r} is one too many): raise its count")
        res = chi2_test(observed, expected, min_expected, total_rtol)
        if not res.pvalue > self.alpha_per_test:
            raise AssertionError(
                f"{self.name}, {label}: the samples do not fit the density (p = {res.pvalue:.3g} <= "
                f"{self.alpha_per_test:.3g}, the Šidák level of {self.alpha:g} over {self.tests} tests)\n"
                + res.report())
        return res
