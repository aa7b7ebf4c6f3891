"""``mcocl bench``: output files, the lecture's orderings measured by the bench, bad problem files.

The quick bench runs once per session (a few seconds); the ordering tests
assert on the numbers it wrote into its own JSON summary, with margins wide
enough for a busy machine: the variance ratios behind them are about 600x
(stratified, smooth 4-D), 10^5x (N-rooks, additive 6-D) and 10x (balance and
power against either single proposal, two peaks), while throughput noise on
a shared machine is at most a few x.
"""

from __future__ import annotations

import csv
import importlib.util
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import special

from mcocl.bench import genz
from mcocl.bench.integrate_suite import _lower_gamma, builtin_problems
from mcocl.bench.numpy_baseline import TranslationError, compile_numpy, translate_opencl
from mcocl.bench.problems import load_problem_file
from mcocl.bench.report import CSV_COLUMNS, SUMMARY_FIELDS
from mcocl.bench.runner import checkpoint_times
from mcocl.cli import main
from mcocl.errors import InputError, KernelBuildError

HAS_MATPLOTLIB = importlib.util.find_spec("matplotlib") is not None
needs_matplotlib = pytest.mark.skipif(not HAS_MATPLOTLIB, reason="matplotlib is not installed (pip install matplotlib)")


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    """Run ``mcocl bench --quick`` once; return (output folder, exit status, summary)."""
    out = tmp_path_factory.mktemp("bench-quick")
    status = main(["bench", "--quick", "--out", str(out)] + ([] if HAS_MATPLOTLIB else ["--no-plot"]))
    summary = json.loads((out / "integrate-summary.json").read_text())
    return out, status, summary


@pytest.fixture(scope="module")
def quick_solve(quick):
    """The solve suite's summary from the same quick run."""
    return json.loads((quick[0] / "solve-summary.json").read_text())


def _est(summary: dict, problem: str, name: str) -> dict:
    prob = next(p for p in summary["problems"] if p["name"] == problem)
    return next(e for e in prob["estimators"] if e["name"] == name)


# -- files ---------------------------------------------------------------------


@needs_matplotlib
def test_quick_draws_png(quick):
    out, status, _ = quick
    assert status == 0
    for png in ("integrate-error-vs-time.png", "integrate-efficiency.png", "solve-error-vs-time.png"):
        data = (out / png).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000, png


