"""``mcocl bench``: variance versus time for every estimator, on this machine."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..bench import BenchOptions, available_suites, run_bench
from ..bench.status import BenchStatus
from ..bench.suite import load_suite
from .common import positive
from .paths import check_files

DEFAULT_BUDGET = 5.0
QUICK_BUDGET = 0.25
DEFAULT_OUT = "bench-out"

DESCRIPTION = """\
Measure which estimator buys the most accuracy per second, on this machine.

For each problem and each estimator the bench samples for --budget seconds,
recording checkpoints (seconds, samples, estimate, reported standard error,
actual error against the exact value).  It prints one table per problem:

  samples/s     throughput
  var/sample    the estimator's honest variance per sample, stderr^2 x samples
                (for stratified and N-rooks designs the variance of the
                design means, not the plain sample variance of f); solve and
                render: per query point or pixel
  efficiency    1 / (variance per sample x seconds per sample)
  rel. eff.     efficiency over that of the suite's plain estimator
                (integrate: independent, solve: roulette, render: path)
  error at end  estimate - exact (solve, render: RMS over the query points
                or pixels against the exact values or the reference image)
  |err|<=4 se   whether the actual error agrees with the reported stderr
  rms z         root mean square of error/stderr over the checkpoints: about
                1 when the stderr is honest (<< 1: overstated, >> 1: understated)

and the engine's speed-up over a vectorised NumPy float64 version of the
plain estimator, timed in the same process (the 'numpy' row; integrate and
solve).  Files in --out:
SUITE-table.txt, SUITE-checkpoints.csv (one row per checkpoint),
SUITE-summary.json, SUITE-error-vs-time.png and SUITE-efficiency.png.

