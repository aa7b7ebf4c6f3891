"""No silently wrong result (issue 10): each class of input that used to give a
plausible-looking but wrong answer with exit status 0 is refused or fixed."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import mcocl
from mcocl.cli import main
from mcocl.errors import InputError

FURNACE = str(Path(__file__).resolve().parent.parent / "scenes" / "furnace.json")


@pytest.mark.parametrize("snippet, dim", [("x[5]", 2), ("x[0] + x[ 1 ]", 1), ("x[2u]*2.0f", 2)])
def test_a_constant_index_beyond_dim_is_refused(snippet: str, dim: int) -> None:
    with pytest.raises(InputError, match=r"beyond the \d coordinate"):
        mcocl.integrate(snippet, dim=dim, samples=1000)


def test_a_constant_index_beyond_dim_is_refused_in_walks_too() -> None:
    with pytest.raises(InputError, match="y\\[1\\] is beyond"):
        mcocl.solve_fredholm("0.5f*x[0]*y[1]", "1.0f", dim=1, at=[0.5], walks=100)


def test_indices_inside_dim_and_other_names_are_accepted() -> None:
    r = mcocl.integrate("float max[3]; max[2] = x[1]; return max[2] + x[0];", dim=2, samples=4096, seed=1)
    assert math.isfinite(r.estimate)


def test_proposal_and_proposals_together_are_refused_on_the_command_line(capsys) -> None:
    code = main(["integrate", "x[0]", "--proposal", "power:a=0.5", "--proposals", "power:a=0.5", "power:a=1"])
    assert code == 2 and "not both" in capsys.readouterr().err


@pytest.mark.parametrize("budget", [1e-9, 1e-6])
def test_a_tiny_time_budget_still_computes_the_first_block(budget: float) -> None:
    r = mcocl.integrate("exp(-x[0])", dim=1, samples=None, time_budget=budget, seed=2)
    assert r.samples > 0 and math.isfinite(r.estimate) and math.isfinite(r.stderr)
    assert abs(r.estimate - (1 - math.exp(-1))) < 6 * r.stderr


def test_a_non_finite_exposure_is_refused(tmp_path, capsys) -> None:
    r = mcocl.render(FURNACE, spp=1, seed=0)
    with pytest.raises(InputError, match="exposure"):
        r.save_png(tmp_path / "x.png", exposure=float("nan"))
    with pytest.raises(SystemExit):
        main(["render", FURNACE, "--spp", "1", "--out", str(tmp_path / "a.exr"), "--exposure", "nan"])
    assert "finite" in capsys.readouterr().err
    assert np.all(np.isfinite(r.mean))