def test_quick_writes_csv_json(quick):
    out, status, summary = quick
    assert status == 0
    for suite in ("integrate", "solve"):
        for kind in ("table.txt", "checkpoints.csv", "summary.json"):
            assert (out / f"{suite}-{kind}").stat().st_size > 0, (suite, kind)

    with open(out / "integrate-checkpoints.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert tuple(rows[0].keys()) == CSV_COLUMNS
    runs: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        runs.setdefault((r["problem"], r["estimator"]), []).append(r)
    expected = {(p["name"], e["name"]) for p in summary["problems"] for e in p["estimators"]}
    assert set(runs) == expected
    for key, rs in runs.items():
        assert len(rs) >= 2, key  # progressive: several checkpoints per run
        secs = [float(r["seconds"]) for r in rs]
        samples = [int(r["samples"]) for r in rs]
        assert secs == sorted(secs) and samples == sorted(samples) and samples[0] > 0, key
        for r in rs:
            assert math.isfinite(float(r["estimate"])) and float(r["stderr"]) >= 0, key

    assert {"suite", "budget_seconds", "machine", "problems"} <= set(summary)
    for p in summary["problems"]:
        assert {"name", "dim", "exact", "numpy_speedup", "estimators"} <= set(p)
        assert p["numpy_speedup"] > 0  # the NumPy baseline ran on every quick problem
        for e in p["estimators"]:
            assert set(SUMMARY_FIELDS) <= set(e)
            assert e["failed"] is None
    table = (out / "integrate-table.txt").read_text()
    for word in ("samples/s", "var/sample", "efficiency", "rel. eff.", "engine vs NumPy"):
        assert word in table


def test_quick_reports_honest_numbers(quick, quick_solve):
    """Every estimator's final error agrees with its reported stderr; efficiency = 1/(V * s/sample)."""
    _, _, summary = quick
    for p in summary["problems"] + quick_solve["problems"]:
        for e in p["estimators"]:
            assert e["consistent"] is True, (p["name"], e["name"], e["z"])
            v, sps = e["variance_per_sample"], e["samples_per_second"]
            assert e["efficiency"] == pytest.approx(sps / v, rel=1e-9)
            assert v == pytest.approx(e["stderr"] ** 2 * e["samples"] / e["points"], rel=1e-9)


# -- the lecture's orderings, as the bench measures them ---------------------------


def test_bench_stratified_beats_independent_on_smooth(quick):
    e = _est(quick[2], "smooth-gauss-4d", "stratified")
    assert e["relative_efficiency"] > 10


def test_bench_nrooks_far_better_on_additive(quick):
    e = _est(quick[2], "additive-6d", "nrooks")
    assert e["relative_efficiency"] > 1000


def test_bench_combined_beats_single_proposals_on_two_peaks(quick):
    s = quick[2]
    singles = [_est(s, "two-peak-2d", n)["efficiency"] for n in ("peak-a", "peak-b")]
    for h in ("balance", "power"):
        eff = _est(s, "two-peak-2d", h)["efficiency"]
        assert eff > 2 * max(singles), (h, eff, singles)


def test_bench_nee_beats_plain_walk_on_peaked_source(quick_solve):
    # variance per walk about 20x lower, at about half the walks per second
    assert _est(quick_solve, "peaked-source-1d", "nee")["relative_efficiency"] > 2


def test_bench_subcritical_beats_uniform_moves_on_peaked_kernel(quick_solve):
    # variance per walk about 200x lower, at about a quarter of the walks per second
    assert _est(quick_solve, "peaked-kernel-1d", "subcritical")["relative_efficiency"] > 5


# -- problem files ------------------------------------------------------------------


def _write(tmp_path, obj, name="problems.json"):
    p = tmp_path / name
    p.write_text(obj if isinstance(obj, str) else json.dumps(obj))
    return p


GOOD = {"name": "bump", "expression": "exp(-x[0]*x[0] - x[1]*x[1])", "dim": 2,
        "exact": (math.sqrt(math.pi) / 2 * math.erf(1.0)) ** 2}


def test_problem_file_runs_with_chosen_estimators(tmp_path):
    f = _write(tmp_path, {"problems": [GOOD]})
    out = tmp_path / "out"
    status = main(["bench", "integrate", "--problem", str(f), "--estimators", "independent", "stratified",
                   "--budget", "0.05", "--out", str(out), "--no-plot"])
    assert status == 0
    s = json.loads((out / "integrate-summary.json").read_text())
    (prob,) = s["problems"]
    assert prob["name"] == "bump"
    assert [e["name"] for e in prob["estimators"]] == ["independent", "stratified", "numpy"]
    # the NumPy twin was translated from the OpenCL C expression and integrates the same function
    assert _est(s, "bump", "numpy")["consistent"] is True


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ({"exact": None}, ["bump", "'exact'"]),
        ({"dim": "two"}, ["bump", "'dim'"]),
        ({"proposals": "nonsense"}, ["bump", "'proposals'"]),
        ({"colour": 3}, ["bump", "colour"]),
    ],
)
def test_problem_file_field_errors_name_problem_and_field(tmp_path, change, words):
    obj = {**GOOD, **change}
    f = _write(tmp_path, [obj])
    with pytest.raises(InputError) as ei:
        load_problem_file(f)
    for w in words:
        assert w in str(ei.value)


def test_problem_file_missing_field(tmp_path):
    obj = {k: v for k, v in GOOD.items() if k != "exact"}
    with pytest.raises(InputError, match=r"problem #1 \('bump'\): missing field 'exact'"):
        load_problem_file(_write(tmp_path, obj))


def test_problem_file_bad_json(tmp_path):
    with pytest.raises(InputError, match="not valid JSON.*line 1"):
        load_problem_file(_write(tmp_path, '{"problems": [ {"name": }'))


