"""Progressive runs of every estimator of every problem, with checkpoints.

Each (problem, estimator) pair runs for the time budget in steps that end at
geometrically spaced times (budget/512, budget/256, ..., budget); after each
step the run's cumulative state is recorded: seconds, samples, estimate,
reported standard error and actual error.  From the last checkpoint the
bench derives what the table shows:

- variance per sample  V = stderr^2 * samples, the estimator's *honest*
  variance (for stratified and N-rooks designs the variance of the design
  means, not the plain sample variance of f; see ``mcocl.integrate``);
- efficiency  1 / (V * seconds per sample) = 1 / (stderr^2 * seconds), the
  inverse of the work needed for unit variance (lecture: an estimator is
  better when variance x cost is smaller), relative to ``independent``;
- the cross-check of V against the actual error: z = error / stderr at the
  end (consistent when |z| <= 4) and z_rms, the root mean square of z over
  the checkpoints from 1/16 of the run on (about 1 when stderr is honest;
  far below 1 when it overstates the error, far above when it understates
  it; the checkpoints are nested, so it is a coarse, noisy check).
"""

from __future__ import annotations

import math
import platform
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from ..errors import MCOCLError
from .status import BenchStatus
from .suite import BenchOptions, BenchProblem, Observation, ProgressiveRun, Suite, select_estimators

Z_CONSISTENT = 4.0
FIRST_CHECKPOINT = 0.01  # seconds
MIN_STEP = 0.002  # seconds


def checkpoint_times(budget: float, first: float = FIRST_CHECKPOINT) -> list[float]:
    """Times (cumulative seconds) at which a run of ``budget`` seconds is observed.

    Doubling from about ``first`` up to ``budget``, at least three of them.
    """
    k = max(int(math.floor(math.log2(budget / first))), 2) if budget > first else 2
    return [budget / 2**j for j in range(k, -1, -1)]


@dataclass
class EstimatorRecord:
    """One estimator's run on one problem: its checkpoints and what follows from them."""

    name: str
    description: str = ""
    kind: str = "engine"  # "engine", "numpy" or "peer"
    checkpoints: list[Observation] = field(default_factory=list)
    info: dict[str, Any] = field(default_factory=dict)
    failed: str = ""
    interrupted: bool = False

    @property
    def final(self) -> Observation | None:
        """The last checkpoint."""
        return self.checkpoints[-1] if self.checkpoints else None

    @property
    def samples(self) -> int:
        """Samples at the end."""
        return self.final.samples if self.final else 0

    @property
    def seconds(self) -> float:
        """Sampling seconds at the end."""
        return self.final.seconds if self.final else math.nan

    @property
    def samples_per_second(self) -> float:
        """Throughput."""
        f = self.final
        return f.samples / f.seconds if f and f.seconds > 0 else math.nan

    @property
    def stderr(self) -> float:
        """Reported standard error at the end."""
        return self.final.stderr if self.final else math.nan

    @property
    def error(self) -> float:
        """Actual error at the end."""
        return self.final.error if self.final else math.nan

    @property
    def variance_per_sample(self) -> float:
        """stderr^2 * samples / points: the honest variance of one sample's contribution."""
        f = self.final
        return f.stderr**2 * f.samples / f.points if f else math.nan

    @property
    def efficiency(self) -> float:
        """1 / (variance per sample * seconds per sample) = points / (stderr^2 * seconds)."""
        return self._efficiency(self.final.stderr if self.final else math.nan)

    @property
    def z(self) -> float:
        """error / stderr at the end."""
        f = self.final
        if not f or not math.isfinite(f.error) or not math.isfinite(f.stderr):
            return math.nan
        if f.stderr == 0:
            return 0.0 if f.error == 0 else math.copysign(math.inf, f.error)
        return f.error / f.stderr

    @property
    def consistent(self) -> bool | None:
        """|error| <= 4 stderr at the end (None when there is nothing to judge)."""
        z = self.z
        return None if math.isnan(z) else bool(abs(z) <= Z_CONSISTENT)

    @property
    def efficiency_from_error(self) -> float:
        """points / (error^2 * seconds): the efficiency the actual error implies (noisy; the cross-check)."""
        return self._efficiency(self.final.error if self.final else math.nan)

    def _efficiency(self, spread: float) -> float:
        """points / (spread^2 * seconds) at the end, for spread = the stderr or the actual error."""
        f = self.final
        if not f or not f.seconds > 0 or not math.isfinite(spread):
            return math.nan
        w = spread**2 * f.seconds / f.points
        return 1.0 / w if w > 0 else math.inf

    @property
    def z_rms(self) -> float:
        """Root mean square of error/stderr over the later checkpoints (about 1 when stderr is honest).

        Checkpoints before 1/16 of the run are left out: there a design-based
        stderr rests on a handful of designs (two at first: a t distribution
        with one degree of freedom, whose z has no finite variance).
        """
        f = self.final
        start = f.seconds / 16 if f else 0.0
        zs = [c.error / c.stderr for c in self.checkpoints
              if c.seconds >= start and math.isfinite(c.error) and math.isfinite(c.stderr) and c.stderr > 0]
        return math.sqrt(sum(z * z for z in zs) / len(zs)) if zs else math.nan

    @property
    def nonfinite(self) -> int:
        """NaN/Inf samples left out."""
        return self.final.nonfinite if self.final else 0


