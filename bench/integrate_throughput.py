"""Throughput of ``mcocl.integrate`` against vectorised NumPy, in one process (issue 2).

The integrand is exp(-(x0^2 + x1^2 + x2^2 + x3^2)) over [0, 1]^4 with the
independent (plain) sampler.  The engine runs ``--samples`` samples (default
10^8) after a warm-up that builds the kernel; NumPy runs the same estimator
in float64 with ``Generator(PCG64)``, drawing chunks of 10^6 points into a
preallocated array (``mcocl.bench.numpy_baseline.NumpyPlainRun``; the
integrand is ``exp(-einsum('ij,ij->j', x, x))``, the fastest of the obvious
NumPy spellings measured).  The two alternate ``--repeats`` times so that
both see the same machine load; the best repeat of each is reported.

Printed per side: samples/s of wall time (the figure the ratio uses), and
samples per CPU-second, which is steadier on a shared machine: for the
engine the CPU time of the whole process (PoCL's threads are in it), for
NumPy that of the calling thread (the process's would count idle PoCL
threads too).  Goal on a 2-core CPU: >= 20x.

    python bench/integrate_throughput.py                 # 1e8 samples each, 2 repeats
    python bench/integrate_throughput.py --samples 1e9 --numpy-samples 1e8 --repeats 3
    python bench/integrate_throughput.py --json
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

import numpy as np

import mcocl
from mcocl.bench.numpy_baseline import NumpyPlainRun
from mcocl.cli.common import count

INTEGRAND = "exp(-(x[0]*x[0] + x[1]*x[1] + x[2]*x[2] + x[3]*x[3]))"
DIM = 4
EXACT = (math.sqrt(math.pi) / 2 * math.erf(1.0)) ** DIM
GOAL = 20.0


def numpy_integrand(x: np.ndarray) -> np.ndarray:
    """exp(-|x|^2) for points in the columns of ``x`` (shape (4, n))."""
    return np.exp(-np.einsum("ij,ij->j", x, x))


def engine_once(samples: int, device: object, lanes: int | None, seed: int) -> dict:
    """One timed ``mcocl.integrate`` run."""
    c0, t0 = time.process_time(), time.perf_counter()
    r = mcocl.integrate(INTEGRAND, DIM, samples, seed=seed, device=device, lanes=lanes)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {"samples": r.samples, "seconds": r.seconds, "call_seconds": wall, "cpu_seconds": cpu,
            "rate": r.samples / r.seconds, "rate_call": r.samples / wall, "rate_cpu": r.samples / cpu,
            "estimate": r.estimate, "stderr": r.stderr, "lanes": r.lanes, "device": r.device}


def numpy_once(samples: int, chunk: int, seed: int) -> dict:
    """One timed NumPy run of the plain estimator."""
    run = NumpyPlainRun(numpy_integrand, DIM, EXACT, seed=seed, chunk=chunk)
    obs = run.run_samples(samples)
    return {"samples": obs.samples, "seconds": run.seconds, "cpu_seconds": run.cpu_seconds,
            "rate": obs.samples / run.seconds, "rate_cpu": obs.samples / run.cpu_seconds,
            "estimate": obs.estimate, "stderr": obs.stderr}


def main(argv: list[str] | None = None) -> int:
    """Measure and print; exit status 0 (the goal is reported, not enforced)."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--samples", type=count, default=10**8, help="engine samples per repeat (default 1e8)")
    ap.add_argument("--numpy-samples", type=count, default=10**8, help="NumPy samples per repeat (default 1e8)")
    ap.add_argument("--chunk", type=count, default=10**6, help="NumPy points per chunk (default 1e6)")
    ap.add_argument("--repeats", type=count, default=2, help="alternating repeats of each side (default 2)")
    ap.add_argument("--device", default=None, help="OpenCL device (index or name substring)")
    ap.add_argument("--lanes", type=int, default=None, help="kernel vector width override")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)

    warm = mcocl.integrate(INTEGRAND, DIM, 1 << 20, device=args.device, lanes=args.lanes)  # build the kernel
    engine, numpy_runs = [], []
    for i in range(args.repeats):
        engine.append(engine_once(args.samples, args.device, args.lanes, seed=1 + i))
        numpy_runs.append(numpy_once(args.numpy_samples, args.chunk, seed=1 + i))
        if not args.json:
            e, n = engine[-1], numpy_runs[-1]
            print(f"repeat {i + 1}: engine {e['rate'] / 1e6:8.1f} M/s   numpy {n['rate'] / 1e6:6.2f} M/s", file=sys.stderr)
    best_e = max(engine, key=lambda r: r["rate"])
    best_n = max(numpy_runs, key=lambda r: r["rate"])
    out = {
        "integrand": INTEGRAND, "dim": DIM, "exact": EXACT, "device": warm.device, "lanes": warm.lanes,
        "build_seconds": warm.build_seconds, "engine": engine, "numpy": numpy_runs,
        "engine_rate": best_e["rate"], "numpy_rate": best_n["rate"],
        "ratio": best_e["rate"] / best_n["rate"],
        "ratio_per_cpu_second": max(r["rate_cpu"] for r in engine) / max(r["rate_cpu"] for r in numpy_runs),
        "goal": GOAL,
    }
    if args.json:
        json.dump(out, sys.stdout, indent=2)
        print()
        return 0
    print(f"integrand  {INTEGRAND} over [0,1]^{DIM}, exact {EXACT:.10f}")
    print(f"device     {warm.device}, {warm.lanes} lanes (kernel build {warm.build_seconds:.2f} s, excluded)")
    print(f"engine     {best_e['samples']:.3g} samples in {best_e['seconds']:.3f} s: {best_e['rate'] / 1e6:.1f} M samples/s "
          f"({best_e['rate_cpu'] / 1e6:.1f} M per CPU-s; whole call incl. pilot {best_e['rate_call'] / 1e6:.1f} M/s); "
          f"estimate {best_e['estimate']:.9f} +- {best_e['stderr']:.2g}")
    print(f"numpy      {best_n['samples']:.3g} samples in {best_n['seconds']:.3f} s: {best_n['rate'] / 1e6:.2f} M samples/s "
          f"({best_n['rate_cpu'] / 1e6:.2f} M per CPU-s; float64, PCG64, chunks of {args.chunk}); "
          f"estimate {best_n['estimate']:.9f} +- {best_n['stderr']:.2g}")
    print(f"ratio      {out['ratio']:.1f}x wall-clock ({out['ratio_per_cpu_second']:.1f}x per CPU-second); "
          f"goal >= {GOAL:g}x: {'met' if out['ratio'] >= GOAL else 'NOT met'} (best of {args.repeats} repeats each)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
