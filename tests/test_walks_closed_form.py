"""Random-walk estimators against closed-form solutions (tests/walk_problems.py).

Every unbiased estimator must agree with the exact f within 5 of its own
reported standard errors at every query point, and the reported standard
error must be right: over 20 seeds the z-scores (estimate - exact) / stderr
have a root mean square near 1.  ``truncated`` is biased by exactly the
missing tail of the Neumann series, which the test predicts and checks.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from walk_problems import CLOSED_FORM, CONST1, ROWGT1, SEP1, SEP2, UNBIASED, Problem

from mcocl import ConvergenceError, solve_fredholm

Z = 5.0


def solve(p: Problem, estimator: str, walks: int, seed: int = 1, **kw):
    return solve_fredholm(p.kernel, p.source, dim=p.dim, at=p.at, walks=walks, estimator=estimator, seed=seed, **kw)


@pytest.mark.parametrize("problem", CLOSED_FORM, ids=lambda p: p.name)
@pytest.mark.parametrize("estimator", UNBIASED)
def test_unbiased_estimators_match_the_closed_form(problem, estimator):
    r = solve(problem, estimator, 100_000)
    z = (r.values - problem.truth()) / r.stderr
    assert np.all(np.abs(z) < Z), f"{problem.name}/{estimator}: z = {z}"
    assert r.walks == 100_000
    assert r.nonfinite == [0, 0, 0]
    assert r.mean_walk_length > 0.1
    assert np.all(r.stderr > 0) and np.all(r.stderr < 0.01)


@pytest.mark.parametrize("problem", (SEP1, SEP2), ids=lambda p: p.name)
def test_roulette_with_a_constant_survival_probability(problem):
    r = solve(problem, "roulette", 100_000, survival=0.6)
    z = (r.values - problem.truth()) / r.stderr
    assert np.all(np.abs(z) < Z), z


@pytest.mark.parametrize("estimator", UNBIASED)
def test_row_integral_above_one_with_a_convergent_series(estimator):
    r = solve(ROWGT1, estimator, 100_000)
    z = (r.values - ROWGT1.truth()) / r.stderr
    assert np.all(np.abs(z) < Z), z


@pytest.mark.parametrize("problem", (SEP1, SEP2), ids=lambda p: p.name)
@pytest.mark.parametrize("estimator", UNBIASED)
def test_reported_stderr_matches_the_spread_over_seeds(problem, estimator):
    seeds = range(100, 120)
    z = []
    for s in seeds:
        r = solve(problem, estimator, 20_000, seed=s)
        z.append((r.values - problem.truth()) / r.stderr)
    z = np.concatenate(z)  # 20 seeds x 3 points, all independent
    rms = math.sqrt(np.mean(z**2))
    # sqrt(chi^2_60 / 60) lies in [0.68, 1.31] with probability 0.9998
    assert 0.65 < rms < 1.35, f"rms z = {rms:.3f}: the reported stderr is {'too small' if rms > 1 else 'too large'}"
    assert abs(np.mean(z)) < 4.0 / math.sqrt(len(z)) + 0.05, f"mean z = {np.mean(z):.3f}"


def test_truncated_bias_is_the_missing_tail_and_shrinks_with_depth():
    # K = 1/2, g = sin(pi x) - 1/pi: T^i g = 2^-i / pi for i >= 1, so the series
    # cut after D moves is f - 2^-D / pi at every x.
    truth = CONST1.truth()
    biases = []
    for depth in (1, 2, 4, 8):
        r = solve(CONST1, "truncated", 200_000, depth=depth)
        expected = truth - 2.0**-depth / math.pi
        z = (r.values - expected) / r.stderr
        assert np.all(np.abs(z) < Z), f"depth {depth}: z = {z}"
        assert r.mean_walk_length == depth
        biases.append(np.mean(np.abs(r.values - truth)))
    assert biases[0] > 0.1  # clearly biased at depth 1 (stderr ~ 1e-3)
    assert all(a > b for a, b in zip(biases, biases[1:])), biases
    # the roulette walk on the same problem is not biased
    r = solve(CONST1, "roulette", 200_000)
    assert np.all(np.abs((r.values - truth) / r.stderr) < Z)


def test_truncated_needs_only_the_series_of_k_to_converge():
    # K = 1.8 cos(6 pi (x - y)), g = cos(6 pi x): T g = 0.9 g, so the series of K
    # converges (spectral radius 0.9) though that of |K| does not (about 1.15).
    # Cut after D moves: f_D = (1 - 0.9^(D+1)) / 0.1 g.
    k, g = "1.8f*cos(6.0f*M_PI_F*(x[0] - y[0]))", "cos(6.0f*M_PI_F*x[0])"
    at = np.array([0.05, 0.3, 0.5])
    r = solve_fredholm(k, g, at=at, walks=200_000, estimator="truncated", depth=6, seed=4)
    expected = (1 - 0.9**7) / 0.1 * np.cos(6 * np.pi * at)
    assert np.all(np.abs((r.values - expected) / r.stderr) < Z)
    # a walk with a constant survival probability has no expectation here
    with pytest.raises(ConvergenceError, match=r"\|K\| has spectral radius"):
        solve_fredholm(k, g, at=at, walks=1000, estimator="roulette", survival=0.5)
