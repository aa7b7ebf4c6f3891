"""sampler="sobol" under a time budget: the measured-rate plan against fixed 2^18 replicates.

Before the time plan (mcocl/integration/sobol_budget.py) a ``time_budget``
run without a sample count added replicates of 2^18 points until the time
was spent, so its error fell only like N^-0.5 in the replicate count; the
old plan is the same run with ``design_samples=2**18``.  Both are timed at
the same budget on smooth Genz integrands in double precision (below
float32's rounding floor), errors RMS over seeds against the closed form.

    PYTHONPATH=. python bench/sobol_time_plan.py [--seeds 6] [--budgets 1 4]
"""

from __future__ import annotations

import argparse
import math

import mcocl
from mcocl.bench import genz

PROBLEMS = [
    ("product peak d=4", genz.product_peak([2.0, 3.0, 2.5, 1.5], [0.4, 0.6, 0.5, 0.3])),
    ("gaussian d=6", genz.gaussian([1.5, 1.0, 2.0, 1.2, 0.8, 1.0], [0.5, 0.4, 0.6, 0.5, 0.3, 0.7])),
]


def main() -> None:
    """Print, per problem and budget, both plans' RMS error, mean stderr, samples and replicate size."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--budgets", type=float, nargs="+", default=[1.0, 4.0])
    args = ap.parse_args()
    print(f"{'problem':18} {'T/s':>5} {'plan':6} {'RMS error':>10} {'stderr':>10} {'samples':>11} {'2^m x R':>9}")
    for name, g in PROBLEMS:
        dim = g.opencl.count("x[") and max(int(p.split("]")[0]) for p in g.opencl.split("x[")[1:]) + 1
        mcocl.integrate(g.opencl, dim=dim, sampler="sobol", samples=1 << 20, precision="double")  # warm build
        for budget in args.budgets:
            for plan, extra in (("2^18", {"design_samples": 1 << 18}), ("rate", {})):
                errs, ses, ns, shape = [], [], [], ""
                for seed in range(args.seeds):
                    r = mcocl.integrate(g.opencl, dim=dim, sampler="sobol", samples=None, time_budget=budget,
                                        seed=seed, precision="double", **extra)
                    errs.append(r.estimate - g.exact)
                    ses.append(r.stderr)
                    ns.append(r.samples)
                    shape = f"2^{(r.samples // r.designs).bit_length() - 1}x{r.designs}"
                rms = math.sqrt(sum(e * e for e in errs) / len(errs))
                print(f"{name:18} {budget:5.3g} {plan:6} {rms:10.3g} {sum(ses) / len(ses):10.3g} "
                      f"{sum(ns) // len(ns):11d} {shape:>9}", flush=True)


if __name__ == "__main__":
    main()
