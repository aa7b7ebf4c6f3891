"""sampler="sobol": Owen-scrambled Sobol' points, randomised quasi-Monte Carlo.

The points (kernels/samplers/sobol_sampler.cl) are checked against a NumPy
twin and SciPy's unscrambled Sobol' sequence, for the net property and for
2-D uniformity; the estimator for bias, the calibration of its stderr (the
spread of R independent scramblings), its convergence rate and determinism.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from chi2 import Chi2Family

import mcocl
from mcocl import rng, runtime
from mcocl.errors import InputError

TABLE = Path(mcocl.__file__).resolve().parent.parent / "kernels" / "samplers" / "sobol_joe_kuo_1024.cl"
LOG2_POINTS = 16  # points per scrambling in the point-reading builds below
# Burley 2020 (JCGT 9(4), sec. 3): the Laine-Karras permutation's constants.
LK = (0x6C50B47C, 0xB82F1E52, 0xC7AFE638, 0x8D22F6E6)


def _device_points(dim: int, first: int, n: int, seed: int, log2_points: int = LOG2_POINTS, how: int = 0) -> np.ndarray:
    """Coordinates 0..dim-1 of samples first..first+n-1, read through kernels/samplers/sampler_points.cl
    (``how``: 0 one sampler_next_nd, 1 sampler_next_1d each, 2 sampler_next_2d pairs)."""
    ctx = runtime.device_context()
    table = -(-dim // 64) * 64
    src = runtime.compose(["samplers/sampler_points.cl"])
    prg = runtime.build(ctx, src, ["-DLANES=1", f"-DDIM={dim}", "-DSAMPLER_BACKEND=SAMPLER_BACKEND_SOBOL",
                                   f"-DSOBOL_LOG2_POINTS={log2_points}", f"-DSOBOL_TABLE_DIMS={table}"],
                        what="sobol points")
    import pyopencl as cl

    out = np.empty((n, dim), np.float32)
    buf = cl.Buffer(ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    runtime.kernel(prg, "sampler_points")(ctx.queue, (n,), None, np.uint64(first), np.uint32(n), np.uint64(seed),
                                          np.uint32(how), buf)
    cl.enqueue_copy(ctx.queue, out, buf)
    return out


def _table() -> np.ndarray:
    """SOBOL_RV of the shipped table, shape (1024, 32): bit-reversed direction numbers."""
    text = TABLE.read_text()
    body = text[text.index("SOBOL_RV[SOBOL_TABLE_DIMS * 32] = {"):]
    words = [int(w, 16) for w in re.findall(r"0x([0-9a-f]{8})", body)]
    return np.array(words, dtype=np.uint32).reshape(1024, 32)


def _reverse(x: np.ndarray) -> np.ndarray:
    b = np.unpackbits(x.astype(">u4").view(np.uint8)).reshape(-1, 32)[:, ::-1]
    return np.packbits(b, axis=1).view(">u4").astype(np.uint32).reshape(x.shape)


def _twin_points(dim: int, first: int, n: int, seed: int, log2_points: int = LOG2_POINTS) -> np.ndarray:
    """A NumPy twin of the back end: direct Sobol', Laine-Karras hash, cell centres."""
    idx = np.arange(first, first + n, dtype=np.uint64)
    point = (idx & np.uint64((1 << log2_points) - 1)).astype(np.uint32)
    rep = idx >> np.uint64(log2_points)
    rv = _table()[:dim]
    x = np.zeros((n, dim), np.uint32)
    for k in range(log2_points):
        x ^= np.where(((point >> np.uint32(k)) & 1)[:, None] == 1, rv[None, :, k], np.uint32(0))
    # per-dimension seeds: Philox words of (replicate, dimension / 4) with the run's seed as key
    reps, inv = np.unique(rep, return_inverse=True)
    ctr = np.array([[int(r) & 0xFFFFFFFF, int(r) >> 32, b, 0] for r in reps for b in range(-(-dim // 4))], np.uint32)
    words = rng.philox4x32_10(ctr, np.array([seed & 0xFFFFFFFF, seed >> 32], np.uint32))
    seeds = words.reshape(len(reps), -1)[:, :dim][inv]
    with np.errstate(over="ignore"):
        y = x + seeds
        for c in LK:
            y ^= y * np.uint32(c)
    bits = _reverse(y)
    return (((bits >> np.uint32(9)).astype(np.float64) + 0.5) * 2.0**-23).astype(np.float32)


def test_the_table_is_scipys_joe_kuo_sequence() -> None:
    from scipy.stats import qmc

    v = _reverse(_table())
    n = 1024
    gray = np.arange(n, dtype=np.uint64)
    gray ^= gray >> np.uint64(1)  # SciPy generates in Gray-code order
    mine = np.zeros((n, 1024), np.uint64)
    for k in range(10):
        mine ^= ((gray >> np.uint64(k)) & np.uint64(1))[:, None] * v[None, :, k].astype(np.uint64)
    ref = qmc.Sobol(1024, scramble=False, bits=32).random(n) * 2.0**32
    assert np.array_equal(mine, ref.astype(np.uint64))


@pytest.mark.parametrize(("first", "seed"), [(0, 1), ((5 << LOG2_POINTS) + 12345, 2**40 + 7)])
def test_device_points_equal_the_numpy_twin(first: int, seed: int) -> None:
    dim = 70  # past one 64-dimension chunk of the table
    twin = _twin_points(dim, first, 2048, seed)
    for how in (0, 1, 2):  # next_nd, next_1d, next_2d
        assert np.array_equal(_device_points(dim, first, 2048, seed, how=how), twin), how


@pytest.mark.parametrize("m", [4, 10, 14])
@pytest.mark.parametrize("replicate", [0, 3])
def test_first_points_of_a_scrambling_are_a_0_m_2_net(m: int, replicate: int) -> None:
    x = _device_points(2, replicate << LOG2_POINTS, 1 << m, seed=17).astype(np.float64)
    assert np.all((x > 0) & (x < 1))
    for a in range(m + 1):
        b = m - a
        box = np.floor(x[:, 0] * 2**a).astype(np.int64) * 2**b + np.floor(x[:, 1] * 2**b).astype(np.int64)
        assert np.array_equal(np.sort(box), np.arange(1 << m)), f"elementary boxes 2^-{a} x 2^-{b}"


def test_scramblings_differ_between_replicates_seeds_and_dimensions() -> None:
    a = _device_points(4, 0, 256, seed=1)
    b = _device_points(4, 1 << LOG2_POINTS, 256, seed=1)
    c = _device_points(4, 0, 256, seed=2)
    for other in (b, c):
        assert np.mean(a == other) < 0.01
    assert np.mean(a[:, 2] == a[:, 3]) < 0.01


DIMS_CHI2 = 64
PAIRS = [(i, j) for i in range(DIMS_CHI2) for j in range(i + 1, DIMS_CHI2)]
CHI2 = Chi2Family("2-D projections of Owen-scrambled Sobol' points", len(PAIRS))


def test_two_dimensional_projections_of_the_first_64_dimensions_are_uniform() -> None:
    # Owen scrambling makes every point uniform on the cube, but the points of
    # one scrambling are not independent (a net's counts vary less than
    # Poisson, a pair of dimensions with a large t-value more), so Pearson's
    # statistic is chi-square only for independent points: take one point from
    # each of 4096 independent scramblings (replicates of 16 points, point
    # r mod 16 of replicate r).  10 x 10 cells: not dyadic.
    reps, log2 = 4096, 4
    x = _device_points(DIMS_CHI2, 0, reps << log2, seed=23, log2_points=log2)
    x = x[np.arange(reps) * (1 << log2) + np.arange(reps) % (1 << log2)]
    cells = np.minimum(np.floor(x.astype(np.float64) * 10).astype(np.int64), 9)
    expected = np.full(100, reps / 100.0)
    for i, j in PAIRS:
        observed = np.bincount(cells[:, i] * 10 + cells[:, j], minlength=100)
        CHI2.check(f"dims {i},{j}", observed, expected)


# Closed forms: exp(-(x0+x1+x2)) cos(x3) over [0,1]^4, etc.
E1 = 1.0 - math.exp(-1.0)
CASES = {
    "smooth 4-D": ("exp(-(x[0]+x[1]+x[2]))*cos(x[3])", 4, {}, E1**3 * math.sin(1.0)),
    "disk 2-D": ("(x[0]*x[0] + x[1]*x[1] < 1.0f) ? 1.0f : 0.0f", 2, {}, math.pi / 4),
    "importance 1-D": ("exp(-3.0f*x[0])", 1, {"proposal": "exponential:rate=2"}, (1 - math.exp(-3.0)) / 3),
    "control 3-D": ("exp(x[0]*x[1]*x[2])", 3, {"control": "1.0f + x[0]*x[1]*x[2]", "control_integral": 1.125},
                    None),
}


def _exp_xyz() -> float:
    # integral of exp(x y z) over the unit cube = sum_k 1 / (k! (k+1)^3)
    return sum(1.0 / (math.factorial(k) * (k + 1) ** 3) for k in range(30))


@pytest.mark.parametrize("case", sorted(CASES))
def test_estimates_agree_with_closed_forms_within_the_reported_stderr(case: str) -> None:
    f, dim, kw, exact = CASES[case]
    exact = _exp_xyz() if exact is None else exact
    r = mcocl.integrate(f, dim=dim, samples=1 << 18, sampler="sobol", seed=31, **kw)
    assert r.samples == 1 << 18 and r.designs == 16
    assert abs(r.estimate - exact) <= 4.5 * r.stderr, (r.estimate - exact, r.stderr)
    # and it is quasi-Monte Carlo: far below the independent sampler's error
    ind = mcocl.integrate(f, dim=dim, samples=1 << 18, seed=31, **kw)
    assert r.stderr < 0.3 * ind.stderr


CALIBRATION = {
    1: ("x[0] < 0.3f ? 1.0f : 0.0f", 1.0 - 0.7, 1 << 12),  # a jump
    2: ("exp(-20.0f*((x[0]-0.4f)*(x[0]-0.4f) + (x[1]-0.6f)*(x[1]-0.6f)))", None, 1 << 12),  # a peak
    5: ("exp(-(x[0]+x[1]+x[2]+x[3]+x[4]))", E1**5, 1 << 14),  # smooth
    10: ("exp(-0.5f*(" + "+".join(f"x[{i}]" for i in range(10)) + "))", (2 * (1 - math.exp(-0.5))) ** 10, 1 << 14),
}


def _gauss2() -> float:
    from scipy.special import erf

    s = math.sqrt(20.0)
    g = lambda c: math.sqrt(math.pi) / (2 * s) * (erf(s * (1 - c)) + erf(s * c))  # noqa: E731
    return g(0.4) * g(0.6)


@pytest.mark.parametrize("dim", sorted(CALIBRATION))
def test_reported_stderr_matches_the_spread_over_seeds(dim: int) -> None:
    f, exact, n = CALIBRATION[dim]
    exact = _gauss2() if exact is None else exact
    err, se = [], []
    for seed in range(80):  # the ratio below has a spread of about 1/sqrt(2 * 80) = 8 %
        r = mcocl.integrate(f, dim=dim, samples=n, sampler="sobol", seed=1000 + seed)
        err.append(r.estimate - exact)
        se.append(r.stderr)
    spread = math.sqrt(np.mean(np.square(err)))
    reported = math.sqrt(np.mean(np.square(se)))
    assert 0.75 <= spread / reported <= 1.25, (spread, reported)


@pytest.mark.parametrize("scrambling", [None, "linear"])  # the default (hashed Owen) and the linear one
def test_rmse_falls_at_least_like_n_to_the_minus_1_3_on_a_smooth_integrand(scrambling: str | None) -> None:
    # a polynomial (float products, no built-ins): its float rounding stays
    # far below the quasi-Monte Carlo error up to 2^20 samples
    f = "x[0]*x[0]*x[1] + x[0]*x[1]*x[1]*x[1] + 0.5f*x[1]"
    exact = 1.0 / 6 + 1.0 / 8 + 0.25
    ns = [1 << k for k in range(10, 21, 2)]
    rmse = []
    for n in ns:
        e = [mcocl.integrate(f, dim=2, samples=n, sampler="sobol", scrambling=scrambling, seed=s).estimate - exact
             for s in range(8)]
        rmse.append(math.sqrt(np.mean(np.square(e))))
    slope = np.polyfit(np.log(ns), np.log(rmse), 1)[0]
    assert slope <= -1.3, (slope, rmse)


def test_lanes_launch_splits_and_resume_give_the_same_result(tmp_path) -> None:
    f = "x[0]*x[1] + 0.5f*x[2]*x[2] - x[1]"
    kw = dict(dim=3, sampler="sobol", seed=5, samples=1 << 20, replicates=8)
    base = mcocl.integrate(f, **kw)
    assert mcocl.integrate(f, lanes=1, **kw).estimate == base.estimate
    # replicates of 4 points: a 16-lane packet spans four scramblings
    small = {**kw, "samples": 64, "replicates": 16}
    assert mcocl.integrate(f, lanes=1, **small).estimate == mcocl.integrate(f, **small).estimate
    split = mcocl.integrate(f, split=2, **kw)
    assert (split.estimate, split.stderr) == (base.estimate, base.stderr)
    # resume: replicates of a fixed size (design_samples), the budget given in two steps
    ckpt = tmp_path / "sobol.npz"
    kw = dict(dim=3, sampler="sobol", seed=5, design_samples=1 << 17)
    full = mcocl.integrate(f, samples=1 << 20, **kw)
    half = mcocl.integrate(f, samples=1 << 19, checkpoint=str(ckpt), **kw)
    assert (full.designs, half.designs) == (8, 4)
    resumed = mcocl.integrate(f, samples=1 << 20, resume=str(ckpt), **kw)
    assert (resumed.estimate, resumed.stderr, resumed.samples) == (full.estimate, full.stderr, full.samples)
    assert full.estimate == base.estimate  # 8 replicates of 2^17 either way


def test_rounding_and_replicates() -> None:
    r = mcocl.integrate("x[0]", samples=1_000_000, sampler="sobol", replicates=10)
    assert (r.designs, r.samples) == (10, 10 * 65536)  # 2^16 = the largest power of two <= 10^6 / 10
    assert "rounded down to replicates x 2^16" in r.notes[-1]
    timed = mcocl.integrate("x[0]", samples=None, time_budget=0.3, sampler="sobol", seed=3)
    assert timed.stopped_by == "time" and timed.designs >= 2 and abs(timed.estimate - 0.5) <= 4.5 * timed.stderr
    with pytest.raises(InputError, match="replicates"):
        mcocl.integrate("x[0]", samples=1000, sampler="nrooks", replicates=4)
    with pytest.raises(InputError, match="replicates"):
        mcocl.integrate("x[0]", samples=1000, sampler="sobol", replicates=1)
    with pytest.raises(InputError, match="1024 coordinates"):
        mcocl.integrate("x[0]", dim=64, samples=1000, sampler="sobol",
                        proposals=["uniform", "uniform"], shares=[9, 8])


def test_plan_rounds_the_budget_to_replicates_times_a_power_of_two() -> None:
    from mcocl.integration.samplers import SAMPLER_SPECS

    sob = SAMPLER_SPECS["sobol"]
    d = sob.plan(2, 1, 1000, None)  # 1000 / 16 = 62.5 -> 2^5
    assert (d.units, d.replicates) == (32, 16) and sob.granules(d, 1000) == (16, 32)
    d = sob.plan_replicated(1, 3, 10**6, None, 4)  # 10^6 / (4 x 3) -> 2^16 units of 3 points
    assert (d.units, d.samples_per_unit) == (65536, 3) and sob.samples_used(d, 4, d.units) == 4 * 65536 * 3
    d = sob.plan(1, 1, 10, None)  # fewer samples than replicates: 16 single points
    assert d.units == 1 and sob.granules(d, 10) == (16, 1)
    d = sob.plan(1, 1, 1 << 40, None)  # 2^36 per replicate is past the cap: 2^30, more replicates
    assert d.units == 1 << 30 and sob.granules(d, 1 << 40) == (1024, 1 << 30)
    d = sob.plan(1, 1, 10**5, 1000)  # design_samples: 2^9 per replicate, the budget in whole replicates
    assert d.units == 512 and sob.granules(d, 10**5) == (195, 512)
    assert sob.granules(sob.plan(1, 1, None, None), None) == (None, 1 << 18)
