"""Random walks against the Nyström reference, and the reference against closed forms.

The Nyström solver (mcocl.walks.nystrom) shares only the parsing of the
expressions with the walks; it is checked first on the closed-form problems,
then used as the truth for kernels without a closed form: non-separable,
signed (kernel and source change sign) in 1-D and 2-D.
"""

from __future__ import annotations

import numpy as np
import pytest
from walk_problems import CLOSED_FORM, ROWGT1, UNBIASED

from mcocl import solve_fredholm
from mcocl.errors import InputError
from mcocl.walks import nystrom, spectral_radius

Z = 5.0


@pytest.mark.parametrize("problem", (*CLOSED_FORM, ROWGT1), ids=lambda p: p.name)
def test_nystrom_reproduces_the_closed_forms(problem):
    sol = nystrom(problem.kernel, problem.source, problem.dim)
    np.testing.assert_allclose(sol(np.asarray(problem.at)), problem.truth(), atol=2e-6)


def test_nystrom_converges_with_the_order():
    k, g = "0.7f*exp(-3.0f*(x[0]-y[0])*(x[0]-y[0]))", "cos(2.0f*x[0])"
    at = [0.0, 0.3, 1.0]
    a, b = nystrom(k, g, 1, order=16)(at), nystrom(k, g, 1, order=64)(at)
    assert np.max(np.abs(a - b)) < 1e-5


NONSEP = [
    ("nonsep1", "0.7f*exp(-3.0f*(x[0]-y[0])*(x[0]-y[0]))", "cos(2.0f*x[0]) + x[0]", 1, [[0.05], [0.5], [0.95]]),
    ("signed1", "0.9f*cos(3.0f*(x[0]-y[0]))", "cos(5.0f*x[0])", 1, [[0.1], [0.45], [0.9]]),
    ("nonsep2", "0.5f*exp(-(x[0]-y[0])*(x[0]-y[0]) - 2.0f*(x[1]-y[1])*(x[1]-y[1]))", "x[0] + x[1]*x[1]", 2,
     [[0.2, 0.7], [0.5, 0.5], [0.9, 0.1]]),
    ("signed2", "0.8f*sin(2.0f*x[0] - 3.0f*y[1] + 1.0f)", "cos(4.0f*x[0]*x[1]) - 0.5f", 2,
     [[0.2, 0.7], [0.5, 0.5], [0.95, 0.05]]),
]


@pytest.mark.parametrize("case", NONSEP, ids=lambda c: c[0])
@pytest.mark.parametrize("estimator", UNBIASED)
def test_walks_match_nystrom(case, estimator):
    _, k, g, dim, at = case
    ref = nystrom(k, g, dim)(np.asarray(at))
    r = solve_fredholm(k, g, dim=dim, at=at, walks=100_000, estimator=estimator, seed=5)
    z = (r.values - ref) / r.stderr
    assert np.all(np.abs(z) < Z), f"{case[0]}/{estimator}: z = {z}"


def test_signed_problem_really_is_signed():
    # the signed cases must exercise negative weights and values
    _, k, g, dim, at = NONSEP[1]
    ref = nystrom(k, g, dim)(np.linspace(0, 1, 11))
    assert ref.min() < 0 < ref.max()
    assert spectral_radius(k, 1, absolute=False) < spectral_radius(k, 1) < 1


def test_user_given_transition_and_source_samplers():
    # K = y: A(x) = 1/2, p(y) = 2y, y = sqrt(u).  g = 2x: G = 1, zeta = sqrt(u).
    # f = 2x + c, c = integral y f = 2/3 + c/2  ->  c = 4/3.
    at = [[0.1], [0.5], [0.9]]
    truth = 2 * np.array([0.1, 0.5, 0.9]) + 4.0 / 3.0
    for est, kw in (
        ("subcritical", {}),
        ("nee", {}),
        ("nee", {"source_integral": 1.0, "source_sampler": "sqrt(u[0])"}),
    ):
        r = solve_fredholm("y[0]", "2.0f*x[0]", at=at, walks=100_000, estimator=est, seed=2,
                           row_integral="0.5f", transition_sampler=["sqrt(u[0])"], **kw)
        z = (r.values - truth) / r.stderr
        assert np.all(np.abs(z) < Z), (est, kw, z)
        assert "user's transition sampler" in r.description


def test_user_sampler_outside_the_domain_is_refused_not_clamped():
    # the sampler check (mcocl/walks/sampler_check.py) refuses it before any walk; before it, the walks
    # counted such points as non-finite
    with pytest.raises(InputError, match=r"transition_sampler: .* lie outside \[0, 1\]"):
        solve_fredholm("y[0]", "1.0f", at=[0.5], walks=4096, estimator="subcritical",
                       row_integral="0.5f", transition_sampler=["2.0f*sqrt(u[0])"])


def test_nystrom_bad_input():
    with pytest.raises(InputError, match="order"):
        nystrom("0.5f", "1.0f", 1, order=0)
    with pytest.raises(InputError, match="not finite"):
        nystrom("0.5f/(x[0]-y[0])", "1.0f", 1, order=7)  # the centre node meets itself
    with pytest.raises(InputError, match="coordinates"):
        nystrom("0.5f", "1.0f", 2, order=4)([[0.1, 0.2, 0.3]])
