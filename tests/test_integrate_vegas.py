"""sampler="vegas": unbiased within its reported error, near-zero variance on separable peaks,
calibrated stderr, deterministic across lanes and resume, and a grid that stays a valid density."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

import mcocl
from mcocl import runtime
from mcocl.accumulate import Accumulator
from mcocl.errors import InputError
from mcocl.integration.codegen import generate
from mcocl.integration.job import ROW
from mcocl.integration.samplers import plan
from mcocl.integration.vegas import Iteration, VegasJob, VegasSettings, _outcome, chi2_q, combine
from mcocl.integration.vegas_grid import VegasGrid
from mcocl.usercode import UserFunction

Z = 4.5


def _lorentz(a: float, c: float = 0.3) -> tuple[str, float]:
    """1/(a + (x-c)^2) on [0, 1] and its exact integral."""
    s = math.sqrt(a)
    return (f"1.0f/({a}f + (x[0]-{c}f)*(x[0]-{c}f))", (math.atan((1 - c) / s) + math.atan(c / s)) / s)


def _gauss_peaks(dim: int, width: float, centre: float = 0.4) -> tuple[str, float]:
    """prod_i exp(-(x_i - centre)^2 / (2 width^2)) and its exact integral (error functions)."""
    f = "*".join(f"exp(-(x[{i}]-{centre}f)*(x[{i}]-{centre}f)*{1 / (2 * width * width)}f)" for i in range(dim))
    r = width * math.sqrt(2.0)
    one = math.sqrt(math.pi / 2) * width * (math.erf((1 - centre) / r) + math.erf(centre / r))
    return f, one**dim


CASES = {
    "lorentz-1d": (*_lorentz(1e-3), 1),
    "gauss-peaks-3d": (*_gauss_peaks(3, 0.05), 3),
    "gauss-peaks-5d": (*_gauss_peaks(5, 0.1), 5),
    "exp-sum-4d": ("exp(-(x[0]+x[1]+x[2]+x[3]))", (1 - math.exp(-1)) ** 4, 4),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_vegas_is_unbiased_within_its_reported_error(case: str) -> None:
    f, exact, dim = CASES[case]
    r = mcocl.integrate(f, dim=dim, samples=1 << 21, sampler="vegas", seed=11)
    assert r.stderr > 0
    assert abs(r.estimate - exact) <= Z * r.stderr, (case, r.estimate, exact, r.stderr)
    assert r.vegas is not None and len(r.vegas["iterations"]) == 10 and r.vegas["bins"] == 256


def test_vegas_approaches_zero_variance_on_a_separable_product_of_peaks() -> None:
    f, exact = _gauss_peaks(4, 0.05)
    v = mcocl.integrate(f, dim=4, samples=1 << 21, sampler="vegas", seed=5)
    plain = mcocl.integrate(f, dim=4, samples=v.samples, seed=5)
    assert abs(v.estimate - exact) <= Z * v.stderr
    assert v.stderr * 20 < plain.stderr, (v.stderr, plain.stderr)


CALIBRATION = {
    "lorentz-1d": (*_lorentz(1e-2), 1),
    "lorentz-2d": (_lorentz(1e-2)[0].replace("x[0]", "x[1]"), _lorentz(1e-2)[1], 2),
    "gauss-peaks-10d": (*_gauss_peaks(10, 0.2), 10),
    "gauss-peaks-5d": (*_gauss_peaks(5, 0.1), 5),
    "jump-2d": ("x[0] + x[1] < 0.7f ? 2.0f : 0.0f", 0.7 * 0.7, 2),
}


@pytest.mark.parametrize("case", sorted(CALIBRATION))
def test_vegas_stderr_is_calibrated_over_seeds(case: str) -> None:
    # the rms of (estimate - exact) / stderr over 40 seeds is 1 for an honest stderr (+-11% at 40 seeds)
    f, exact, dim = CALIBRATION[case]
    z = []
    for seed in range(40):
        r = mcocl.integrate(f, dim=dim, samples=1 << 16, sampler="vegas", seed=100 + seed,
                            vegas_iterations=5, vegas_bins=64)
        z.append((r.estimate - exact) / r.stderr)
    rms = math.sqrt(float(np.mean(np.square(z))))
    assert 0.75 <= rms <= 1.25, (rms, z)


# A peaked polynomial: no transcendental built-ins, so the scalar and vector
# builds compute bit-identical values and only the summation order could differ.
PEAKED_POLY = "x[0]*x[0]*x[0]*x[0]*x[0]*x[0]*x[0]*x[0]*x[1]*x[1]*x[1]*x[1] + x[2]*x[2]*x[2]"


def test_vegas_results_do_not_depend_on_the_lane_width_nor_sub_devices() -> None:
    runs = [mcocl.integrate(PEAKED_POLY, dim=3, samples=1 << 18, sampler="vegas", seed=7, lanes=lanes)
            for lanes in (1, 4, None)]
    assert len({(r.estimate, r.stderr) for r in runs}) == 1
    assert runs[0].vegas["iterations"] == runs[2].vegas["iterations"]
    split = mcocl.integrate(PEAKED_POLY, dim=3, samples=1 << 18, sampler="vegas", seed=7, split=2)
    assert (split.estimate, split.stderr) == (runs[2].estimate, runs[2].stderr)


def test_vegas_block_rows_do_not_depend_on_the_launch_split() -> None:
    f = UserFunction("integrand", PEAKED_POLY, "integrand", (("x", 3),))
    code = generate(f, 3, [], [1], "balance", 2.0, None, None)
    design = replace(plan("vegas", 3, 1, None, None), bins=32)
    grid = VegasGrid.uniform(3, 32).refine(np.arange(1, 97, dtype=float).reshape(3, 32), 1.0)
    job = VegasJob(code, 3, design, 5, 1 << 62, stat_shape=(ROW + 96,), grid_table=grid.device_table(),
                   block_offset=3, shift=0.25)
    runner = job.runner(runtime.device_context())

    def fold(splits: list[int]) -> np.ndarray:
        acc, first = Accumulator(job.stat_shape), 0
        for n in splits:
            acc.add(first, runner.collect(runner.enqueue(first, n)))
            first += n
        return acc.totals

    whole = fold([6])
    assert np.array_equal(whole, fold([1, 2, 3]))
    # every dimension's training row adds up to the sum of v^2 = (v - shift)^2 + 2 shift (v - shift) + shift^2
    sum_v2 = whole[3] + 2 * 0.25 * whole[2] + 0.0625 * whole[0]
    assert whole[ROW:].reshape(3, 32).sum(axis=1) == pytest.approx([sum_v2] * 3, rel=1e-5)


def test_vegas_resume_continues_the_same_adaptation(tmp_path) -> None:
    f, _ = _gauss_peaks(2, 0.05)
    kw = dict(dim=2, samples=1 << 25, sampler="vegas", seed=9, vegas_iterations=6)
    full = mcocl.integrate(f, **kw)
    ckpt = tmp_path / "vegas.ckpt"
    cut = mcocl.integrate(f, time_budget=0.02, checkpoint=str(ckpt), **kw)
    assert cut.stopped_by == "time" and cut.samples < full.samples
    resumed = mcocl.integrate(f, resume=str(ckpt), **kw)
    assert (resumed.estimate, resumed.stderr, resumed.samples) == (full.estimate, full.stderr, full.samples)
    assert resumed.vegas["iterations"] == full.vegas["iterations"]
    # a finished run's checkpoint resumes to the same result without sampling again
    done = tmp_path / "done.ckpt"
    mcocl.integrate(f, checkpoint=str(done), **kw)
    again = mcocl.integrate(f, resume=str(done), **kw)
    assert (again.estimate, again.stderr) == (full.estimate, full.stderr)
    with pytest.raises(InputError):
        mcocl.integrate(f, resume=str(done), **{**kw, "vegas_iterations": 7})


@pytest.mark.parametrize("train", ["zeros", "spike", "range", "random"])
def test_refined_grids_stay_valid_densities(train: str) -> None:
    rng = np.random.default_rng(1)
    grid = VegasGrid.uniform(3, 64)
    for _ in range(30):  # repeated refinement compounds any defect
        m = {"zeros": np.zeros((3, 64)), "spike": np.eye(3, 64) * 1e30,
             "range": 10.0 ** rng.uniform(-30, 30, (3, 64)), "random": rng.exponential(size=(3, 64))}[train]
        grid = grid.refine(m, 1.5)
        e32 = grid.edges.astype(np.float32)
        assert np.all(e32[:, 0] == 0) and np.all(e32[:, -1] == 1)
        w = grid.widths()
        assert np.all(w > 0)
        assert np.allclose(w.sum(axis=1), 1.0, atol=1e-6)
        # the device table tiles [0, 1]: every bin ends where the next begins
        t = grid.device_table().reshape(2, 3, 64)
        assert np.all(np.abs(t[0, :, 1:] - (t[0, :, :-1] + t[1, :, :-1])) <= 2 * np.spacing(np.float32(1)))
        # probability 1/bins per bin, density 1/(bins w): the density integrates to 1
        assert np.allclose((w * (1.0 / (64 * w))).sum(axis=1), 1.0)
    assert VegasGrid.from_list(grid.to_list()).edges.tolist() == grid.edges.tolist()


def test_refinement_moves_bins_onto_the_training_weight() -> None:
    m = np.ones((1, 32))
    m[0, 8] = 1e6  # all the weight in [8/32, 9/32)
    new = VegasGrid.uniform(1, 32).refine(m, 1.5)
    inside = np.sum((new.edges[0, :-1] >= 7 / 32) & (new.edges[0, :-1] < 10 / 32))
    assert inside > 8  # more than the 3 bins of the uniform grid


def test_combination_and_its_chi2() -> None:
    its = [Iteration(1.0, 0.01, 100, 0, 0.0, False), Iteration(1.2, 0.04, 100, 0, 0.0, False)]
    est, var, chi2, dof = combine(its)
    assert est == pytest.approx((1.0 / 0.01 + 1.2 / 0.04) / (1 / 0.01 + 1 / 0.04))
    assert var == pytest.approx(1 / (1 / 0.01 + 1 / 0.04))
    assert chi2 == pytest.approx((1.0 - est) ** 2 / 0.01 + (1.2 - est) ** 2 / 0.04) and dof == 1
    stats = pytest.importorskip("scipy.stats")
    for k in (1, 3, 9, 30):
        for x in (0.5 * k, k, 2.0 * k, 4.0 * k):
            assert abs(chi2_q(x, k) - stats.chi2.sf(x, k)) < 0.02


def test_disagreeing_iterations_get_a_warning_note() -> None:
    its = [Iteration(1.0 + 0.5 * k, 1e-4, 100, 0, 0.0, False) for k in range(5)]
    grid = VegasGrid.uniform(1, 4)

    class _Runner:
        lanes, build_seconds = 1, 0.0
        program = type("P", (), {"note": ""})()

    out = _outcome(its, VegasSettings(5, 4, 1.0), grid, 1.0, "samples", ["cpu"], _Runner(), [])
    assert any(n.startswith("WARNING: the VEGAS iterations disagree") for n in out.notes)
    agree = _outcome([Iteration(1.0, 1e-4, 100, 0, 0.0, False)] * 5, VegasSettings(5, 4, 1.0), grid, 1.0,
                     "samples", ["cpu"], _Runner(), [])
    assert not any(n.startswith("WARNING") for n in agree.notes)


@pytest.mark.parametrize("kw, words", [
    ({"vegas_bins": 100}, "vegas_bins"),
    ({"vegas_iterations": 0}, "vegas_iterations"),
    ({"alpha": -1}, "alpha"),
    ({"samples": None, "target_error": 1e-3}, "samples= or time_budget="),
    ({"proposals": [{"type": "uniform"}, {"type": "uniform"}]}, "combine proposals"),
])
def test_vegas_input_errors_name_the_option(kw: dict, words: str) -> None:
    with pytest.raises(InputError, match=words):
        mcocl.integrate("x[0]", dim=1, **{"samples": 1 << 14, "sampler": "vegas", **kw})


def test_vegas_options_need_the_vegas_sampler() -> None:
    with pytest.raises(InputError, match="only to sampler='vegas'"):
        mcocl.integrate("x[0]", dim=1, samples=1 << 14, alpha=1.0)


def test_cli_json_reports_the_iterations() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "mcocl", "integrate", "exp(-x[0]-x[1])", "--dim", "2", "--sampler", "vegas",
         "--samples", "1e6", "--iterations", "4", "--vegas-bins", "64", "--json"],
        capture_output=True, text=True, check=True,
    )
    d = json.loads(out.stdout)
    assert d["sampler"] == "vegas" and len(d["vegas"]["iterations"]) == 4 and d["vegas"]["bins"] == 64
    assert d["vegas"]["chi2_dof"] is not None
    assert abs(d["estimate"] - (1 - math.exp(-1)) ** 2) <= Z * d["stderr"]


def test_vegas_splits_a_time_budget_over_its_iterations() -> None:
    f, exact = _gauss_peaks(3, 0.05)
    r = mcocl.integrate(f, dim=3, samples=None, time_budget=0.5, sampler="vegas", seed=2, vegas_iterations=5)
    assert r.stopped_by == "time" and len(r.vegas["iterations"]) >= 2
    assert abs(r.estimate - exact) <= Z * r.stderr
