"""Singular integrands: resolution near 0 and the infinite-variance warning (issue 12, part 3)."""

from __future__ import annotations

import math
import warnings

import pytest

import mcocl
from mcocl.errors import HeavyTailWarning

Z_BOUND = 5.0


def _quiet_integrate(*args, **kwargs) -> tuple[mcocl.IntegrationResult, list[warnings.WarningMessage]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = mcocl.integrate(*args, **kwargs)
    return r, [w for w in caught if issubclass(w.category, HeavyTailWarning)]


def test_points_below_2_to_minus_24_are_reached():
    """f = 2^30 on (0, 2^-30), else 0: exact integral 1, all of it below the old clamp at 2^-24.

    A power-law proposal puts 1/8 of the points there; clamping warped points at
    2^-24 gave 0.  Finite variance (f/p = 10 2^30 x^0.9 there), so a z-test applies.
    """
    r = mcocl.integrate("x[0] < 0x1p-30f ? 0x1p30f : 0.0f", dim=1, samples=2**20,
                        proposal=mcocl.power(-0.9), seed=11)
    assert abs(r.estimate - 1.0) <= Z_BOUND * r.stderr, (r.estimate, r.stderr)


def test_first_grid_cell_is_refined_for_sobol():
    """f = 2^23 h(2^23 x) with h(t) = 3 t^2 on the first grid cell: integral 1.

    Every Sobol' replicate of 2^25 points holds exactly 4 points in the cell
    [0, 2^-23); on the bare grid they all sat at its centre, giving h(1/2) =
    0.75 with zero spread between replicates.  Refined, they are uniform in the
    cell and the estimate is 1 within the replicates' standard error.
    """
    f = "x[0] < 0x1p-23f ? 0x1p23f * 3.0f * (x[0] * 0x1p23f) * (x[0] * 0x1p23f) : 0.0f"
    r = mcocl.integrate(f, dim=1, samples=4 * 2**25, sampler="sobol", replicates=4, seed=2)
    assert r.stderr > 0.0
    assert abs(r.estimate - 1.0) <= Z_BOUND * r.stderr, (r.estimate, r.stderr)


@pytest.mark.parametrize("sampler", ["independent", "nrooks"])
def test_infinite_variance_is_reported(sampler: str):
    """x^-3/4 has infinite variance: the run says so (note and HeavyTailWarning) and names the remedy."""
    r, caught = _quiet_integrate("1.0f/pow(x[0], 0.75f)", dim=1, samples=10**8 if sampler == "nrooks" else 10**7,
                                 sampler=sampler, seed=3)
    assert caught, r.notes
    note = [n for n in r.notes if "variance looks infinite" in n]
    assert note and "power" in note[0]


@pytest.mark.parametrize("integrand", ["exp(-x[0]*x[1])*cos(x[2])", "1.0f/pow(x[0], 0.3f)"])
def test_finite_variance_is_not_reported(integrand: str):
    """A smooth integrand and x^-0.3 (finite fourth moment of the squares' blocks) raise no warning."""
    r, caught = _quiet_integrate(integrand, dim=3, samples=10**7, seed=3)
    assert not caught, r.notes
    assert math.isfinite(r.stderr)
