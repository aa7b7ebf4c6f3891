"""``mcocl integrate``: Monte Carlo integration of an OpenCL C expression."""

from __future__ import annotations

import argparse
import json
import sys
import warnings

from ..datafile import loads_json
from ..engine.contract import DeviceFailureWarning
from ..integration import NonFiniteWarning, integrate
from ..integration.api import PRECISIONS
from ..integration.codegen import HEURISTICS
from ..integration.samplers import SAMPLER_SPECS, Sobol
from .common import (
    add_device_args,
    add_halting_args,
    add_persistence_args,
    count,
    positive,
    print_json,
    run_option_kwargs,
)
from .paths import check_files

DESCRIPTION = """\
Estimate the integral of INTEGRAND over the unit cube [0,1]^dim.

INTEGRAND is OpenCL C over `float x[dim]`: an expression such as
"exp(-x[0]*x[0])", or a function body that returns, such as
"float r = x[0]*x[0] + x[1]*x[1]; return r < 1.0f ? 1.0f : 0.0f;".

Samplers (how the uniform points are placed):
  independent  plain secondary estimator, (1/N) sum f(x_i)
  stratified   jittered strata, m^dim per design with 2 samples each; the
               standard error comes from the pairs (honest, not the plain
               sample variance)
  nrooks       Latin hypercube designs (N-rooks); the standard error comes
               from the spread of independent designs
  sobol        randomised quasi-Monte Carlo: --replicates R (default 16)
               independent Owen scramblings of 2^m Sobol' points; the
               samples are rounded down to R x 2^m and the standard error
               comes from the spread of the R replicate means; with
               --time alone, a short pilot measures the rate and 2^m is
               the largest whose R replicates fit the time left;
               --scrambling linear (random matrix and digital shift)
               gives smaller errors than the default hash at large N

Precision: --precision double (independent and sobol, no proposals nor
roulette) evaluates in double: 32-bit uniforms, `float` in the snippet
means double and literals such as 0.3f are read as double constants; the
default float32 evaluation floors the relative error near 1e-8.

Estimators (combine with any sampler):
  --proposal SPEC          importance sampling, x = P^-1(u), f(x)/p(x)
  --proposals SPEC SPEC..  combined estimator, --heuristic average|max|balance|power
  --control G --control-integral J   control variate f - g + J
  --roulette P             Russian roulette with survival probability P

A proposal SPEC is one factor for every dimension or a JSON list of factors:
  uniform | exponential:rate=R | power:a=A | truncnorm:mu=M,sigma=S |
  {"type": "tabulated", "weights": [...]} | {"type": "tabulated2d", "weights": [[...]]} |
  {"type": "analytic", "pdf": "3*x*x", "inverse": "cbrt(u)"}
"""

EXAMPLES = """\
examples:
  mcocl integrate "exp(-x[0]*x[0])" --dim 1 --samples 1e6 --sampler nrooks --seed 7
  mcocl integrate "exp(-x[0]*x[0])" --samples 1e6 --json
  mcocl integrate "exp(-(x[0]+x[1]))*cos(x[2])" --dim 3 --sampler sobol --samples 1e8 --replicates 32
  mcocl integrate "1/(0.01 + (x[0]-0.3)*(x[0]-0.3))" --sampler sobol --samples 1e8 --precision double
  mcocl integrate "exp(-3*x[0])" --proposal exponential:rate=3
  mcocl integrate "1/sqrt(x[0])" --proposal power:a=-0.5
  mcocl integrate "exp(-x[0])" --control "1 - x[0]" --control-integral 0.5
  mcocl integrate "exp(-x[0]*x[0])" --samples 1e12 --time 10 --target-error 1e-7
  mcocl integrate "exp(-x[0]*x[0])" --samples 1e10 --devices all
  mcocl integrate "exp(-x[0]*x[0])" --samples 1e10 --split 2
  mcocl integrate "exp(-x[0]*x[0])" --samples 1e12 --dask tcp://scheduler:8786
"""


