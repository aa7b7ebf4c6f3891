"""Every integration estimator against closed-form integrals in 1, 2, 5 and 10 dimensions.

Two checks per (estimator, dimension) (DESIGN.md §3):
1. one run with a fixed seed: |estimate - exact| <= 5 reported standard errors;
2. calibration: over K = 100 seeds, the root-mean-square actual error agrees
   with the mean reported standard error within 25 %.  With K = 100 the RMS of
   normal errors has a relative spread of 1/sqrt(2K) = 7 %, so 25 % is a
   3.5-sigma bound, chosen before running; a failure means a wrong stderr.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from integration_problems import CASES, Case, tabulated2d_case

import mcocl

DIMS = (1, 2, 5, 10)


@pytest.mark.parametrize("dim", DIMS)
@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_estimate_within_five_stderr(case: Case, dim: int) -> None:
    r = mcocl.integrate(case.integrand(dim), dim=dim, samples=200_000, seed=11, **case.options(dim))
    exact = case.exact(dim)
    assert r.nonfinite == 0
    assert r.stderr > 0
    assert abs(r.estimate - exact) <= 5 * r.stderr, (r.estimate, exact, r.stderr)


@pytest.mark.parametrize("dim", DIMS)
@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_reported_stderr_is_calibrated(case: Case, dim: int) -> None:
    exact = case.exact(dim)
    expr, opts = case.integrand(dim), case.options(dim)
    runs = [mcocl.integrate(expr, dim=dim, samples=1 << 14, seed=1000 + s, **opts) for s in range(100)]
    err = np.array([r.estimate - exact for r in runs])
    se = np.array([r.stderr for r in runs])
    rms = math.sqrt(np.mean(err**2))
    assert abs(rms / se.mean() - 1) <= 0.25, (rms, se.mean())


@pytest.mark.parametrize("dim", (2, 5, 10))
def test_tabulated2d_importance(dim: int) -> None:
    expr, exact, opts = tabulated2d_case(dim)
    r = mcocl.integrate(expr, dim=dim, samples=200_000, seed=5, **opts)
    assert abs(r.estimate - exact) <= 5 * r.stderr
    runs = [mcocl.integrate(expr, dim=dim, samples=1 << 14, seed=2000 + s, **opts) for s in range(100)]
    rms = math.sqrt(np.mean([(q.estimate - exact) ** 2 for q in runs]))
    assert abs(rms / np.mean([q.stderr for q in runs]) - 1) <= 0.25


def test_stderr_falls_as_inverse_sqrt_n() -> None:
    # lecture: sigma_sec = sigma_prim / sqrt(N)
    f = "exp(-x[0]*x[0])"
    a = mcocl.integrate(f, samples=1 << 16, seed=3)
    b = mcocl.integrate(f, samples=1 << 20, seed=3)
    assert b.stderr == pytest.approx(a.stderr / 4, rel=0.05)
    assert b.variance == pytest.approx(a.variance, rel=0.05)


# Discontinuous integrands (issue 12, part 4): a jump cuts one stratum in one
# dimension, so the stratum pairs alone usually miss it; the reported stderr
# must still be calibrated.  Exact values: the measure of the region x0 < 0.3
# (0.3) and of the triangle x0 + x1 < 0.7 (0.7^2 / 2, times 2).
STRATIFIED_JUMPS = {
    "jump-1d": ("x[0] < 0.3f ? 1.0f : 0.0f", 1, 0.3),
    "jump-2d": ("x[0] + x[1] < 0.7f ? 2.0f : 0.0f", 2, 0.49),
}


@pytest.mark.parametrize("samples", (1 << 12, 1 << 16))
@pytest.mark.parametrize("case", sorted(STRATIFIED_JUMPS))
def test_stratified_stderr_is_calibrated_on_a_jump(case: str, samples: int) -> None:
    # 40 seeds: an honest stderr puts ~0.3 % beyond 3 (t with >= 15 dof: ~1 %),
    # and the rms z is 1 +- 11 %; before the design spread entered, 50-59 % were beyond 3.
    f, dim, exact = STRATIFIED_JUMPS[case]
    z = np.array([(r.estimate - exact) / r.stderr
                  for r in (mcocl.integrate(f, dim=dim, samples=samples, sampler="stratified", seed=300 + s)
                            for s in range(40))])
    assert np.mean(np.abs(z) > 3) <= 0.05, z
    assert 0.7 <= math.sqrt(np.mean(z**2)) <= 1.3, z


def test_one_dimensional_stratified_budgets_hold_sixteen_designs() -> None:
    r = mcocl.integrate("x[0] < 0.3f ? 1.0f : 0.0f", samples=1 << 16, sampler="stratified", seed=1)
    assert r.samples == 1 << 16
    assert any("2048^1 strata per design" in n for n in r.notes), r.notes
