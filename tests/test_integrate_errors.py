"""Bad input gets a clear error naming what was wrong; bad samples are counted, never averaged in."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import warnings

import numpy as np
import pytest
from vector_lanes import needs_vector_lanes

import mcocl
from mcocl.errors import InputError, KernelBuildError


def test_integrand_that_does_not_compile_quotes_the_line() -> None:
    with pytest.raises(KernelBuildError) as e:
        mcocl.integrate("float s = x[0];\nreturn s * undefined_thing;", samples=100)
    msg = str(e.value)
    assert "integrand, line 2" in msg
    assert "return s * undefined_thing;" in msg
    assert "undefined_thing" in msg
    assert len(msg.splitlines()) < 12  # not a 200-line compiler log


def test_unfinished_expression() -> None:
    with pytest.raises(KernelBuildError, match="end of the expression"):
        mcocl.integrate("exp(-x[0]", samples=100)


@pytest.mark.parametrize(
    ("kwargs", "needle"),
    [
        ({"sampler": "halton"}, "sampler"),
        ({"dim": 0}, "dim"),
        ({"dim": 2.5}, "dim"),
        ({"samples": 0}, "samples"),
        ({"samples": -5}, "samples"),
        ({"seed": -1}, "seed"),
        ({"proposal": [1.0, -2.0, 3.0]}, "negative"),
        ({"proposal": [0.0, 0.0]}, "all zero"),
        ({"proposal": [1.0, float("nan")]}, "NaN"),
        ({"proposal": "exponential:rate=0"}, "rate"),
        ({"proposal": "power:a=-1"}, "a must be > -1"),
        ({"proposal": "truncnorm:mu=5,sigma=0.01"}, "no usable mass"),
        ({"proposal": "gaussian"}, "unknown proposal"),
        ({"proposal": {"type": "exponential"}}, "needs"),
        ({"proposal": {"type": "exponential", "rate": 1, "scale": 2}}, "unknown key"),
        ({"proposals": ["uniform", "exponential:rate=1"], "shares": [1]}, "shares"),
        ({"proposals": ["uniform", "exponential:rate=1"], "shares": [1, 0]}, "shares"),
        ({"proposals": ["uniform", "exponential:rate=1"], "heuristic": "median"}, "heuristic"),
        ({"proposals": ["uniform", "exponential:rate=1"], "beta": 0}, "beta"),
        ({"proposal": "uniform", "proposals": ["uniform"]}, "either"),
        ({"control": "x[0]"}, "control_integral"),
        ({"roulette": 1.5}, "roulette"),
        ({"roulette": 0}, "roulette"),
        ({"samples": None}, "time_budget"),
        ({"time_budget": -1}, "time_budget"),
    ],
)
def test_bad_arguments(kwargs: dict, needle: str) -> None:
    args = {"samples": 1000, **kwargs}
    with pytest.raises(InputError, match=needle):
        mcocl.integrate("x[0]", **args)


def test_proposal_dimension_mismatch() -> None:
    with pytest.raises(InputError, match="covers 1 dimension"):
        mcocl.integrate("x[0]*x[1]", dim=2, samples=1000, proposal=["uniform"])
    with pytest.raises(InputError, match="2-D array"):
        mcocl.tabulated2d([1.0, 2.0])


def test_nonfinite_samples_are_counted_and_left_out() -> None:
    # NaN on [0, 0.25), 1 elsewhere: the estimate of the finite part is exactly 1
    f = "x[0] < 0.25f ? NAN : 1.0f"
    with pytest.warns(mcocl.NonFiniteWarning, match="NaN or infinite"):
        r = mcocl.integrate(f, samples=1 << 16, seed=1)
    assert r.nonfinite == pytest.approx(0.25 * r.samples, rel=0.05)
    assert r.estimate == 1.0
    assert math.isfinite(r.stderr)
    with pytest.warns(mcocl.NonFiniteWarning):
        s = mcocl.integrate("1.0f / (x[0] - x[0])", samples=1000, sampler="stratified")
    assert s.nonfinite == s.samples


@needs_vector_lanes
def test_scalar_fallback_for_code_not_valid_on_vectors() -> None:
    body = "if (x[0] < 0.5f) return 1.0f;\nreturn 0.0f;"
    r = mcocl.integrate(body, samples=1 << 16, seed=2)
    assert r.lanes == 1
    assert any("scalar" in n for n in r.notes)
    assert abs(r.estimate - 0.5) <= 5 * r.stderr


@needs_vector_lanes
def test_lane_form_that_means_something_else_is_caught() -> None:
    # any() of a scalar comparison tests its sign bit (always 0); of a vector
    # comparison, whether some lane is true: compiles both ways, means different things.
    r = mcocl.integrate("any(x[0] > 0.5f) ? 1.0f : 0.0f", samples=1 << 14, seed=3)
    assert r.lanes == 1
    assert any("disagreed" in n for n in r.notes)
    assert r.estimate == 0.0


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mcocl", *args], capture_output=True, text=True, timeout=120)


def test_cli_json_has_the_documented_fields() -> None:
    p = _cli("integrate", "exp(-x[0]*x[0])", "--dim", "1", "--samples", "1e5", "--json", "--seed", "7")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    for key in ("estimate", "stderr", "variance", "samples", "seconds", "device", "sampler", "seed", "nonfinite"):
        assert key in d
    assert abs(d["estimate"] - math.sqrt(math.pi) / 2 * math.erf(1)) <= 5 * d["stderr"]
    assert d["seed"] == 7 and d["samples"] == 100_000


def test_cli_errors_exit_nonzero_with_a_message() -> None:
    p = _cli("integrate", "exp(-x[0]*y)", "--samples", "1000")
    assert p.returncode == 2
    assert "integrand, line 1" in p.stderr and "Traceback" not in p.stderr
    p = _cli("integrate", "x[0]", "--sampler", "halton")
    assert p.returncode == 2 and "invalid choice" in p.stderr
    p = _cli("integrate", "x[0]", "--samples", "0")
    assert p.returncode == 2 and "samples" in p.stderr
    p = _cli("integrate", "x[0]", "--proposal", "[1, -1]")
    assert p.returncode == 2 and "negative" in p.stderr


def test_cli_warns_about_nonfinite_samples() -> None:
    p = _cli("integrate", "x[0] < 0.5f ? INFINITY : 1.0f", "--samples", "1e4", "--quiet")
    assert p.returncode == 0
    assert "WARNING" in p.stderr and "NaN or infinite" in p.stderr
    assert "nonfinite" in p.stdout


def test_quantised_cdf_keeps_tiny_bins() -> None:
    from mcocl.integration.proposals import CDF_TOTAL, quantised_cdf

    with warnings.catch_warnings():
        cum = quantised_cdf(np.array([1e-12, 1.0, 0.0, 1e-12]))
    counts = np.diff(cum.astype(np.int64))
    assert cum[-1] == CDF_TOTAL
    assert list(counts > 0) == [True, True, False, True]
