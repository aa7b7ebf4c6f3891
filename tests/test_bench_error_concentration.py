"""bench/error_concentration.py's arithmetic: the error shares and the oracle allocation's gain."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
from error_concentration import oracle_gain, shares  # noqa: E402


def test_shares_count_the_fewest_pixels_holding_each_share():
    err = np.zeros((4, 5))
    err[1, 2], err[3, 4], err[0, 0] = 6.0, 3.0, 1.0  # 60 %, 30 %, 10 % of the sum
    assert shares(err) == {0.5: 1, 0.8: 2, 0.9: 2}
    assert shares(np.ones((10, 10))) == {0.5: 50, 0.8: 80, 0.9: 90}


@pytest.mark.parametrize(("dev", "want"), [(np.full(16, 3.0), 1.0), (np.array([1.0, 0.0, 0.0, 0.0]), 4.0),
                                           (np.array([1.0, 2.0]), 2 * 5 / 9)])
def test_oracle_gain_is_uniform_over_proportional_allocation(dev, want):
    # uniform n = N / P: MSE sum s^2 P / N; n_p = N s_p / sum s: MSE (sum s)^2 / N
    assert oracle_gain(dev) == pytest.approx(want)
    assert oracle_gain(np.zeros(5)) == 1.0
