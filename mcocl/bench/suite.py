"""What a bench suite is: problems, their estimators, and progressive runs.

The bench is generic over *suites* (``integrate``, ``solve``, ``render``); a
suite is a module that knows its problems.  The runner (:mod:`.runner`) only
sees these interfaces:

- a :class:`BenchProblem` has a name, a description and a list of named
  estimators, plus an optional NumPy baseline;
- an estimator is a factory of :class:`ProgressiveRun`, a run that can be
  advanced by a number of seconds and says after each step where it stands
  (an :class:`Observation`: cumulative seconds, samples, estimate, reported
  standard error and actual error against the problem's reference).

A new suite is a module with a ``SUITE`` object implementing :class:`Suite`,
registered in :data:`SUITE_MODULES`.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from ..errors import InputError

# Suite name -> module (relative to this package) defining ``SUITE``.  A suite
# whose module is missing is "not available in this build".
SUITE_MODULES = {
    "integrate": ".integrate_suite",
    "solve": ".solve_suite",
    "render": ".render_suite",
}


@dataclass
class Observation:
    """Where a progressive run stands (cumulative since its start).

    Attributes:
        seconds: sampling wall time so far (kernel builds excluded).
        samples: samples so far (integrand evaluations, walks, paths).
        estimate: the current estimate (a scalar; for images a summary).
        stderr: the standard error the estimator reports for itself.
        error: the actual error against the reference (signed for scalars,
            RMSE for images).
        nonfinite: NaN/Inf samples left out so far.
        stopped_by: why the last step ended (``time``, ``interrupt``, ...).
        points: independent estimates the scalar figures aggregate (query
            points, pixels; 1 for an integral): a sample contributes to one
            of them, so the variance per sample is stderr^2 * samples / points.
    """

    seconds: float
    samples: int
    estimate: float
    stderr: float
    error: float
    nonfinite: int = 0
    stopped_by: str = "time"
    points: int = 1


# progress callback: (seconds of this run so far) -> None
Tick = Callable[[float], None]


class ProgressiveRun(Protocol):
    """One estimator on one problem, run in steps."""

    def advance(self, seconds: float, tick: Tick | None = None) -> Observation:
        """Compute for about ``seconds`` more; return the cumulative state."""

    def close(self) -> None:
        """Release files and buffers."""


@dataclass
class EstimatorSpec:
    """A named estimator of a problem.

    Attributes:
        name: what tables and ``--estimators`` call it.
        start: builds the run (compiles kernels); may raise ``MCOCLError``.
        description: one line for the report.
        info: extra facts for the JSON summary (design sizes, proposals).
        kind: ``engine`` (mcocl's) or ``peer`` (another package's, timed alike).
    """

    name: str
    start: Callable[[], ProgressiveRun]
    description: str = ""
    info: dict[str, Any] = field(default_factory=dict)
    kind: str = "engine"


@dataclass
class BaselineSpec:
    """The NumPy baseline of a problem, or why there is none."""

    start: Callable[[], ProgressiveRun] | None
    description: str = ""
    unavailable: str = ""


class BenchProblem(Protocol):
    """A problem with a known reference."""

    name: str
    description: str

    def estimators(self) -> list[EstimatorSpec]:
        """Every estimator this problem offers, in table order."""

    def baseline(self) -> BaselineSpec:
        """The NumPy version of the plain estimator (or the reason there is none)."""

    def unavailable(self) -> list[tuple[str, str]]:
        """Optional: (estimator, why it cannot run here) for estimators left out (a peer's missing package)."""

    def summary(self) -> dict[str, Any]:
        """JSON facts about the problem (dimension, reference value, ...)."""


@dataclass
class BenchOptions:
    """What the user asked of a bench run (suites read what applies to them).

    Attributes:
        quick: the small fast subset (a few seconds in all).
        seed: seed of every estimator.
        device: OpenCL device spec (``mcocl devices``).
        lanes: kernel vector width override.
        problem_files: users' problem files (replace the built-in problems).
        only: names (or shell patterns) of built-in problems to run.
        inputs: positional inputs of the suite (the scene of ``render``).
        reference: a reference file given by the user (``render``).
        reference_seconds: time for a reference the bench renders itself
            (``render``; default 8x the budget).
        reference_integrator: the integrator of that reference (``render``;
            ``mis`` by default; ``bdpt`` where only it resolves a caustic).
        cache_dir: where references computed by the bench are cached.
        budget: seconds per estimator (set by :func:`mcocl.bench.run_bench`).
        peers: also run other packages' integrators (``integrate``: scipy's
            scrambled Sobol' and the ``vegas`` package, with mcocl's ``sobol``
            and ``vegas`` samplers beside them).
    """

    quick: bool = False
    seed: int = 1
    device: Any = None
    lanes: int | None = None
    problem_files: list[str] = field(default_factory=list)
    only: list[str] | None = None
    inputs: list[str] = field(default_factory=list)
    reference: str | None = None
    reference_seconds: float | None = None
    reference_integrator: str = "mis"
    cache_dir: str | None = None
    budget: float | None = None
    peers: bool = False


class Suite(Protocol):
    """A family of problems."""

    name: str
    error_kind: str  # "signed" (scalar error) or "rmse" (over query points or pixels)
    reference_estimator: str  # the plain estimator others are compared with (and NumPy against)

    def problems(self, options: BenchOptions) -> list[BenchProblem]:
        """The problems to run (a small fast subset when ``options.quick``).

        Raises:
            InputError: a bad problem file or selection; the message names
                the problem and the field.
        """


def load_suite(name: str) -> Suite:
    """The suite called ``name``.

    Raises:
        InputError: unknown suite, or one not available in this build.
    """
    if name not in SUITE_MODULES:
        raise InputError(f"unknown bench suite {name!r}; choose one of {', '.join(SUITE_MODULES)}")
    try:
        mod = importlib.import_module(SUITE_MODULES[name], __package__)
    except ModuleNotFoundError as e:
        if e.name and e.name.endswith(SUITE_MODULES[name].lstrip(".")):
            raise InputError(f"the {name!r} bench suite is not available in this build") from None
        raise
    return mod.SUITE


def available_suites() -> list[str]:
    """Names of the suites whose modules exist."""
    out = []
    for name in SUITE_MODULES:
        try:
            load_suite(name)
        except InputError:
            continue
        out.append(name)
    return out


def select_estimators(specs: Sequence[EstimatorSpec], wanted: Sequence[str] | None) -> tuple[list[EstimatorSpec], list[str]]:
    """The specs named in ``wanted`` (all when None), and the names this problem lacks."""
    if wanted is None:
        return list(specs), []
    by_name = {s.name: s for s in specs}
    return [by_name[w] for w in wanted if w in by_name], [w for w in wanted if w not in by_name]