def test_problem_file_expression_that_does_not_compile_exits_nonzero(tmp_path, capsys):
    bad = {**GOOD, "name": "broken", "expression": "exp(-x[0]*) + 1"}
    f = _write(tmp_path, {"problems": [GOOD, bad]})
    status = main(["bench", "integrate", "--problem", str(f), "--budget", "0.05", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert status != 0
    assert "broken" in err and "'expression'" in err and "exp(-x[0]*) + 1" in err
    assert not (tmp_path / "o").exists()  # checked before anything ran


def test_problem_file_bad_proposal_names_its_index(tmp_path):
    from mcocl.bench.integrate_suite import SUITE
    from mcocl.bench.suite import BenchOptions

    bad = {**GOOD, "proposals": ["uniform", {"type": "analytic", "pdf": "2*x", "inverse": "sqrt(u"}]}
    f = _write(tmp_path, [bad])
    with pytest.raises(KernelBuildError, match=r"'bump'.*'proposals\[1\]'"):
        SUITE.problems(BenchOptions(problem_files=[str(f)]))


def test_unknown_estimator_is_an_error(tmp_path, capsys):
    f = _write(tmp_path, [GOOD])
    status = main(["bench", "integrate", "--problem", str(f), "--estimators", "indepndent", "--out", str(tmp_path)])
    assert status == 2
    assert "indepndent" in capsys.readouterr().err


# -- building blocks -----------------------------------------------------------------


def test_checkpoint_times_double_up_to_budget():
    t = checkpoint_times(5.0)
    assert t[-1] == 5.0 and t[0] < 0.02 and all(b == pytest.approx(2 * a) for a, b in zip(t, t[1:]))
    assert len(checkpoint_times(0.001)) >= 3


def _quad(f, d, points=(), nodes=16):
    """Composite Gauss-Legendre product rule on [0, 1]^d, pieces split at ``points`` on every axis.

    A generic quadrature (it knows only where the kinks and jumps may be), so
    it checks the closed forms independently; 16 nodes per smooth piece are
    exact to ~1e-12 for these integrands.
    """
    t, w = np.polynomial.legendre.leggauss(nodes)
    edges = np.unique(np.concatenate([[0.0, 1.0], np.asarray(points, dtype=float)]))
    xs = np.concatenate([(a + b) / 2 + (b - a) / 2 * t for a, b in zip(edges, edges[1:])])
    ws = np.concatenate([(b - a) / 2 * w for a, b in zip(edges, edges[1:])])
    grids = np.meshgrid(*([xs] * d), indexing="ij")
    weights = np.ones_like(grids[0])
    for g in np.meshgrid(*([ws] * d), indexing="ij"):
        weights = weights * g
    return float(np.sum(f(np.stack([g.ravel() for g in grids])) * weights.ravel()))


@pytest.mark.parametrize(
    ("g", "d"),
    [
        (genz.oscillatory([1.2, 0.8], [0.3, 0.0]), 2),
        (genz.product_peak([5.0, 3.0], [0.3, 0.6]), 2),
        (genz.corner_peak([1.0, 2.0, 0.5]), 3),
        (genz.gaussian([2.0, 3.0], [0.5, 0.2]), 2),
        (genz.continuous([2.0, 3.0], [0.4, 0.7]), 2),
        (genz.discontinuous([0.3, 0.7, 1.1], [0.6, 0.7, 0.5]), 3),
    ],
    ids=lambda v: getattr(v, "family", str(v)),
)
def test_genz_exact_integrals_against_quadrature(g, d):
    f = compile_numpy(g.numpy, d)
    points = [0.3, 0.4, 0.5, 0.6, 0.7]  # the kinks and jumps of the families above
    assert _quad(f, d, points) == pytest.approx(g.exact, rel=1e-7, abs=1e-10)


def test_genz_singular_twin_and_integral():
    """The corner singularity: the twin is the formula, and each factor integrates to 1."""
    from scipy.integrate import quad

    g = genz.singular([0.3, 0.4], [0, 1])
    f = compile_numpy(g.numpy, 2)
    assert f(np.array([[0.2], [0.7]]))[0] == pytest.approx(0.7 * 0.6 * 0.2**-0.3 * 0.3**-0.4, rel=1e-12)
    assert g.exact == 1.0
    f1 = compile_numpy(genz.singular([0.45], [1]).numpy, 1)
    assert quad(lambda t: f1(np.array([[t]]))[0], 0, 1, limit=200)[0] == pytest.approx(1.0, rel=1e-8)


def test_genz_corner_peak_exact_in_ten_dimensions():
    """The rational inclusion-exclusion sum against the 1-D formula applied once per coordinate (d = 1)
    and against a symmetric case whose sum has a closed form: all a_i = a, sum_k (-1)^k C(d,k) / (1 + k a)."""
    assert genz.corner_peak([0.7]).exact == pytest.approx((1 - 1 / 1.7) / 0.7, rel=1e-15)
    a, d = 0.185, 10
    total = math.fsum((-1) ** k * math.comb(d, k) / (1 + k * a) for k in range(d + 1))
    assert genz.corner_peak([a] * d).exact == pytest.approx(total / (math.factorial(d) * a**d), rel=1e-9)


def test_builtin_exact_values_against_quadrature():
    probs = {p.name: p for p in builtin_problems()}
    p = probs["two-peak-2d"]
    assert _quad(compile_numpy(p.numpy, 2), 2, nodes=64) == pytest.approx(p.exact, rel=1e-9)
    p = probs["singular-1d"]
    assert p.exact == pytest.approx(special.gammainc(0.6, 1.0) * special.gamma(0.6), rel=1e-12)
    assert _lower_gamma(2.5, 3.0) == pytest.approx(special.gammainc(2.5, 3.0) * special.gamma(2.5), rel=1e-12)
    assert probs["additive-6d"].exact == pytest.approx(math.e - 1)
    assert probs["smooth-gauss-4d"].control_integral == pytest.approx(_quad(
        compile_numpy("(1 - x[0]**2 + 0.5*x[0]**4)", 1), 1) ** 4)
    assert probs["disk-2d"].exact == pytest.approx(math.pi / 4)


def test_builtin_numpy_twins_integrate_to_exact():
    """Each built-in problem's NumPy twin is the same function: plain MC hits the exact value within 5 se."""
    rng = np.random.default_rng(3)
    for p in builtin_problems():
        f = compile_numpy(p.numpy, p.dim)
        v = f(rng.random((p.dim, 200_000)))
        se = v.std() / math.sqrt(v.size)
        assert abs(v.mean() - p.exact) <= 5 * se, p.name


def test_translate_opencl():
    x = np.random.default_rng(0).random((2, 5))
    f = compile_numpy(translate_opencl("exp(-x[0]*x[0]) + 1.5f*pow(x[1], 2) / 3"), 2)
    assert np.allclose(f(x), np.exp(-x[0] ** 2) + 1.5 * x[1] ** 2 / 3)
    for code in ("float r = x[0]; return r;", "x[0] > 0.5f ? 1.0f : 0.0f", "x[0] < 1 && x[1] < 1", "foo(x[0])"):
        with pytest.raises(TranslationError):
            translate_opencl(code)


def test_missing_matplotlib_is_a_clear_error_after_the_data_is_written(tmp_path, capsys, monkeypatch):
    for mod in ("matplotlib", "matplotlib.figure", "matplotlib.backends.backend_agg"):
        monkeypatch.setitem(sys.modules, mod, None)  # import of it raises ImportError
    f = _write(tmp_path, [GOOD])
    out = tmp_path / "out"
    status = main(["bench", "integrate", "--problem", str(f), "--estimators", "independent", "--no-numpy",
                   "--budget", "0.02", "--out", str(out)])
    assert status == 2
    assert "matplotlib" in capsys.readouterr().err
    assert (out / "integrate-checkpoints.csv").exists() and (out / "integrate-summary.json").exists()


# -- render suite ----------------------------------------------------------------------

FURNACE = Path(__file__).resolve().parent.parent / "scenes" / "furnace.json"


def test_render_bench_against_a_cached_reference(tmp_path, capsys):
    out = tmp_path / "out"
    args = ["bench", "render", str(FURNACE), "--budget", "0.1", "--reference-time", "0.5", "--out", str(out),
            "--no-plot"]
    assert main(args) == 0
    first = capsys.readouterr()
    assert "rendering the reference" in first.err
    s = json.loads((out / "render-summary.json").read_text())
    (prob,) = s["problems"]
    assert [e["name"] for e in prob["estimators"]] == ["path", "nee", "mis", "lt", "bdpt"]
    assert prob["baseline_unavailable"]  # said, not silently missing
    for e in prob["estimators"]:
        assert e["points"] == prob["width"] * prob["height"] and e["error"] >= 0 and e["failed"] is None
    assert len(list((out / "cache").glob("render-reference-*.exr"))) == 1
    assert main(args) == 0  # the second bench reuses the cached reference
    assert "rendering the reference" not in capsys.readouterr().err


def test_render_bench_compares_chosen_integrators(tmp_path, capsys):
    """--integrators mis lt bdpt: those three at equal time, rel. eff. against the first (mis), the
    reference rendered by --reference-integrator and cached apart from a mis reference."""
    out = tmp_path / "out"
    args = ["bench", "render", str(FURNACE), "--budget", "0.1", "--reference-time", "0.5", "--out", str(out),
            "--no-plot", "--integrators", "mis", "lt", "bdpt", "--reference-integrator", "bdpt"]
    assert main(args) == 0
    got = capsys.readouterr()
    assert "rendering the reference (bdpt" in got.err
    assert "rel. eff. against 'mis'" in got.out
    s = json.loads((out / "render-summary.json").read_text())
    (prob,) = s["problems"]
    assert prob["reference"].startswith("bdpt, ")
    assert [e["name"] for e in prob["estimators"]] == ["mis", "lt", "bdpt"]
    by_name = {e["name"]: e for e in prob["estimators"]}
    assert by_name["mis"]["relative_efficiency"] == pytest.approx(1.0)
    assert all(e["failed"] is None for e in prob["estimators"])
    assert main([*args[:-1], "mis"]) == 0  # a mis reference is another cache entry
    assert "rendering the reference (mis" in capsys.readouterr().err
    assert len(list((out / "cache").glob("render-reference-*.exr"))) == 2


def test_render_bench_refuses_an_unknown_reference_integrator(tmp_path, capsys):
    status = main(["bench", "render", str(FURNACE), "--reference-integrator", "photon", "--budget", "0.05",
                   "--out", str(tmp_path / "o")])
    assert status == 2
    assert "--reference-integrator" in capsys.readouterr().err


def test_render_bench_reference_of_the_wrong_size(tmp_path, capsys):
    import mcocl

    other = mcocl.render(str(Path(__file__).resolve().parent.parent / "scenes" / "furnace_sphere.json"), spp=1)
    ref = tmp_path / "ref.exr"
    other.save_exr(ref)
    status = main(["bench", "render", str(FURNACE), "--reference", str(ref), "--budget", "0.05",
                   "--out", str(tmp_path / "o")])
    assert status == 2
    assert "--reference" in capsys.readouterr().err


def test_example_problem_file_parses():
    probs = load_problem_file(Path(__file__).resolve().parent.parent / "docs" / "bench" / "example_problems.json")
    assert [p.name for p in probs] == ["bump-2d", "inverse-sqrt-1d", "two-bumps-1d"]
    assert list(probs[2].estimator_options()) == ["independent", "stratified", "nrooks", "left", "right", "average",
                                                  "max", "balance", "power", "roulette-half"]
    assert probs[0].baseline().start is not None  # NumPy twin translated from the OpenCL C expression


def test_problem_file_bad_extra_estimator_names_it(tmp_path):
    from mcocl.bench.integrate_suite import SUITE
    from mcocl.bench.suite import BenchOptions

    f = _write(tmp_path, [{**GOOD, "estimators": {"rr": {"roulette": 2.0}}}])
    with pytest.raises(InputError, match=r"'bump'.*'estimators\.rr'.*roulette"):
        SUITE.problems(BenchOptions(problem_files=[str(f)]))


# -- peers (issue 12, part 6) -----------------------------------------------------------

HAS_SCIPY = importlib.util.find_spec("scipy") is not None
HAS_VEGAS = importlib.util.find_spec("vegas") is not None


def test_peers_run_beside_ours_in_the_same_table(tmp_path, capsys):
    out = tmp_path / "out"
    status = main(["bench", "integrate", "--peers", "--only", "disk-2d", "--budget", "0.2", "--no-numpy",
                   "--no-plot", "--out", str(out)])
    assert status == 0
    table = capsys.readouterr().out
    s = json.loads((out / "integrate-summary.json").read_text())
    by_name = {e["name"]: e for e in s["problems"][0]["estimators"]}
    peers = [n for n, ok in (("scipy-sobol", HAS_SCIPY), ("vegas-package", HAS_VEGAS)) if ok]
    for name in ("independent", "sobol", "vegas", *peers):
        e = by_name[name]
        assert e["kind"] == ("peer" if name in peers else "engine")
        assert e["samples"] > 0 and math.isfinite(e["efficiency"]) and math.isfinite(e["error"])
        # equal wall time: each run stops near the budget (a step never more than doubles it)
        assert 0.02 <= e["seconds"] <= 1.0, (name, e["seconds"])
        assert abs(e["error"]) <= 5 * e["stderr"], (name, e["error"], e["stderr"])
        assert name in table
    if peers:
        assert "best of ours vs best peer at equal time" in table
    if HAS_SCIPY:
        # 16 scramblings of 2^k points each
        n = by_name["scipy-sobol"]["samples"] // 16
        assert by_name["scipy-sobol"]["samples"] % 16 == 0 and n & (n - 1) == 0


def test_a_missing_peer_is_skipped_with_the_reason(tmp_path, capsys, monkeypatch):
    from mcocl.bench import integrate_peers

    monkeypatch.setitem(integrate_peers.PEER_PACKAGES, "vegas-package", ("no_such_vegas_module", "pip install it"))
    out = tmp_path / "out"
    status = main(["bench", "integrate", "--peers", "--only", "disk-2d", "--estimators", "independent",
                   "vegas-package", "--budget", "0.05", "--no-numpy", "--no-plot", "--out", str(out)])
    assert status == 0
    text = capsys.readouterr().out
    assert "skipped vegas-package" in text and "'no_such_vegas_module' package is not installed" in text
    names = [e["name"] for e in json.loads((out / "integrate-summary.json").read_text())["problems"][0]["estimators"]]
    assert names == ["independent"]


@pytest.mark.skipif(not HAS_SCIPY, reason="scipy is not installed")
def test_scipy_sobol_peer_is_unbiased_and_reports_the_replicate_spread():
    from mcocl.bench.integrate_peers import ScipySobolRun

    run = ScipySobolRun(lambda x: np.exp(-x[0] * x[1]), 2, float(special.expi(-1.0) * -1 + 0.5772156649015329), seed=3)
    # exact: int_0^1 int_0^1 e^{-xy} = int_0^1 (1 - e^{-x}) / x dx = Ein(1) = E1(1) + gamma + ln 1
    # one step of 2^10 points per scrambling: scipy's points lie on a 2^-30 grid (cell corners), a bias
    # of about 3e-10 here that far longer runs would resolve (the same issue as our 2^-23 grid)
    obs = run.advance(1e-5)
    assert obs.samples == 16 * 1024 and obs.stderr > 0
    assert abs(obs.error) <= 5 * obs.stderr, (obs.error, obs.stderr)
    # the stderr is the spread of 16 replicate means over sqrt(16)
    means = run.sums / run.good
    assert obs.stderr == pytest.approx(means.std(ddof=1) / 4)
