"""``mcocl bench``: which estimator buys the most accuracy per second, measured.

For each problem of a suite and each of its estimators the bench runs for a
time budget, records checkpoints (seconds, samples, estimate, reported
standard error, actual error), and reports variance per sample, efficiency
(1 / (variance per sample x seconds per sample)) relative to independent
sampling, whether the actual error agrees with the reported standard error,
and the engine's speed-up over a vectorised NumPy version of the plain
estimator timed in the same process.

Modules: :mod:`.suite` (the plug-in interface), :mod:`.runner` (progressive
runs), :mod:`.report` (table, CSV, JSON), :mod:`.plots` (PNG),
:mod:`.integrate_suite` and :mod:`.problems` (integration problems),
:mod:`.numpy_baseline`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ..errors import InputError
from .runner import BenchResult, run_suite
from .status import BenchStatus
from .suite import BenchOptions, available_suites, load_suite

__all__ = ["BenchOptions", "BenchResult", "available_suites", "run_bench"]


def run_bench(suite: str, budget: float, options: BenchOptions | None = None,
              estimators: Sequence[str] | None = None, out: str | Path | None = None, plots: bool = True,
              baseline: bool = True, status: BenchStatus | bool = False) -> tuple[BenchResult, dict[str, Path]]:
    """Run a bench suite and (when ``out`` is given) write its files.

    Args:
        suite: ``integrate``, ``solve`` or ``render``.
        budget: sampling seconds per estimator and problem.
        options: what to run (problems, seed, device, quick subset).
        estimators: estimator names to run (None: every one a problem offers).
        out: folder for the table, CSV, JSON and PNG files.
        plots: draw the PNG figures (needs matplotlib).
        baseline: time the NumPy baseline too.
        status: a :class:`BenchStatus`, or True for one on stderr.

    Returns:
        (the result, the written files by kind).

    Raises:
        InputError: bad problem files or selections (before anything runs).
        PlottingUnavailableError: plots requested without matplotlib (the other
            files are written first).
    """
    from .report import write_reports

    options = options or BenchOptions()
    options.budget = budget
    s = load_suite(suite)
    problems = s.problems(options)
    if estimators is not None:
        offered = {e.name for prob in problems for e in prob.estimators()}
        # a peer whose package is missing is skipped with the reason, not an unknown name
        offered |= {n for prob in problems for n, _ in getattr(prob, "unavailable", list)()}
        unknown = [e for e in estimators if e not in offered]
        if unknown:
            raise InputError(f"--estimators: no problem offers {unknown}; offered: {', '.join(sorted(offered))}")
    if status is True:
        status = BenchStatus(f"bench {suite}")
    result = run_suite(s, problems, budget, options, estimators, baseline, status or None)
    files: dict[str, Path] = {}
    if out is not None:
        files.update(write_reports(result, out))
        if plots:
            from .plots import write_plots

            files.update(write_plots(result, out))
    return result, files
