"""sampler="sobol", scrambling="linear": random linear matrix scrambling with a digital shift.

The points (kernels/samplers/sobol_block.cl) are read through integration:
the indicator of an elementary box of volume 2^-m holds exactly one point of
every 2^m-point replicate when the replicate is a (0, m, 2)-net (dimensions
0-1) or stratified in one dimension (every coordinate), so the estimate is
exactly 2^-m and the stderr 0 (up to the rounding of the shifted sums).  Then the estimator's bias, the
calibration of its stderr, its convergence rate and determinism, as for the
default scrambling (test_integrate_sobol.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_integrate_sobol import CALIBRATION, CASES, _exp_xyz, _gauss2

import mcocl
from mcocl.errors import InputError

LINEAR = {"sampler": "sobol", "scrambling": "linear"}


def _box(lo: list[float], hi: list[float], axes: list[int]) -> str:
    terms = [f"x[{a}] >= {lo_!r}f && x[{a}] < {hi_!r}f" for a, lo_, hi_ in zip(axes, lo, hi, strict=True)]
    return f"({' && '.join(terms)}) ? 1.0f : 0.0f"


@pytest.mark.parametrize("precision", ["single", "double"])
def test_every_replicate_is_a_0_m_2_net_in_the_first_two_dimensions(precision: str) -> None:
    m = 10
    for a in range(m + 1):
        w0, w1 = 2.0**-a, 2.0 ** -(m - a)
        c0, c1 = (3 * 2**a) // 7, (5 * 2 ** (m - a)) // 9  # some box away from the corners
        f = _box([c0 * w0, c1 * w1], [(c0 + 1) * w0, (c1 + 1) * w1], [0, 1])
        r = mcocl.integrate(f, dim=2, samples=4 << m, replicates=4, seed=11 + a, precision=precision, **LINEAR)
        assert (r.designs, r.samples) == (4, 4 << m)
        # every replicate mean is 2^-m; the stderr is their spread after the shifted sums' rounding
        assert r.estimate == 2.0**-m and r.stderr < 1e-6 * 2.0**-m, f"elementary boxes 2^-{a} x 2^-{m - a}"


@pytest.mark.parametrize("axis", [2, 37, 63])
def test_every_coordinate_is_stratified(axis: int) -> None:
    m = 12
    f = _box([1234 * 2.0**-m], [1235 * 2.0**-m], [axis])
    r = mcocl.integrate(f, dim=64, samples=3 << m, replicates=3, seed=axis, **LINEAR)
    assert r.estimate == 2.0**-m and r.stderr < 1e-6 * 2.0**-m


def test_scramblings_differ_between_replicates_and_from_the_hash() -> None:
    f = "x[0]*x[1] + 0.5f*x[2]*x[2] - x[1]"
    kw = dict(dim=3, samples=1 << 14, seed=5, replicates=4, precision="double")
    lin = mcocl.integrate(f, **kw, **LINEAR)
    hashed = mcocl.integrate(f, sampler="sobol", **kw)
    other_seed = mcocl.integrate(f, **{**kw, "seed": 6}, **LINEAR)
    assert len({lin.estimate, hashed.estimate, other_seed.estimate}) == 3
    assert lin.stderr > 0.0


@pytest.mark.parametrize("case", sorted(CASES))
def test_estimates_agree_with_closed_forms_within_the_reported_stderr(case: str) -> None:
    f, dim, kw, exact = CASES[case]
    exact = _exp_xyz() if exact is None else exact
    r = mcocl.integrate(f, dim=dim, samples=1 << 18, seed=31, **kw, **LINEAR)
    assert r.samples == 1 << 18 and r.designs == 16
    assert abs(r.estimate - exact) <= 4.5 * r.stderr, (r.estimate - exact, r.stderr)
    assert "linearly scrambled" in r.notes[-1]
    ind = mcocl.integrate(f, dim=dim, samples=1 << 18, seed=31, **kw)
    assert r.stderr < 0.3 * ind.stderr


@pytest.mark.parametrize("dim", sorted(CALIBRATION))
def test_reported_stderr_matches_the_spread_over_seeds(dim: int) -> None:
    f, exact, n = CALIBRATION[dim]
    exact = _gauss2() if exact is None else exact
    err, se = [], []
    # 320 seeds: the ratio below has a spread of about 1/sqrt(2 * 320) = 4 % (the 1-D jump's
    # per-replicate error takes two values, whose mean over 16 replicates is far from normal)
    for seed in range(320):
        r = mcocl.integrate(f, dim=dim, samples=n, seed=1000 + seed, **LINEAR)
        err.append(r.estimate - exact)
        se.append(r.stderr)
    spread = math.sqrt(np.mean(np.square(err)))
    reported = math.sqrt(np.mean(np.square(se)))
    assert 0.75 <= spread / reported <= 1.25, (spread, reported)


# The rate test runs for both scramblings in test_integrate_sobol.py.


def test_lanes_launch_splits_and_resume_give_the_same_result(tmp_path) -> None:
    f = "x[0]*x[1] + 0.5f*x[2]*x[2] - x[1]"
    kw = dict(dim=3, seed=5, samples=1 << 20, replicates=8, **LINEAR)
    base = mcocl.integrate(f, **kw)
    assert mcocl.integrate(f, lanes=1, **kw).estimate == base.estimate
    small = {**kw, "samples": 64, "replicates": 16}  # replicates of 4 points: a packet spans four
    assert mcocl.integrate(f, lanes=1, **small).estimate == mcocl.integrate(f, **small).estimate
    split = mcocl.integrate(f, split=2, **kw)
    assert (split.estimate, split.stderr) == (base.estimate, base.stderr)
    ckpt = tmp_path / "sobol.npz"
    kw = dict(dim=3, seed=5, design_samples=1 << 17, **LINEAR)
    full = mcocl.integrate(f, samples=1 << 20, **kw)
    mcocl.integrate(f, samples=1 << 19, checkpoint=str(ckpt), **kw)
    # the checkpoint's design keeps the scrambling, even when the resuming call does not name it
    resumed = mcocl.integrate(f, samples=1 << 20, resume=str(ckpt), dim=3, seed=5, design_samples=1 << 17,
                              sampler="sobol")
    assert (resumed.estimate, resumed.stderr, resumed.samples) == (full.estimate, full.stderr, full.samples)
    assert full.estimate == base.estimate


def test_bad_scrambling_is_refused() -> None:
    with pytest.raises(InputError, match="scrambling: unknown scrambling 'owen'"):
        mcocl.integrate("x[0]", samples=1000, sampler="sobol", scrambling="owen")
    with pytest.raises(InputError, match="belongs to sampler='sobol'"):
        mcocl.integrate("x[0]", samples=1000, sampler="nrooks", scrambling="linear")
