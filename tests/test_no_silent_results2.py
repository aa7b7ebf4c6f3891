"""No silently wrong result, second part (issue 10): overflowing float partial
sums, user densities that are not densities, a wrong row integral, and the
throughput of a resumed run."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mcocl
from mcocl.cli import main
from mcocl.errors import InputError

POLY = "x[0]*x[1] + x[2]"


def test_a_resumed_integration_reports_the_throughput_of_its_own_samples(tmp_path) -> None:
    ckpt = tmp_path / "run.npz"
    total = 1 << 20
    mcocl.integrate(POLY, dim=3, samples=total // 2, seed=5, checkpoint=str(ckpt))
    resumed = mcocl.integrate(POLY, dim=3, samples=total, seed=5, resume=str(ckpt))
    assert resumed.samples == total and resumed.samples_this_run == total // 2
    assert resumed.samples_per_second == (total // 2) / resumed.seconds
    assert resumed.to_dict()["samples_this_run"] == total // 2
    fresh = mcocl.integrate(POLY, dim=3, samples=total // 2, seed=5)
    assert fresh.samples_this_run == fresh.samples


def test_a_resumed_vegas_integration_counts_only_its_own_samples(tmp_path) -> None:
    kw = dict(dim=2, samples=1 << 22, sampler="vegas", seed=3, vegas_iterations=4)
    done = tmp_path / "done.npz"
    first = mcocl.integrate("x[0]*x[1]", checkpoint=str(done), **kw)
    assert first.samples_this_run == first.samples > 0
    again = mcocl.integrate("x[0]*x[1]", resume=str(done), **kw)  # finished: nothing is sampled again
    assert again.samples == first.samples and again.samples_this_run == 0


def test_a_resumed_solve_reports_the_throughput_of_its_own_walks(tmp_path) -> None:
    ckpt = tmp_path / "w.npz"
    kw = dict(dim=1, at=[0.5], seed=2)
    part = mcocl.solve_fredholm("0.5f", "1.0f", walks=1 << 14, checkpoint=str(ckpt), **kw)
    resumed = mcocl.solve_fredholm("0.5f", "1.0f", walks=1 << 15, resume=str(ckpt), **kw)
    assert resumed.walks == 1 << 15 and resumed.walks_this_run == (1 << 15) - part.walks
    assert resumed.walks_per_second == resumed.walks_this_run / resumed.seconds


def _analytic(pdf: str, inverse: str) -> dict[str, str]:
    return {"type": "analytic", "pdf": pdf, "inverse": inverse}


@pytest.mark.parametrize("pdf, inverse, message", [
    ("-1.0f", "u", r"proposal: the analytic proposal's pdf is -1 at x = .*finite and >= 0"),
    ("x < 0.5f ? 1.0f : NAN", "u", r"pdf is nan"),
    ("2.0f", "u", r"not the density of its inverse CDF"),  # not normalised
    ("2*x", "u", r"not the density of its inverse CDF"),  # the inverse of another density
    ("1.0f", "sqrt(u)", r"not the density of its inverse CDF"),
    ("1.0f", "2*u", r"inverse CDF is .* must map \(0, 1\) into \[0, 1\]"),
    ("x < 0.5f ? 2.0f : 5.0f", "0.5f*u", r"integrates to 3.5"),  # mass where the inverse never goes
])
def test_a_user_density_that_is_not_its_inverse_cdfs_density_is_refused(pdf: str, inverse: str, message: str) -> None:
    with pytest.raises(InputError, match=message):
        mcocl.integrate("x[0]", dim=1, samples=1 << 14, proposal=_analytic(pdf, inverse))


def test_a_wrong_density_is_named_among_several_proposals() -> None:
    good = _analytic("2*x", "sqrt(u)")
    with pytest.raises(InputError, match=r"proposals\[1\]\[0\]: the analytic proposal's pdf is -1"):
        mcocl.integrate("x[0]*x[1]", dim=2, samples=1 << 14,
                        proposals=[[good, "uniform"], [_analytic("-1.0f", "u"), good]])


@pytest.mark.parametrize("integrand, truth, pdf, inverse", [
    ("x[0]", 0.5, "2*x", "sqrt(u)"),
    ("x[0]", 0.5, "0.5f*rsqrt(x)", "u*u"),  # an integrable singularity at 0
    ("x[0]", 0.5, "0.1f*pow(x, -0.9f)", "pow(u, 10.0f)"),  # a strong one
    ("x[0] < 0.5f ? x[0] : 0.0f", 0.125, "x < 0.5f ? 2.0f : 0.0f", "0.5f*u"),  # a gap where the density is 0
    ("x[0]", 0.5, "3.0f*exp(-3.0f*x)/(1.0f - exp(-3.0f))", "-log(1.0f - u*(1.0f - exp(-3.0f)))/3.0f"),
])
def test_correct_user_densities_are_accepted(integrand: str, truth: float, pdf: str, inverse: str) -> None:
    r = mcocl.integrate(integrand, dim=1, samples=1 << 18, seed=4, proposal=_analytic(pdf, inverse))
    assert abs(r.estimate - truth) < 6 * r.stderr + 1e-6


def test_a_wrong_row_integral_is_refused() -> None:
    # K = y: the integral of |K(x, y)| dy is 1/2; with A = 2.5 the walks answered 10.0 where the truth is 2
    kw = dict(at=[0.5], walks=4096, estimator="subcritical", transition_sampler=["sqrt(u[0])"])
    with pytest.raises(InputError, match=r"row_integral: A\(x\) = 2.5 at x = .* is 0.5"):
        mcocl.solve_fredholm("y[0]", "1.0f", row_integral="2.5f", **kw)
    with pytest.raises(InputError, match=r"A\(x\) = -0.5 .* finite and >= 0"):
        mcocl.solve_fredholm("y[0]", "1.0f", row_integral="-0.5f", **kw)
    with pytest.raises(InputError, match=r"64 points per axis"):
        mcocl.solve_fredholm("0.3f*y[0]*y[1]", "1.0f", dim=2, at=[[0.5, 0.5]], walks=4096, estimator="subcritical",
                             row_integral="0.08f", transition_sampler=["sqrt(u[0])", "sqrt(u[1])"])


# Each with the inverse CDF of |K(x, .)| / A(x), which the sampler check requires (tests/test_walk_sampler_check.py):
# the masses left and right of x, L and R, pick the side, then the side's CDF is inverted in closed form.
KINK_SAMPLER = ("float L = 0.5f*x[0]*x[0], R = 0.5f*(1-x[0])*(1-x[0]); float t = u[0]*(L+R); "
                "return t < L ? x[0] - sqrt(x[0]*x[0] - 2*t) : x[0] + sqrt(2*(t-L));")
SINGULAR_SAMPLER = ("float L = 2*sqrt(x[0]), R = 2*sqrt(1-x[0]); float t = u[0]*(L+R); float h; "
                    "return t < L ? (h = 0.5f*(L-t), x[0] - h*h) : (h = 0.5f*(t-L), x[0] + h*h);")


@pytest.mark.parametrize("kernel, row_integral, sampler", [
    ("y[0]", "0.5f", "sqrt(u[0])"),
    ("0.5f*fabs(x[0]-y[0])", "0.25f*(x[0]*x[0] + (1-x[0])*(1-x[0]))", KINK_SAMPLER),  # a kink at y = x
    ("0.2f*rsqrt(fabs(x[0]-y[0]))", "0.4f*(sqrt(x[0]) + sqrt(1-x[0]))", SINGULAR_SAMPLER),  # integrable singularity
])
def test_a_correct_row_integral_is_accepted(kernel: str, row_integral: str, sampler: str) -> None:
    r = mcocl.solve_fredholm(kernel, "1.0f", at=[0.5], walks=4096, estimator="subcritical", seed=1,
                             row_integral=row_integral, transition_sampler=[sampler])
    assert np.all(np.isfinite(r.values))


def test_a_wrong_source_integral_is_refused() -> None:
    # g = 2x: the integral of |g| is 1
    kw = dict(at=[0.5], walks=4096, estimator="nee", source_sampler="sqrt(u[0])")
    with pytest.raises(InputError, match=r"source_integral: G = 3, but the integral of \|g\| is 1"):
        mcocl.solve_fredholm("0.5f", "2.0f*x[0]", source_integral=3.0, **kw)
    r = mcocl.solve_fredholm("0.5f", "2.0f*x[0]", source_integral=1.0, seed=2, **kw)
    assert np.all(np.isfinite(r.values))


def test_the_cli_refuses_a_wrong_row_integral_with_one_line(capsys) -> None:
    code = main(["solve", "--kernel", "y[0]", "--source", "1.0f", "--at", "0.5", "--estimator", "subcritical",
                 "--row-integral", "2.5f", "--transition-sampler", "sqrt(u[0])", "--walks", "4096"])
    err = capsys.readouterr().err
    assert code == 2 and "row_integral" in err and "Traceback" not in err


HUGE = "x[0] < 0.5f ? 3e38f : -3e38f"  # finite samples whose squares, and sums of a few, overflow float


@pytest.mark.parametrize("sampler", ["independent", "stratified", "nrooks", "sobol"])
def test_huge_finite_samples_give_a_finite_estimate(sampler: str) -> None:
    r = mcocl.integrate(HUGE, dim=1, samples=1 << 20, sampler=sampler, seed=3)
    assert r.nonfinite == 0
    assert np.isfinite(r.estimate) and np.isfinite(r.stderr) and r.stderr > 0
    assert abs(r.estimate) <= 6 * r.stderr  # the exact integral is 0
    r = mcocl.integrate("3e38f*x[0]", dim=1, samples=1 << 20, sampler=sampler, seed=3)
    assert abs(r.estimate - 1.5e38) <= 6 * r.stderr


def test_the_recomputed_sums_agree_across_vector_widths() -> None:
    # the per-virtual-lane double sums are the same; vlane_sum adds the lanes of
    # one vector before the running total, so the total may differ in its last bit
    a = mcocl.integrate(HUGE, dim=1, samples=1 << 18, seed=5, lanes=1)
    b = mcocl.integrate(HUGE, dim=1, samples=1 << 18, seed=5, lanes=8)
    assert a.estimate == b.estimate and a.stderr == pytest.approx(b.stderr, rel=1e-12)


def test_non_finite_sums_are_reported_loudly() -> None:
    from mcocl.integration.api import IntegrationResult, _report_overflowed_sums

    r = IntegrationResult(estimate=math.nan, stderr=math.nan, variance=math.nan, samples=10, seconds=1.0,
                          device="d", sampler="independent", seed=0, nonfinite=0)
    totals = np.zeros(9)
    totals[3] = math.inf
    with pytest.warns(mcocl.NonFiniteWarning, match="finite samples are not finite"):
        _report_overflowed_sums(totals, r)
    assert r.notes and r.notes[0].startswith("WARNING")
