"""User transition and source samplers of walks are checked against their densities (issue 10).

A sampler that draws from another density than |K(x, .)| / A(x) or |g| / G
gave a wrong answer with exit 0; mcocl/walks/sampler_check.py now refuses it
before any walk, and accepts the right inverse CDFs, including one of a
kernel with an integrable singularity.
"""

from __future__ import annotations

import numpy as np
import pytest

import mcocl
from mcocl.cli import main
from mcocl.errors import InputError

ROW = dict(kernel="y[0]", source="1.0f", estimator="subcritical", row_integral="0.5f")  # A = 1/2, p(y) = 2y
SRC = dict(kernel="0.5f", source="2.0f*x[0]", estimator="nee", source_integral=1.0)  # G = 1, p(z) = 2z
PLANE = dict(kernel="0.3f*y[0]*y[1]", source="1.0f", dim=2, at=[[0.5, 0.5]], estimator="subcritical",
             row_integral="0.075f")


@pytest.mark.parametrize(("kw", "sampler", "words"), [
    (ROW, {"transition_sampler": "u[0]"}, r"transition_sampler does not sample \|K\(x, y\)\| / A\(x\): at x = "),
    (ROW, {"transition_sampler": "1.0f - sqrt(u[0])"}, r"differ from that density by 0\.[3-9]"),
    (SRC, {"source_sampler": "u[0]"}, r"source_sampler does not sample \|g\| / G"),
    (PLANE, {"transition_sampler": ["sqrt(u[0])", "u[1]"]}, r"cell \[.*\) x \[.*\) got"),
    (ROW, {"transition_sampler": "sqrt(u[0]) - 0.5f"}, r"transition_sampler: \d+ of 16384 sampled points"),
])
def test_a_sampler_of_another_density_is_refused(kw, sampler, words) -> None:
    with pytest.raises(InputError, match=words):
        mcocl.solve_fredholm(**{"at": [0.5], **kw}, **sampler, walks=4096)


@pytest.mark.parametrize(("kw", "sampler", "truth"), [
    (ROW, {"transition_sampler": "sqrt(u[0])"}, 2.0),  # f = 1 + (1/2) f -> 2
    (SRC, {"source_sampler": "sqrt(u[0])"}, None),
    (PLANE, {"transition_sampler": ["sqrt(u[0])", "sqrt(u[1])"]}, None),
])
def test_the_right_sampler_is_accepted_and_unbiased(kw, sampler, truth) -> None:
    r = mcocl.solve_fredholm(**{"at": [0.5], **kw}, **sampler, walks=1 << 15, seed=5)
    assert np.all(np.isfinite(r.values))
    if truth is not None:
        assert abs(r.values[0] - truth) < 5 * r.stderr[0]


def test_the_cli_refuses_a_wrong_sampler_with_one_line(capsys) -> None:
    code = main(["solve", "--kernel", "y[0]", "--source", "1.0f", "--at", "0.5", "--estimator", "subcritical",
                 "--row-integral", "0.5f", "--transition-sampler", "u[0]", "--walks", "4096"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "transition_sampler does not sample" in err
