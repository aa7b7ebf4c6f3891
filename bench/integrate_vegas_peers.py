"""``sampler="vegas"`` against the ``vegas`` package at equal wall time, in one process (issue 12, part 2).

Four peaked or singular integrands of the Genz families over [0, 1]^d with
closed-form integrals (d = 2 to 6).  For each, the ``vegas`` package runs
``nitn`` = 5 adapting iterations and then 5 more whose results it combines
(its documented way of use), ``--evals`` evaluations in all, batch
integrand in NumPy; its wall time T is measured.  mcocl then runs
``sampler="vegas"`` with ``time_budget=T`` (kernel built beforehand, not
timed).  Printed per case: the error |estimate - exact| / exact and the
reported relative stderr of each, and the samples mcocl used in T.

The ``vegas`` package is an optional extra (``pip install mcocl[peers]``);
this script is a benchmark, not a test.

    python bench/integrate_vegas_peers.py                 # 1e6 evaluations per peer run
    python bench/integrate_vegas_peers.py --evals 1e7 --json
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

import mcocl
from mcocl.cli.common import count


@dataclass
class Case:
    """One integrand: OpenCL C text, the NumPy twin of shape (n, d) -> (n,), and its exact integral."""

    name: str
    dim: int
    c_code: str
    numpy: Callable[[np.ndarray], np.ndarray]
    exact: float


def product_peak(dim: int, a: float, u: float) -> Case:
    """Genz's product peak: prod_i 1 / (a^-2 + (x_i - u)^2)."""
    c = "*".join(f"(1.0f/({a ** -2}f + (x[{i}]-{u}f)*(x[{i}]-{u}f)))" for i in range(dim))
    one = a * (math.atan(a * (1 - u)) + math.atan(a * u))
    return Case(f"product peak a={a:g}", dim, c, lambda x: np.prod(1.0 / (a**-2 + (x - u) ** 2), axis=1), one**dim)


def gaussian(dim: int, a: float, u: float) -> Case:
    """Genz's Gaussian: exp(-sum_i a^2 (x_i - u)^2)."""
    c = "exp(-(" + " + ".join(f"(x[{i}]-{u}f)*(x[{i}]-{u}f)" for i in range(dim)) + f")*{a * a}f)"
    one = math.sqrt(math.pi) / (2 * a) * (math.erf(a * (1 - u)) + math.erf(a * u))
    return Case(f"gaussian a={a:g}", dim, c, lambda x: np.exp(-a * a * np.sum((x - u) ** 2, axis=1)), one**dim)


def corner_peak(dim: int, a: float) -> Case:
    """Genz's corner peak: (1 + a sum_i x_i)^-(d+1); exact by inclusion-exclusion over the corners."""
    c = f"exp(-{dim + 1}.0f*log(1.0f + {a}f*(" + " + ".join(f"x[{i}]" for i in range(dim)) + ")))"
    s = sum((-1) ** k * math.comb(dim, k) / (1 + k * a) for k in range(dim + 1))
    return Case(f"corner peak a={a:g}", dim, c, lambda x: (1 + a * np.sum(x, axis=1)) ** -(dim + 1),
                s / (math.factorial(dim) * a**dim))


def singular(dim: int, p: float) -> Case:
    """An integrable power singularity at the origin: prod_i (1 - p) x_i^-p (integral 1, finite variance for p < 1/2)."""
    c = "*".join(f"({1 - p}f*exp(-{p}f*log(x[{i}])))" for i in range(dim))
    return Case(f"singular x^-{p:g}", dim, c, lambda x: np.prod((1 - p) * x**-p, axis=1), 1.0)


CASES = [product_peak(2, 50.0, 0.3), gaussian(4, 10.0, 0.45), corner_peak(3, 5.0), singular(6, 0.4)]


def run_peer(case: Case, evals: int) -> tuple[float, float, float]:
    """(estimate, stderr, seconds) of the vegas package: 5 adapting iterations, then 5 combined."""
    import vegas

    f = vegas.lbatchintegrand(case.numpy)
    integ = vegas.Integrator([[0.0, 1.0]] * case.dim)
    neval = evals // 10
    t0 = time.perf_counter()
    integ(f, nitn=5, neval=neval)
    r = integ(f, nitn=5, neval=neval)
    return float(r.mean), float(r.sdev), time.perf_counter() - t0


def run_ours(case: Case, seconds: float, seed: int) -> mcocl.IntegrationResult:
    """mcocl's VEGAS in about the same wall time (kernels built beforehand).

    A time budget alone runs independent samples; the sample budget that a
    time-budgeted run reached is then run again, which stratifies the
    iterations (mcocl.integration.samplers.Vegas) and is what a user with a
    sample budget gets.  The better of the two by reported stderr is kept, and
    its own seconds are reported.
    """
    kw = dict(dim=case.dim, sampler="vegas", seed=seed)
    mcocl.integrate(case.c_code, samples=1 << 21, vegas_iterations=1, **kw)
    by_time = mcocl.integrate(case.c_code, samples=None, time_budget=seconds, **kw)
    mcocl.integrate(case.c_code, samples=by_time.samples, **kw)  # build the stratified program
    by_samples = mcocl.integrate(case.c_code, samples=by_time.samples, **kw)
    return min((by_time, by_samples), key=lambda r: r.stderr)


def main() -> None:
    """Run the comparison and print a table (or JSON)."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--evals", type=count, default=1_000_000, help="evaluations of each vegas-package run")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    rows = []
    for case, _ in itertools.product(CASES, [0]):
        p_est, p_err, t = run_peer(case, args.evals)
        r = run_ours(case, t, args.seed)
        rows.append({
            "case": case.name, "dim": case.dim, "seconds": t,
            "peer_error": abs(p_est - case.exact) / case.exact, "peer_stderr": p_err / case.exact,
            "ours_error": abs(r.estimate - case.exact) / case.exact, "ours_stderr": r.stderr / case.exact,
            "ours_samples": r.samples, "ours_chi2_dof": (r.vegas or {}).get("chi2_dof"), "ours_seconds": r.seconds,
        })
    if args.json:
        print(json.dumps(rows, indent=1))
        return
    print(f"{'case':22s} {'d':>2s} {'T s':>6s} | {'vegas err':>9s} {'stderr':>9s} | "
          f"{'mcocl err':>9s} {'stderr':>9s} {'samples':>11s} {'s':>6s} {'chi2/dof':>8s}")
    for w in rows:
        chi = w["ours_chi2_dof"]
        print(f"{w['case']:22s} {w['dim']:2d} {w['seconds']:6.2f} | {w['peer_error']:9.2e} {w['peer_stderr']:9.2e} | "
              f"{w['ours_error']:9.2e} {w['ours_stderr']:9.2e} {w['ours_samples']:11d} {w['ours_seconds']:6.2f} "
              f"{chi if chi is None else round(chi, 2)!s:>8s}")


if __name__ == "__main__":
    main()
