"""``mcocl solve``: an integral equation of the second kind by random walks."""

from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np

from ..engine.contract import DeviceFailureWarning
from ..integration import NonFiniteWarning
from ..walks import ESTIMATORS, nystrom, solve_fredholm
from ..walks.sobol_walks import WALK_SAMPLERS
from .common import (
    add_device_args,
    add_halting_args,
    add_persistence_args,
    count,
    print_json,
    run_option_kwargs,
)
from .paths import check_files

DESCRIPTION = """\
Solve f(x) = g(x) + integral over [0,1]^dim of K(x,y) f(y) dy at query points
by random walks (the Neumann series f = g + Tg + T^2 g + ...).

KERNEL is OpenCL C over `float x[dim], y[dim]`, SOURCE over `float x[dim]`:
an expression such as "0.5f*(x[0] + y[0])" or a body that returns.

Estimators:
  truncated    the series cut after --depth moves (biased; uniform moves)
  roulette     uniform moves, Russian roulette with survival --survival
               (a probability, or 'weight' for min(1, |walk weight|))
  subcritical  moves ~ |K(x,.)|, survival min(1, integral |K(x,.)|); the
               density is tabulated unless --row-integral and
               --transition-sampler give it
  nee          subcritical walk plus next-event estimation of the g term,
               sampled ~ |g| (tabulated unless --source-integral and
               --source-sampler give it)

A walk that makes --max-walk-length moves stops the run: the series appears
not to converge (spectral radius of |K| >= 1).
"""

EXAMPLES = """\
examples:
  mcocl solve --kernel "0.5f" --source "sin(M_PI_F*x[0]) - 0.318309886f" --dim 1 \\
              --at 0.1 0.5 0.9 --walks 1e6 --estimator nee --json
  mcocl solve --kernel "0.5f*(x[0] + y[0])" --source "x[0]*x[0] - x[0]/6.0f - 0.125f" \\
              --at 0.1 0.5 0.9 --estimator roulette --reference
  mcocl solve --kernel "0.3f" --source "x[0]*x[1]" --dim 2 --at 0.2,0.7 0.5,0.5
  mcocl solve --kernel "y[0]" --source "1.0f" --at 0.5 --estimator subcritical \\
              --row-integral "0.5f" --transition-sampler "sqrt(u[0])"
"""


def _point(text: str) -> list[float]:
    try:
        return [float(c) for c in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"a query point is numbers separated by commas (e.g. 0.2,0.7), got {text!r}") from None


def _survival(text: str) -> str | float:
    if text == "weight":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected 'weight' or a probability, got {text!r}") from None


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``solve`` parser."""
    p = sub.add_parser("solve", help="solve an integral equation of the second kind by random walks",
                       description=DESCRIPTION, epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--kernel", required=True, help="K(x, y), OpenCL C over float x[dim], y[dim]")
    p.add_argument("--source", required=True, help="g(x), OpenCL C over float x[dim]")
    p.add_argument("--dim", type=int, default=1, help="dimension of the domain [0,1]^dim (default 1)")
    p.add_argument("--at", type=_point, nargs="+", required=True, metavar="POINT",
                   help="query points; in 2-D and higher each is x0,x1,...")
    p.add_argument("--walks", type=count, default=None,
                   help="walks per query point (default 1e6, or unlimited with --time/--target-error)")
    p.add_argument("--estimator", choices=tuple(ESTIMATORS), default="nee", help="(default nee)")
    p.add_argument("--seed", type=int, default=0, help="64-bit seed (default 0)")
    p.add_argument("--depth", type=int, default=8, help="moves of the truncated estimator (default 8)")
    p.add_argument("--survival", type=_survival, default="weight",
                   help="roulette survival probability, or 'weight' (default)")
    p.add_argument("--row-integral", default=None, help="A(x) = integral of |K(x,y)| dy, OpenCL C over x")
    p.add_argument("--transition-sampler", nargs="+", default=None, metavar="EXPR",
                   help="inverse CDF of |K(x,.)|/A(x): one expression per coordinate over x and u")
    p.add_argument("--source-integral", type=float, default=None, help="G = integral of |g|")
    p.add_argument("--source-sampler", nargs="+", default=None, metavar="EXPR",
                   help="inverse CDF of |g|/G: one expression per coordinate over u")
    p.add_argument("--max-walk-length", type=count, default=10_000, help="walk-length guard (default 10000 moves)")
    p.add_argument("--table-cells", type=count, default=None, help="tabulation cells of x per axis")
    p.add_argument("--table-bins", type=count, default=None, help="tabulation bins of y per axis")
    p.add_argument("--sampler", choices=WALK_SAMPLERS, default="independent",
                   help="independent, or sobol: Owen-scrambled Sobol' walks, stderr from the replicate spread")
    p.add_argument("--replicates", type=count, default=None, help="independent scramblings of --sampler sobol (default 16)")
    p.add_argument("--reference", action="store_true", help="also compute the Nyström solution at the points")
    p.add_argument("--order", type=count, default=None, help="Gauss-Legendre nodes per axis of the reference")
    add_halting_args(p, "stop once every point's standard error is at most this", "--target-stderr")
    add_persistence_args(p, "problem")
    add_device_args(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Solve and print the result."""
    check_files([("--checkpoint", args.checkpoint)], resume=args.resume)
    shared = run_option_kwargs(args)
    walks = args.walks
    if walks is None and shared["time_budget"] is None and shared["target_error"] is None:
        walks = 1_000_000
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", NonFiniteWarning)
        r = solve_fredholm(
            args.kernel, args.source, dim=args.dim, at=args.at, walks=walks, estimator=args.estimator,
            depth=args.depth, survival=args.survival, row_integral=args.row_integral,
            transition_sampler=args.transition_sampler, source_integral=args.source_integral,
            source_sampler=args.source_sampler, max_walk_length=args.max_walk_length,
            table_cells=args.table_cells, table_bins=args.table_bins, sampler=args.sampler,
            replicates=args.replicates, **shared,
        )
    for w in caught:
        if issubclass(w.category, (NonFiniteWarning, DeviceFailureWarning)):
            print(f"WARNING: {w.message}", file=sys.stderr)
    ref = None
    if args.reference:
        sol = nystrom(args.kernel, args.source, args.dim, order=args.order, device=args.device)
        ref = sol(np.asarray(r.at))
    if args.json:
        d = r.to_dict()
        if ref is not None:
            d["reference"] = [float(v) for v in ref]
            d["reference_order"] = sol.order
        print_json(d)
    else:
        for k, (p, v, e) in enumerate(zip(r.at, r.values, r.stderr)):
            line = f"f({', '.join(f'{c:g}' for c in p)}) = {v:.10g} ± {e:.3g}"
            if ref is not None:
                line += f"   Nyström {ref[k]:.10g}  ({(v - ref[k]) / e:+.2f} stderr)" if e > 0 else f"   Nyström {ref[k]:.10g}"
            print(line)
        print(f"walks     {r.walks} per point in {r.seconds:.3f} s ({r.walks_per_second / 1e6:.2f} M walks/s, "
              f"{r.lanes} lanes), mean length {r.mean_walk_length:.3g} moves")
        print(f"estimator {r.estimator}: {r.description}")
        print(f"device    {r.device}")
        if any(r.nonfinite):
            print(f"nonfinite {r.nonfinite}  (walks left out, per point)")
        if r.stopped_by != "walks":
            print(f"stopped   by {r.stopped_by}")
        for n in r.notes:
            print(f"note      {n}")
    return 130 if r.stopped_by == "interrupt" else 0
