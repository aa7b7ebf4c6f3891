"""Random walks per second of ``mcocl.solve_fredholm`` against vectorised NumPy, in one process (issue 3).

The problem is the issue's example, f = g + ∫ K f on [0, 1] with
K = (x + y)/2, g = x^2 - x/6 - 1/8 (exact f = x^2), at x = 0.1, 0.5, 0.9.
Both sides run the same ``roulette`` walk: uniform moves, weight
W <- W K(x, y), survival P = min(1, |W|), W <- W / P, value sum W g.

- engine: ``solve_fredholm(..., estimator="roulette")``, after a warm-up
  that builds the kernel; ``--walks`` walks per point;
- NumPy: the same walk in float64 with ``Generator(PCG64)``, all walks of a
  chunk advanced together, the finished ones dropped by compaction each
  step (``numpy_roulette`` below).

The two alternate ``--repeats`` times so that both see the same machine load;
the best repeat of each is reported, as walks/s of wall time (the ratio) and
walks per CPU-second of the process (PoCL's threads are in the process;
steadier on a shared machine).  ``--lanes 1 8 16`` also times the engine at
each lane width, and ``--estimators`` the other estimators.  Goal: >= 20x.

    python bench/walk_throughput.py
    python bench/walk_throughput.py --walks 1e7 --numpy-walks 1e6 --repeats 3 --lanes 1 8 16
    python bench/walk_throughput.py --estimators roulette subcritical nee --json
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

import mcocl
from mcocl.cli.common import count

KERNEL = "0.5f*(x[0] + y[0])"
SOURCE = "x[0]*x[0] - x[0]/6.0f - 0.125f"
AT = (0.1, 0.5, 0.9)
GOAL = 20.0


def k_np(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """K(x, y) = (x + y) / 2."""
    return 0.5 * (x + y)


def g_np(x: np.ndarray) -> np.ndarray:
    """g(x) = x^2 - x/6 - 1/8."""
    return x * x - x / 6.0 - 0.125


def numpy_roulette(x0: float, walks: int, rng: np.random.Generator, chunk: int) -> tuple[float, float, float]:
    """The roulette walk in NumPy: (mean, stderr, mean walk length) at x0."""
    s1 = s2 = moves = 0.0
    done = 0
    while done < walks:
        n = min(chunk, walks - done)
        value = np.full(n, g_np(np.float64(x0)))
        idx = np.arange(n)
        x = np.full(n, x0)
        w = np.ones(n)
        while idx.size:
            y = rng.random(idx.size)
            u = rng.random(idx.size)
            wn = w * k_np(x, y)
            p = np.minimum(1.0, np.abs(wn))
            live = u < p
            idx, y, w = idx[live], y[live], wn[live] / p[live]
            value[idx] += w * g_np(y)
            x = y
            moves += idx.size
        s1 += value.sum()
        s2 += (value * value).sum()
        done += n
    mean = s1 / walks
    var = (s2 - s1 * s1 / walks) / (walks - 1)
    return mean, float(np.sqrt(var / walks)), moves / walks


def numpy_once(walks: int, chunk: int, seed: int) -> dict:
    """One timed NumPy run at every point."""
    rng = np.random.Generator(np.random.PCG64(seed))
    c0, t0 = time.process_time(), time.perf_counter()
    res = [numpy_roulette(x0, walks, rng, chunk) for x0 in AT]
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    n = walks * len(AT)
    return {"walks": n, "seconds": wall, "cpu_seconds": cpu, "rate": n / wall, "rate_cpu": n / cpu,
            "values": [r[0] for r in res], "stderr": [r[1] for r in res],
            "mean_walk_length": float(np.mean([r[2] for r in res]))}


def engine_once(walks: int, estimator: str, lanes: int | None, device: object, seed: int) -> dict:
    """One timed ``solve_fredholm`` run."""
    c0 = time.process_time()
    r = mcocl.solve_fredholm(KERNEL, SOURCE, at=[[a] for a in AT], walks=walks, estimator=estimator, seed=seed,
                             lanes=lanes, device=device)
    cpu = time.process_time() - c0
    n = r.walks * len(AT)
    return {"walks": n, "seconds": r.seconds, "cpu_seconds": cpu, "rate": n / r.seconds, "rate_cpu": n / cpu,
            "values": r.values.tolist(), "stderr": r.stderr.tolist(), "mean_walk_length": r.mean_walk_length,
            "lanes": r.lanes, "device": r.device, "estimator": estimator}


def main(argv: list[str] | None = None) -> int:
    """Measure and print; exit status 0 (the goal is reported, not enforced)."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--walks", type=count, default=10**7, help="engine walks per point per repeat (default 1e7)")
    ap.add_argument("--numpy-walks", type=count, default=10**6, help="NumPy walks per point per repeat (default 1e6)")
    ap.add_argument("--chunk", type=count, default=1 << 20, help="NumPy walks advanced together (default 2^20)")
    ap.add_argument("--repeats", type=count, default=2, help="alternating repeats of each side (default 2)")
    ap.add_argument("--lanes", type=int, nargs="+", default=[0], help="engine lane widths to time (0: the default)")
    ap.add_argument("--estimators", nargs="+", default=["roulette"], choices=("truncated", "roulette", "subcritical", "nee"),
                    help="engine estimators to time (the ratio uses roulette)")
    ap.add_argument("--device", default=None, help="OpenCL device (index or name substring)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)

    configs = [(e, lanes or None) for e in args.estimators for lanes in args.lanes]
    for est, lanes in configs:  # warm-up: build every kernel before timing
        mcocl.solve_fredholm(KERNEL, SOURCE, at=[[a] for a in AT], walks=1 << 14, estimator=est, lanes=lanes,
                             device=args.device)
    engine: dict[str, list[dict]] = {f"{e}/{lanes or 'default'}": [] for e, lanes in configs}
    numpy_runs: list[dict] = []
    for i in range(args.repeats):
        for est, lanes in configs:
            engine[f"{est}/{lanes or 'default'}"].append(engine_once(args.walks, est, lanes, args.device, seed=1 + i))
        numpy_runs.append(numpy_once(args.numpy_walks, args.chunk, seed=1 + i))
        if not args.json:
            line = "   ".join(f"{k} {v[-1]['rate'] / 1e6:.2f}" for k, v in engine.items())
            print(f"repeat {i + 1} (M walks/s): {line}   numpy {numpy_runs[-1]['rate'] / 1e6:.3f}", file=sys.stderr)
    best = {k: max(v, key=lambda r: r["rate"]) for k, v in engine.items()}
    best_n = max(numpy_runs, key=lambda r: r["rate"])
    best_n_cpu = max(r["rate_cpu"] for r in numpy_runs)
    roulette = [k for k in best if k.startswith("roulette/")]
    ratio = max(best[k]["rate"] for k in roulette) / best_n["rate"] if roulette else None
    ratio_cpu = max(max(r["rate_cpu"] for r in engine[k]) for k in roulette) / best_n_cpu if roulette else None
    out = {"kernel": KERNEL, "source": SOURCE, "at": AT, "engine": engine, "numpy": numpy_runs,
           "best": {k: {"rate": v["rate"], "rate_cpu": max(r["rate_cpu"] for r in engine[k]), "lanes": v["lanes"],
                        "mean_walk_length": v["mean_walk_length"]} for k, v in best.items()},
           "numpy_rate": best_n["rate"], "numpy_rate_cpu": best_n_cpu,
           "ratio": ratio, "ratio_per_cpu_second": ratio_cpu, "goal": GOAL}
    if args.json:
        json.dump(out, sys.stdout, indent=2)
        print()
        return 0
    print(f"problem    K = {KERNEL}, g = {SOURCE}, at x = {AT} (exact f = x^2)")
    for k, v in best.items():
        print(f"engine     {k:22s} {v['rate'] / 1e6:8.2f} M walks/s ({out['best'][k]['rate_cpu'] / 1e6:.2f} M per CPU-s), "
              f"{v['lanes']} lanes, mean length {v['mean_walk_length']:.3f}, "
              f"values {np.round(v['values'], 5).tolist()} +- {np.round(v['stderr'], 5).tolist()}")
    print(f"numpy      roulette float64/PCG64   {best_n['rate'] / 1e6:8.3f} M walks/s ({best_n_cpu / 1e6:.3f} M per CPU-s), "
          f"mean length {best_n['mean_walk_length']:.3f}, values {np.round(best_n['values'], 5).tolist()}")
    if ratio is not None:
        print(f"ratio      {ratio:.1f}x wall-clock ({ratio_cpu:.1f}x per CPU-second), roulette; "
              f"goal >= {GOAL:g}x: {'met' if ratio >= GOAL else 'NOT met'} (best of {args.repeats} repeats each)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