@dataclass
class ProblemRecord:
    """Every estimator's record on one problem."""

    name: str
    description: str
    summary: dict[str, Any]
    estimators: list[EstimatorRecord] = field(default_factory=list)
    skipped: list[tuple[str, str]] = field(default_factory=list)
    baseline_unavailable: str = ""
    reference: str = "independent"

    def get(self, name: str) -> EstimatorRecord | None:
        """The record of an estimator (``numpy`` for the baseline), if it ran."""
        for e in self.estimators:
            if e.name == name and e.final is not None and not e.failed:
                return e
        return None

    def relative_efficiency(self, e: EstimatorRecord) -> float:
        """Efficiency of ``e`` over that of the reference estimator (NaN without it)."""
        ref = self.get(self.reference)
        if ref is None or not math.isfinite(ref.efficiency) or ref.efficiency <= 0:
            return math.nan
        return e.efficiency / ref.efficiency

    @property
    def numpy_speedup(self) -> float:
        """Samples/s of the engine's reference estimator over the NumPy baseline's (the same estimator)."""
        ind, base = self.get(self.reference), self.get("numpy")
        if ind is None or base is None:
            return math.nan
        return ind.samples_per_second / base.samples_per_second


@dataclass
class BenchResult:
    """A whole bench run."""

    suite: str
    budget: float
    options: BenchOptions
    problems: list[ProblemRecord] = field(default_factory=list)
    started: str = ""
    wall_seconds: float = 0.0
    interrupted: bool = False
    error_kind: str = "signed"
    reference: str = "independent"

    @property
    def failures(self) -> list[tuple[str, str, str]]:
        """(problem, estimator, message) of every run that failed."""
        return [(p.name, e.name, e.failed) for p in self.problems for e in p.estimators if e.failed]

    @property
    def device(self) -> str:
        """The OpenCL device the engine ran on (from the first engine record)."""
        for p in self.problems:
            for e in p.estimators:
                if e.info.get("device"):
                    return str(e.info["device"])
        return ""

    def machine(self) -> dict[str, Any]:
        """Where it ran."""
        import os

        return {"host": platform.node(), "platform": platform.platform(), "python": platform.python_version(),
                "cpus": os.cpu_count(), "device": self.device}


class BenchInterruptedError(Exception):
    """Ctrl-C during a run: the bench stops and reports what it has."""


