"""The lecture's variance orderings, measured (DESIGN.md §3, point 4).

Where the lecture promises that one estimator beats another, both variances
per sample are measured with the engine and compared; where theory gives the
number (control variates, the combined estimators), it is computed here by
quadrature, independently of the engine.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate as quad

import mcocl


def test_stratified_beats_independent_on_smooth_integrand() -> None:
    f = "exp(-x[0]*x[0] - x[1]*x[1])"
    ind = mcocl.integrate(f, dim=2, samples=1 << 20, seed=1)
    strat = mcocl.integrate(f, dim=2, samples=1 << 20, seed=1, sampler="stratified")
    # lecture: sigma_strat^2 = sigma_sec^2 - sum_i I_i^2 + I^2/N <= sigma_sec^2; for a smooth
    # f in 2-D the gain grows like N^(2/d) = N: orders of magnitude here.
    assert strat.variance < 1e-3 * ind.variance


def test_nrooks_removes_variance_of_additive_integrand() -> None:
    # f = sum_j h(x_j): N-rooks stratifies every 1-D projection, which is all an additive f has.
    f = "x[0]*x[0] + sin(3.0f*x[1]) + exp(x[2]) + 1.0f/(1.0f + x[3]) + x[4]"
    ind = mcocl.integrate(f, dim=5, samples=1 << 20, seed=2)
    lhs = mcocl.integrate(f, dim=5, samples=1 << 20, seed=2, sampler="nrooks")
    exact = 1 / 3 + (1 - math.cos(3)) / 3 + (math.e - 1) + math.log(2) + 0.5
    assert abs(lhs.estimate - exact) <= 5 * lhs.stderr
    assert lhs.variance < 1e-4 * ind.variance


def test_importance_sampling_proportional_to_f_is_zero_variance() -> None:
    # p = f exactly: f/p = 1 for every sample (lecture: the ideal density).
    f = "3.0f*exp(-3.0f*x[0]) / (1.0f - exp(-3.0f))"
    ind = mcocl.integrate(f, samples=1 << 18, seed=3)
    imp = mcocl.integrate(f, samples=1 << 18, seed=3, proposal="exponential:rate=3")
    assert imp.estimate == pytest.approx(1.0, abs=1e-6)
    # nothing is left but float32 rounding: the stderr is the engine's rounding floor
    assert imp.stderr <= 2.0**-23 * imp.estimate
    assert ind.stderr > 1e3 * imp.stderr


# Two narrow peaks, and one proposal for each: a tabulated density with 90 % of its
# mass on its own peak and 10 % spread over [0, 1], so every estimator is unbiased
# and has finite variance, but a single proposal pays dearly for the other peak.
PEAKS = "exp(-0.5f*(x[0]-0.2f)*(x[0]-0.2f)/0.0025f) + exp(-0.5f*(x[0]-0.8f)*(x[0]-0.8f)/0.0025f)"
_C = (np.arange(64) + 0.5) / 64


def _peak_table(mu: float) -> np.ndarray:
    bump = np.exp(-0.5 * (_C - mu) ** 2 / 0.0025)
    return 0.1 / 64 + 0.9 * bump / bump.sum()


PROPS = [mcocl.tabulated(_peak_table(0.2)), mcocl.tabulated(_peak_table(0.8))]


def _peaks_np(x: np.ndarray) -> np.ndarray:
    return np.exp(-0.5 * (x - 0.2) ** 2 / 0.0025) + np.exp(-0.5 * (x - 0.8) ** 2 / 0.0025)


def _theory_variance(weights: str) -> float:
    """Variance of one combined sample (one point per technique), by quadrature (lecture slide 'Rozptyl kombinovaného odhadu')."""
    p = [lambda x, f=f: f.pdf_np(np.array([[x]]))[0] for f in PROPS]
    edges = list(np.arange(65) / 64)
    total = 0.0
    for i in range(2):
        def w(x: float, i: int = i) -> float:
            q = np.array([p[0](x), p[1](x)])
            if weights == "average":
                return 0.5
            if weights == "balance":
                return q[i] / q.sum()
            if weights == "power":
                return q[i] ** 2 / (q**2).sum()
            return float(q[i] == q.max() and (i == 0 or q[0] < q[1]))
        m2 = m1 = 0.0
        pi = p[i]
        for a, b in zip(edges[:-1], edges[1:]):
            m2 += quad.quad(lambda x, pi=pi: (w(x) * _peaks_np(x)) ** 2 / pi(x), a, b)[0]
            m1 += quad.quad(lambda x: w(x) * _peaks_np(x), a, b)[0]
        total += m2 - m1 * m1
    return total


def test_combined_heuristics_on_two_peaks() -> None:
    n = 1 << 18
    exact = quad.quad(_peaks_np, 0, 1, points=[0.2, 0.8])[0]
    runs = {h: mcocl.integrate(PEAKS, samples=2 * n, seed=4, proposals=PROPS, heuristic=h) for h in ("average", "max", "balance", "power")}
    singles = [mcocl.integrate(PEAKS, samples=n, seed=4, proposal=p) for p in PROPS]
    for r in runs.values():
        assert abs(r.estimate - exact) <= 5 * r.stderr
    # variance per combined sample (2 evaluations) against theory
    for h, r in runs.items():
        measured = r.stderr**2 * (r.samples // 2)
        assert measured == pytest.approx(_theory_variance(h), rel=0.15), h
    # each single proposal barely covers the other peak; per evaluation it is far worse
    best = max(runs["balance"].variance, runs["power"].variance)
    for s in singles:
        assert abs(s.estimate - exact) <= 5 * s.stderr
        assert best < 0.5 * s.variance
    # the lecture's ordering: balance and power beat the average
    assert runs["balance"].variance < runs["average"].variance
    assert runs["power"].variance < runs["average"].variance


def test_control_variate_cuts_variance_by_theoretical_ratio() -> None:
    # f = e^x, g = 1 + x + x^2/2 (its Taylor polynomial), J = 1 + 1/2 + 1/6
    f, g, j = "exp(x[0])", "1.0f + x[0] + 0.5f*x[0]*x[0]", 1 + 0.5 + 1 / 6
    plain = mcocl.integrate(f, samples=1 << 20, seed=5)
    cv = mcocl.integrate(f, samples=1 << 20, seed=5, control=g, control_integral=j)
    var_f = (math.e**2 - 1) / 2 - (math.e - 1) ** 2
    h = lambda x: np.exp(x) - (1 + x + x * x / 2)  # noqa: E731
    m1 = quad.quad(h, 0, 1)[0]
    var_h = quad.quad(lambda x: h(x) ** 2, 0, 1)[0] - m1 * m1
    assert abs(cv.estimate - (math.e - 1)) <= 5 * cv.stderr
    assert plain.variance == pytest.approx(var_f, rel=0.02)
    assert cv.variance / plain.variance == pytest.approx(var_h / var_f, rel=0.05)


def test_russian_roulette_is_unbiased_and_costs_variance() -> None:
    # lecture: <I>_Russ = f(xi/P)/P for xi < P; unbiased, variance grows as P falls
    f = "exp(-x[0]*x[0])"
    exact = math.sqrt(math.pi) / 2 * math.erf(1)
    plain = mcocl.integrate(f, samples=1 << 20, seed=6)
    vs = []
    for p in (0.8, 0.5, 0.2):
        r = mcocl.integrate(f, samples=1 << 20, seed=6, roulette=p)
        assert abs(r.estimate - exact) <= 5 * r.stderr
        # theory: Var = E[f^2]/P - I^2
        ef2 = math.sqrt(math.pi / 2) / 2 * math.erf(math.sqrt(2))
        assert r.variance == pytest.approx(ef2 / p - exact**2, rel=0.03)
        vs.append(r.variance)
    assert plain.variance < vs[0] < vs[1] < vs[2]
