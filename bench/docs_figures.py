"""Regenerate the bench tables and plots that the README shows (``docs/bench/``).

One command, best run on a quiet machine (every figure is a timing)::

    python bench/docs_figures.py                    # integrate and solve, 5 s per estimator
    python bench/docs_figures.py --budget 10 --render-budget 60

It runs ``mcocl bench integrate`` and ``mcocl bench solve`` (and ``mcocl bench
render SCENE`` when the render suite and the scene exist) with ``--out
docs/bench``, which leaves there, per suite, the table (``*-table.txt``), the
checkpoints (``*-checkpoints.csv``), the summary (``*-summary.json``) and the
plots (``*-error-vs-time.png``, ``*-efficiency.png``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mcocl.bench.suite import available_suites
from mcocl.cli import main as mcocl_main

ROOT = Path(__file__).resolve().parent.parent


def main(argv: list[str] | None = None) -> int:
    """Run the suites into the docs folder; return the worst exit status."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--budget", default="5", help="seconds per estimator for integrate and solve (default 5)")
    ap.add_argument("--render-budget", default="30", help="seconds per integrator for render (default 30)")
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "veach_mis.json"), help="scene of the render suite")
    ap.add_argument("--out", default=str(ROOT / "docs" / "bench"), help="output folder (default docs/bench)")
    ap.add_argument("--device", default=None, help="OpenCL device")
    ap.add_argument("--cache", default=str(ROOT / "bench-out" / "cache"),
                    help="cache of rendered references, kept out of docs/ (default bench-out/cache)")
    args = ap.parse_args(argv)

    extra = ["--device", args.device] if args.device else []
    suites = available_suites()
    status = 0
    for suite in ("integrate", "solve"):
        if suite in suites:
            status = max(status, mcocl_main(["bench", suite, "--budget", args.budget, "--out", args.out, *extra]))
    if "render" in suites and Path(args.scene).exists():
        status = max(status, mcocl_main(["bench", "render", args.scene, "--budget", args.render_budget,
                                         "--out", args.out, "--cache", args.cache, *extra]))
    elif "render" in suites:
        print(f"render suite skipped: no scene at {args.scene}", file=sys.stderr)
    print(f"figures in {args.out}", file=sys.stderr)
    return status


if __name__ == "__main__":
    sys.exit(main())