def run_progressive(run: ProgressiveRun, rec: EstimatorRecord, budget: float, status: BenchStatus | None) -> None:
    """Advance ``run`` through the checkpoint times, appending to ``rec.checkpoints``.

    Raises:
        BenchInterruptedError: after recording the step that Ctrl-C cut short.
    """
    times = checkpoint_times(budget)
    done = 0.0
    tick = status.tick if status is not None else None
    for t in times:
        if done >= t - MIN_STEP / 2:
            continue  # an earlier step overshot this checkpoint
        try:
            obs = run.advance(max(t - done, MIN_STEP), tick)
        except KeyboardInterrupt:
            rec.interrupted = True
            raise BenchInterruptedError from None
        rec.checkpoints.append(obs)
        done = obs.seconds
        if obs.stopped_by == "interrupt":
            rec.interrupted = True
            raise BenchInterruptedError


def _run_one(start: Any, rec: EstimatorRecord, budget: float, status: BenchStatus | None) -> None:
    run = None
    try:
        run = start()
        run_progressive(run, rec, budget, status)
    except MCOCLError as e:
        rec.failed = str(e)
    except KeyboardInterrupt:  # outside a sampling step (building, starting): stop, keep what was done
        rec.interrupted = True
        raise BenchInterruptedError from None
    finally:
        if run is not None:
            info = getattr(run, "info", None)
            if callable(info):
                rec.info.update(info())
            run.close()


def relative_to(plain: str, chosen: Sequence[str]) -> str:
    """The estimator relative efficiencies are taken against: the suite's plain one, or, when the chosen
    ones leave it out (``bench render --integrators mis lt bdpt``), the first one chosen."""
    return plain if plain in chosen or not chosen else chosen[0]


def run_suite(suite: Suite, problems: Sequence[BenchProblem], budget: float, options: BenchOptions,
              estimators: Sequence[str] | None = None, baseline: bool = True, status: BenchStatus | None = None) -> BenchResult:
    """Run every selected estimator (and the NumPy baseline) of every problem for ``budget`` seconds each.

    Args:
        suite: the suite (for its name and error kind).
        problems: the problems, in order.
        budget: sampling seconds per estimator.
        options: recorded in the result.
        estimators: names to run (None: all each problem offers); names a
            problem lacks are recorded in its ``skipped`` list with the reason.
        baseline: also time the NumPy baseline.
        status: progress display.

    Returns:
        the :class:`BenchResult`; an interrupted bench returns what it has
        with ``interrupted`` set.
    """
    t0 = time.perf_counter()
    result = BenchResult(suite.name, budget, options, started=time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                         error_kind=suite.error_kind, reference=suite.reference_estimator)
    plan: list[tuple[BenchProblem, ProblemRecord, list[Any]]] = []
    for prob in problems:
        chosen, missing = select_estimators(prob.estimators(), estimators)
        reference = relative_to(suite.reference_estimator, [s.name for s in chosen])
        if not result.problems:
            result.reference = reference
        rec = ProblemRecord(prob.name, prob.description, prob.summary(), reference=reference)
        rec.skipped = [(m, f"not an estimator of {prob.name} (it offers {', '.join(s.name for s in prob.estimators())})")
                       for m in missing]
        # optional: only problems with peers (integrate) have estimators that can be unavailable
        unavailable = getattr(prob, "unavailable", list)()
        rec.skipped += [(n, why) for n, why in unavailable if estimators is None or n in estimators]
        runs: list[Any] = [(s.name, s.description, s.kind, s.start) for s in chosen]
        if baseline:
            b = prob.baseline()
            if b.start is None:
                rec.baseline_unavailable = b.unavailable
            else:
                runs.append(("numpy", b.description, "numpy", b.start))
        plan.append((prob, rec, runs))
        result.problems.append(rec)
    total = sum(len(r) for _, _, r in plan)
    if status is not None:
        status.begin(total, budget)
    try:
        for prob, rec, runs in plan:
            for name, description, kind, start in runs:
                er = EstimatorRecord(name, description, kind)
                rec.estimators.append(er)
                if status is not None:
                    status.start_run(prob.name, name)
                _run_one(start, er, budget, status)
                if status is not None:
                    status.end_run(er)
    except BenchInterruptedError:
        result.interrupted = True
    finally:
        if status is not None:
            status.close()
    result.wall_seconds = time.perf_counter() - t0
    return result
