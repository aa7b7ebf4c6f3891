"""Bad input, divergent series and non-finite values: clear errors, nothing silent."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mcocl import ConvergenceError, InputError, KernelBuildError, NonFiniteWarning, solve_fredholm
from mcocl.cli import main as cli_main

AT = [[0.1], [0.5], [0.9]]


def test_kernel_that_does_not_compile_is_quoted():
    with pytest.raises(KernelBuildError) as e:
        solve_fredholm("0.5f*(x[0] + z)", "1.0f", at=AT, walks=1000)
    msg = str(e.value)
    assert "kernel" in msg and "0.5f*(x[0] + z)" in msg and "^" in msg


def test_source_that_does_not_compile_is_quoted():
    with pytest.raises(KernelBuildError, match=r"source[\s\S]*undeclared"):
        solve_fredholm("0.5f", "x[0] + undeclared_thing", at=AT, walks=1000)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"at": [[0.1, 0.2]], "dim": 1}, r"at: the query points have 2 coordinates but the problem has dim=1"),
        ({"at": [[0.1], [0.5]], "dim": 2}, r"at: the query points have 1 coordinates but the problem has dim=2"),
        ({"at": [[1.5]]}, r"at\[0\] = \[1.5\] is not a point of the domain"),
        ({"at": [[float("nan")]]}, r"at\[0\]"),
        ({"at": []}, r"at must be a non-empty list"),
        ({"dim": 0}, r"dim must be an integer >= 1"),
        ({"walks": 0}, r"walks must be an integer >= 1"),
        ({"walks": None}, r"walks=None needs time_budget"),
        ({"estimator": "magic"}, r"estimator: unknown estimator 'magic'"),
        ({"seed": -1}, r"seed must be"),
        ({"estimator": "roulette", "survival": 1.5}, r"survival must be 'weight' or a probability"),
        ({"estimator": "nee", "survival": 0.5}, r"survival applies to estimator='roulette' only"),
        ({"estimator": "subcritical", "row_integral": "0.5f"}, r"needs both row_integral"),
        ({"estimator": "roulette", "row_integral": "0.5f", "transition_sampler": "u[0]"}, r"apply to the subcritical"),
        ({"estimator": "subcritical", "row_integral": "0.5f", "transition_sampler": ["u[0]", "u[0]"]},
         r"transition_sampler must give one OpenCL C expression per coordinate \(1\)"),
        ({"estimator": "nee", "source_integral": -1.0, "source_sampler": "u[0]"}, r"source_integral must be a positive"),
        ({"estimator": "subcritical", "source_integral": 1.0, "source_sampler": "u[0]"}, r"apply to the nee estimator"),
        ({"max_walk_length": 0}, r"max_walk_length must be an integer >= 1"),
        ({"estimator": "truncated", "depth": 20, "max_walk_length": 10}, r"depth \(20\) exceeds max_walk_length"),
        ({"table_bins": 100_000}, r"table_bins must be a power of two"),
        ({"table_bins": 1024, "dim": 2, "at": [[0.5, 0.5]]}, r"table_bins: 1024\^2 = 1048576 bins"),
        ({"lanes": 3}, r"lanes must be"),
        ({"time_budget": -1.0}, r"time_budget must be a positive number"),
    ],
)
def test_bad_arguments_are_named(kwargs, match):
    args = {"kernel": "0.5f", "source": "1.0f", "at": AT, "walks": 1000}
    args.update(kwargs)
    with pytest.raises(InputError, match=match):
        solve_fredholm(**args)


def test_empty_code_is_rejected():
    with pytest.raises(InputError, match="kernel must be OpenCL C code"):
        solve_fredholm("  ", "1.0f", at=AT)


@pytest.mark.parametrize("estimator", ["roulette", "subcritical", "nee"])
def test_divergent_series_is_stopped_by_the_guard(estimator):
    # K = 1.2: spectral radius 1.2, the weights grow like 1.2^n
    with pytest.raises(ConvergenceError, match="appears not to converge"):
        solve_fredholm("1.2f", "1.0f", at=AT, walks=100_000, estimator=estimator)


def test_borderline_series_is_stopped_by_the_walk_length_guard():
    # K = 1: the weight stays 1 and the walk never dies: only the length guard can stop it
    with pytest.raises(ConvergenceError, match="max_walk_length=300"):
        solve_fredholm("1.0f", "1.0f", at=AT, walks=100_000, estimator="subcritical", max_walk_length=300)


@pytest.mark.parametrize(("estimator", "kw"), [("truncated", {}), ("roulette", {"survival": 0.5})])
def test_divergence_is_caught_before_fixed_length_walks(estimator, kw):
    with pytest.raises(ConvergenceError, match=r"spectral radius about 1\.2"):
        solve_fredholm("1.2f", "1.0f", at=AT, walks=1000, estimator=estimator, **kw)


def test_nonfinite_walks_are_counted_reported_and_left_out():
    # g is NaN for x < 0.2: every walk that visits there is non-finite
    with pytest.warns(NonFiniteWarning, match="NaN or infinite"):
        r = solve_fredholm("0.5f", "sqrt(x[0] - 0.2f)", at=[[0.5], [0.9]], walks=20_000, estimator="roulette")
    assert all(0 < n < 20_000 for n in r.nonfinite)
    assert np.all(np.isfinite(r.values)) and np.all(np.isfinite(r.stderr))
    # a NaN at the query point itself: every walk is non-finite, the value is NaN, nothing raises
    with pytest.warns(NonFiniteWarning):
        r = solve_fredholm("0.5f", "sqrt(x[0] - 0.2f)", at=[[0.1]], walks=2048, estimator="roulette")
    assert r.nonfinite == [2048] and np.isnan(r.values[0])


def test_nonfinite_kernel_values_are_noted_in_the_tabulation():
    with pytest.warns(NonFiniteWarning):
        r = solve_fredholm("0.5f*sqrt(y[0] - 0.3f)", "1.0f", at=[[0.5]], walks=4096, estimator="subcritical")
    assert any("NaN/Inf" in n for n in r.notes)
    assert r.nonfinite[0] > 0


def test_cli_reports_errors_with_a_nonzero_exit(capsys):
    assert cli_main(["solve", "--kernel", "1.2f", "--source", "1.0f", "--at", "0.5", "--quiet"]) == 2
    assert "appears not to converge" in capsys.readouterr().err
    assert cli_main(["solve", "--kernel", "0.5f", "--source", "1.0f", "--dim", "2", "--at", "0.5", "--quiet"]) == 2
    assert "dim=2" in capsys.readouterr().err
    assert cli_main(["solve", "--kernel", "0.5f +", "--source", "1.0f", "--at", "0.5", "--quiet"]) == 2
    assert "kernel" in capsys.readouterr().err


def test_cli_json_has_the_documented_fields(capsys):
    rc = cli_main(["solve", "--kernel", "0.5f", "--source", "sin(M_PI_F*x[0]) - 0.318309886f", "--at", "0.1", "0.5",
                   "--walks", "2e4", "--estimator", "nee", "--json", "--reference", "--order", "32"])
    assert rc == 0
    d = json.loads(capsys.readouterr().out)
    for key in ("values", "stderr", "walks", "mean_walk_length", "seconds", "estimator", "seed", "reference"):
        assert key in d
    assert d["walks"] == 20_000 and d["estimator"] == "nee" and len(d["values"]) == 2
    np.testing.assert_allclose(d["reference"], np.sin(np.pi * np.array([0.1, 0.5])), atol=1e-6)
    rc = cli_main(["solve", "--kernel", "0.3f", "--source", "x[0]*x[1]", "--dim", "2", "--at", "0.2,0.7", "0.5,0.5",
                   "--walks", "5000", "--json", "--estimator", "roulette"])
    d = json.loads(capsys.readouterr().out)
    assert rc == 0 and d["at"] == [[0.2, 0.7], [0.5, 0.5]]
