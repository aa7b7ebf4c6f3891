"""mcocl's sampler="sobol" against scipy.stats.qmc.Sobol(scramble=True) at equal wall time.

Smooth Genz integrands (mcocl/bench/genz.py), d = 2..8, in one process.  For
each mcocl budget N = R x 2^m (R = --replicates, default 16) the script times
mcocl (build excluded, warm) and gives scipy the largest 2^k points whose
generation plus NumPy evaluation of the same integrand fits in that time.
Errors are RMS over seeds against the closed form.

    PYTHONPATH=. python bench/sobol_peers.py [--seeds 5] [--max-log2 22]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from scipy.stats import qmc

import mcocl
from mcocl.bench import genz

PROBLEMS = [
    ("oscillatory d=2", genz.oscillatory([4.0, 3.0], [0.3, 0.0])),
    ("product peak d=4", genz.product_peak([2.0, 3.0, 2.5, 1.5], [0.4, 0.6, 0.5, 0.3])),
    ("gaussian d=6", genz.gaussian([1.5, 1.0, 2.0, 1.2, 0.8, 1.0], [0.5, 0.4, 0.6, 0.5, 0.3, 0.7])),
    ("corner peak d=8", genz.corner_peak([0.3, 0.2, 0.25, 0.15, 0.3, 0.2, 0.1, 0.25])),
]


def scipy_run(g: genz.GenzIntegrand, d: int, log2: int, seed: int) -> tuple[float, float]:
    """(error, seconds) of one scrambled-Sobol' estimate with 2^log2 points."""
    t0 = time.perf_counter()
    x = qmc.Sobol(d, scramble=True, seed=seed).random_base2(log2).T  # noqa: F841 - read by eval
    est = float(np.mean(eval(g.numpy, {"np": np, "x": x})))
    return est - g.exact, time.perf_counter() - t0


def mcocl_run(g: genz.GenzIntegrand, d: int, n: int, seed: int, replicates: int = 16) -> tuple[float, float, float]:
    """(error, seconds, reported stderr) of one mcocl sobol estimate."""
    r = mcocl.integrate(g.opencl, dim=d, samples=n, sampler="sobol", seed=seed, replicates=replicates)
    return r.estimate - g.exact, r.seconds, r.stderr


def main() -> None:
    """Print one table row per problem and budget."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--min-log2", type=int, default=16)
    ap.add_argument("--max-log2", type=int, default=22)
    ap.add_argument("--replicates", type=int, default=16, help="mcocl's R (the error grows like R at equal N)")
    args = ap.parse_args()
    print(f"{'problem':18} {'N mcocl':>9} {'t mcocl':>8} {'rmse mcocl':>11} {'stderr':>9} "
          f"{'N scipy':>9} {'t scipy':>8} {'rmse scipy':>11} {'ratio':>7}")
    for name, g in PROBLEMS:
        d = int(name.split("d=")[1])
        mcocl_run(g, d, 1 << 16, 0)  # build and warm up
        scipy_times: dict[int, float] = {}
        for k in range(args.min_log2, args.max_log2 + 1, 2):
            n = 1 << k
            runs = [mcocl_run(g, d, n, s, args.replicates) for s in range(args.seeds)]
            t = float(np.median([r[1] for r in runs]))
            rm = math.sqrt(np.mean([r[0] ** 2 for r in runs]))
            se = math.sqrt(np.mean([r[2] ** 2 for r in runs]))
            # the largest 2^j scipy points that fit in t (timed once per size, median of 3)
            j = 8
            while True:
                if j + 1 not in scipy_times:
                    scipy_times[j + 1] = float(np.median([scipy_run(g, d, j + 1, s)[1] for s in range(3)]))
                if scipy_times[j + 1] > t or j + 1 > 26:
                    break
                j += 1
            sr = [scipy_run(g, d, j, s) for s in range(args.seeds)]
            srm = math.sqrt(np.mean([e ** 2 for e, _ in sr]))
            st = float(np.median([s for _, s in sr]))
            print(f"{name:18} {n:9d} {t:8.4f} {rm:11.3e} {se:9.2e} {1 << j:9d} {st:8.4f} {srm:11.3e} {srm / rm:7.1f}",
                  flush=True)


if __name__ == "__main__":
    main()