Modes:
  integrate   built-in integrands with exact integrals (smooth, peaked,
              discontinuous, singular, additive, two-peak, the six Genz
              families, 1 to 10 dimensions), or your own from --problem FILE
  solve       random-walk estimators on integral equations with known solutions
  render      path, nee, mis, lt and bdpt on a scene at equal time against one
              reference image (given with --reference, or rendered by
              --reference-integrator, mis by default, for --reference-time,
              8x the budget by default, and cached); --integrators picks some
  integrate --peers
              adds mcocl's sobol and vegas samplers and, timed alike in the
              same process on the NumPy twin, scipy's scrambled Sobol'
              (scipy-sobol) and the vegas package (vegas-package); a peer
              whose package is not installed is skipped with the reason
  --quick     the problems behind the lecture's orderings, a few seconds each
              suite (integrate and solve; with a mode, that mode's subset)
"""

EXAMPLES = """\
examples:
  mcocl bench --quick
  mcocl bench integrate --budget 5 --out bench-out/
  mcocl bench solve --budget 5 --out bench-out/
  mcocl bench render scenes/veach_mis.json --budget 30 --out bench-out/
  mcocl bench render scenes/caustic.json --budget 30 --integrators mis lt bdpt --reference-integrator bdpt
  mcocl bench integrate --problem my_problems.json --estimators independent stratified nrooks
  mcocl bench integrate --only 'genz-*' two-peak-2d --budget 2
  mcocl bench integrate --list
  mcocl bench integrate --peers --only 'genz-*' --budget 2
"""

PROBLEM_FILE_HELP = """\
problem file (JSON): {"problems": [{"name": ..., "expression": "<OpenCL C over x[dim]>",
"dim": N, "exact": V, optional "numpy", "proposals", "proposal_names", "shares",
"control": {"expression": ..., "integral": J}, "estimators": {name: {integrate kwargs}}}]}
"""


# A day per estimator and problem: a bench of many estimators must still end in
# a time a person waits for (issue 10: --budget 1e30 ran for ever).
MAX_BUDGET = 86400.0


def budget_seconds(text: str) -> float:
    """A --budget: a positive number of seconds, at most MAX_BUDGET."""
    v = positive(text)
    if v > MAX_BUDGET:
        raise argparse.ArgumentTypeError(f"expected at most {MAX_BUDGET:g} seconds (a day) per estimator, got {text!r}")
    return v


def _common(p: argparse.ArgumentParser, top: bool) -> None:
    """Options valid before and after the mode (a mode's copy only overrides when given)."""
    d = (lambda v: v) if top else (lambda v: argparse.SUPPRESS)
    p.add_argument("--budget", type=budget_seconds, default=d(None), metavar="SECONDS",
                   help=f"sampling seconds per estimator and problem (default {DEFAULT_BUDGET:g}; {QUICK_BUDGET:g} with --quick)")
    p.add_argument("--out", default=d(None), metavar="DIR", help=f"folder for the table, CSV, JSON and PNG files (default {DEFAULT_OUT})")
    p.add_argument("--quick", action="store_true", default=d(False), help="the quick subset, a few seconds in all")
    p.add_argument("--seed", type=int, default=d(1), help="seed of every estimator (default 1)")
    p.add_argument("--device", default=d(None), help="OpenCL device: index from `mcocl devices` or a name substring")
    p.add_argument("--lanes", type=int, choices=(1, 2, 4, 8, 16), default=d(None), help="kernel vector width override")
    p.add_argument("--no-plot", dest="plot", action="store_false", default=d(True), help="do not draw the PNG plots")
    p.add_argument("--no-numpy", dest="numpy", action="store_false", default=d(True), help="skip the NumPy baseline")
    p.add_argument("--estimators", nargs="+", default=d(None), metavar="NAME",
                   help="run only these estimators (names as in the tables)")


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``bench`` parser and its modes."""
    p = sub.add_parser("bench", help="variance versus time of every estimator (tables, CSV, JSON, plots)",
                       description=DESCRIPTION, epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    _common(p, top=True)
    modes = p.add_subparsers(dest="mode", metavar="MODE")
    pi = modes.add_parser("integrate", help="integration estimators on integrands with exact integrals",
                          epilog=PROBLEM_FILE_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    _common(pi, top=False)
    pi.add_argument("--problem", action="append", default=[], metavar="FILE",
                    help="a JSON problem file (repeatable); replaces the built-in problems")
    pi.add_argument("--only", nargs="+", default=None, metavar="NAME",
                    help="built-in problems to run (names or shell patterns such as 'genz-*')")
    pi.add_argument("--list", action="store_true", help="list the problems and their estimators, run nothing")
    pi.add_argument("--peers", action="store_true",
                    help="also time scipy's scrambled Sobol' and the vegas package (on the NumPy twin, same process, "
                         "same time) beside mcocl's sobol and vegas; a peer whose package is missing is skipped")
    ps = modes.add_parser("solve", help="random-walk estimators on integral equations with known solutions")
    _common(ps, top=False)
    ps.add_argument("--only", nargs="+", default=None, metavar="NAME", help="built-in problems to run")
    ps.add_argument("--list", action="store_true", help="list the problems and their estimators, run nothing")
    pr = modes.add_parser("render", help="integrators on a scene against a reference image (RMSE)")
    _common(pr, top=False)
    pr.add_argument("scene", nargs="?", default=None, help="scene file")
    pr.add_argument("--reference", default=None, metavar="EXR",
                    help="reference image of the scene (default: rendered by --reference-integrator and cached "
                         "in OUT/cache)")
    pr.add_argument("--reference-time", type=positive, default=None, metavar="SECONDS",
                    help="render time of the cached reference (default 8x the budget)")
    pr.add_argument("--integrators", nargs="+", dest="estimators", default=argparse.SUPPRESS, metavar="NAME",
                    help="the integrators to compare (path nee mis lt bdpt; default all), as --estimators; "
                         "rel. eff. is against path, or the first named when path is not")
    pr.add_argument("--reference-integrator", default="mis", metavar="NAME",
                    help="integrator of the rendered reference (default mis; bdpt resolves caustics that mis "
                         "and path leave noisy)")
    pr.add_argument("--cache", default=None, metavar="DIR", help="where rendered references are cached (default OUT/cache)")
    pr.add_argument("--list", action="store_true", help="list the integrators, run nothing")
    p.set_defaults(func=run)


def _options(args: argparse.Namespace) -> BenchOptions:
    out = args.out or DEFAULT_OUT
    return BenchOptions(
        quick=args.quick, seed=args.seed, device=args.device, lanes=args.lanes,
        problem_files=list(getattr(args, "problem", []) or []), only=getattr(args, "only", None),
        inputs=[args.scene] if getattr(args, "scene", None) else [], reference=getattr(args, "reference", None),
        reference_seconds=getattr(args, "reference_time", None),
        reference_integrator=getattr(args, "reference_integrator", "mis"),
        cache_dir=getattr(args, "cache", None) or str(Path(out) / "cache"),
        peers=getattr(args, "peers", False),
    )


def _list(suite: str, options: BenchOptions) -> None:
    if suite == "render":  # listing must not render a reference
        from ..bench.render_suite import DESCRIPTIONS

        for name, text in DESCRIPTIONS.items():
            print(f"{name}: {text}")
        return
    for prob in load_suite(suite).problems(options):
        names = " ".join(s.name for s in prob.estimators())
        print(f"{prob.name}: {prob.description}\n    estimators: {names}")


def run(args: argparse.Namespace) -> int:
    """Run the requested suites; print the tables; write the files."""
    if args.mode is None and not args.quick:
        print("mcocl bench: give a mode (integrate, solve, render) or --quick; see mcocl bench --help",
              file=sys.stderr)
        return 2
    suites = [args.mode] if args.mode else available_suites()
    if args.mode == "render" and not args.quick and not args.scene and not getattr(args, "list", False):
        print("mcocl bench render: give a scene file (mcocl bench render SCENE)", file=sys.stderr)
        return 2
    if args.mode is None:
        # `mcocl bench --quick` runs every suite's built-in quick subset; render needs a scene of its own
        suites = [s for s in suites if s != "render"]
    options = _options(args)
    check_files(inputs=[(f"--problem {f}", f) for f in options.problem_files] + [("the scene", s) for s in options.inputs]
                + [("--reference", options.reference)],
                folders=[("--out", args.out or DEFAULT_OUT), ("--cache", options.cache_dir)])
    if getattr(args, "list", False):
        _list(suites[0], options)
        return 0
    budget = args.budget or (QUICK_BUDGET if args.quick else DEFAULT_BUDGET)
    out = args.out or DEFAULT_OUT
    status = 0
    for suite in suites:
        result, files = run_bench(suite, budget, options, args.estimators, out, plots=False, baseline=args.numpy,
                                  status=BenchStatus(f"bench {suite}"))
        from ..bench.report import format_table

        sys.stdout.write(format_table(result))
        sys.stdout.write("\n")
        sys.stdout.flush()
        if args.plot:
            from ..bench.plots import write_plots

            files.update(write_plots(result, out))
        print(f"wrote {', '.join(str(f) for f in files.values())}", file=sys.stderr)
        if result.interrupted:
            return 130
        if result.failures:
            status = 1
    return status