def _spec(text: str) -> object:
    t = text.strip()
    if t.startswith("{") or t.startswith("["):
        try:
            return loads_json(t, "proposal JSON")
        except json.JSONDecodeError as e:
            raise argparse.ArgumentTypeError(f"proposal JSON: {e}") from None
    return t


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``integrate`` parser."""
    p = sub.add_parser("integrate", help="integrate a function over the unit cube",
                       description=DESCRIPTION, epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("integrand", help="OpenCL C over float x[dim]")
    p.add_argument("--dim", type=int, default=1, help="dimension of the cube (default 1)")
    p.add_argument("--samples", type=count, default=None,
                   help="integrand evaluations (default 1e6, or unlimited with --time/--target-error)")
    p.add_argument("--sampler", choices=tuple(SAMPLER_SPECS), default="independent",
                   help="point placement (default independent)")
    p.add_argument("--seed", type=int, default=0, help="64-bit seed (default 0)")
    p.add_argument("--proposal", type=_spec, default=None, help="importance-sampling density (see above)")
    p.add_argument("--proposals", type=_spec, nargs="+", default=None, help="densities of a combined estimator")
    p.add_argument("--shares", type=int, nargs="+", default=None, help="samples of each proposal per unit")
    p.add_argument("--heuristic", choices=tuple(HEURISTICS), default="balance", help="combined weights (default balance)")
    p.add_argument("--beta", type=positive, default=2.0, help="power-heuristic exponent (default 2)")
    p.add_argument("--control", default=None, help="control variate g(x), OpenCL C")
    p.add_argument("--control-integral", type=float, default=None, help="exact integral J of g")
    p.add_argument("--roulette", type=float, default=None, help="Russian roulette survival probability P in (0, 1]")
    add_halting_args(p, "stop once the standard error is at most this", "--target-stderr")
    p.add_argument("--design-samples", type=count, default=None,
                   help="samples per stratified / N-rooks design / Sobol' replicate")
    p.add_argument("--replicates", type=count, default=None,
                   help="independent scramblings of --sampler sobol (default 16)")
    p.add_argument("--scrambling", choices=Sobol.SCRAMBLINGS, default=None,
                   help="--sampler sobol: hash (Laine-Karras, default) or linear (random matrix and digital shift)")
    p.add_argument("--precision", choices=PRECISIONS, default="single",
                   help="evaluate in float32 (single, default) or double (independent and sobol)")
    p.add_argument("--iterations", type=int, default=None, help="--sampler vegas: iterations (default 10)")
    p.add_argument("--vegas-bins", type=int, default=None,
                   help="--sampler vegas: grid bins per dimension, a power of two (default 256)")
    p.add_argument("--alpha", type=float, default=None, help="--sampler vegas: damping of the grid refinement (default 1.5)")
    add_persistence_args(p, "job")
    add_device_args(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run an integration and print the result."""
    check_files([("--checkpoint", args.checkpoint)], resume=args.resume)
    shared = run_option_kwargs(args)
    samples = args.samples
    if samples is None and shared["time_budget"] is None and shared["target_error"] is None:
        samples = 1_000_000
    # both given is refused by integrate() with one message for the API and the CLI
    proposal, proposals = args.proposal, args.proposals
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", NonFiniteWarning)
        r = integrate(
            args.integrand, dim=args.dim, samples=samples, sampler=args.sampler,
            proposal=proposal, proposals=proposals, shares=args.shares, heuristic=args.heuristic, beta=args.beta,
            control=args.control, control_integral=args.control_integral, roulette=args.roulette,
            design_samples=args.design_samples, replicates=args.replicates, scrambling=args.scrambling,
            vegas_iterations=args.iterations, vegas_bins=args.vegas_bins, alpha=args.alpha,
            precision=args.precision, **shared,
        )
    for w in caught:
        if issubclass(w.category, (NonFiniteWarning, DeviceFailureWarning)):
            print(f"WARNING: {w.message}", file=sys.stderr)
    if args.json:
        print_json(r.to_dict())
    else:
        print(f"estimate  {r.estimate:.12g}")
        print(f"stderr    {r.stderr:.6g}   ({r.variance_method})")
        print(f"samples   {r.samples}   in {r.seconds:.3f} s  ({r.samples_per_second / 1e6:.1f} M samples/s, {r.lanes} lanes)")
        print(f"estimator {r.estimator}")
        print(f"device    {r.device}")
        if r.nonfinite:
            print(f"nonfinite {r.nonfinite}  (left out of the estimate)")
        if r.stopped_by != "samples":
            print(f"stopped   by {r.stopped_by}")
        for n in r.notes:
            print(f"note      {n}")
    return 130 if r.stopped_by == "interrupt" else 0
