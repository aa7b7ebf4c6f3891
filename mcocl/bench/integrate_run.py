"""A progressive run of ``mcocl.integrate``: checkpoints by save and resume.

The bench needs the state of a run at several times (seconds, samples,
estimate, standard error).  ``mcocl.integrate`` is called repeatedly, saving
its accumulator to a checkpoint file and resuming from it on the next call.
A resumed run gives the same statistics as an uninterrupted one (the
accumulator folds blocks in index order), so the checkpoints of this run are
exactly those of one long run; the cost of a step is a file save and load
(about 3-4 ms measured), and the kernel is built once (the runtime caches
programs).

Each step asks for a *sample count*, not a time: the count that the measured
throughput says fills the step's seconds, rounded to whole blocks (64 Ki
points) or whole designs so that every step ends on a boundary a resume
accepts.  (Asking for short times instead makes the scheduler, which keeps
0.15 s per in-flight chunk in reserve, run one block per chunk: 10x slower
for steps under about 0.3 s.)  A time limit of a few times the step stays as
a safety net when the machine suddenly slows down.
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
import warnings
from typing import Any

from ..engine.contract import Progress
from ..integration import IntegrationResult, NonFiniteWarning, integrate
from .suite import Observation, Tick

# samples of the independent sampler's smallest step: a multiple of its
# kernel block (4096 units) for every number of points per unit
INDEPENDENT_GRANULE = 1 << 16


class IntegrationRun:
    """One estimator of ``mcocl.integrate`` on one integrand, advanced in steps.

    Args:
        expression: the OpenCL C integrand.
        dim: its dimension.
        exact: the exact integral.
        options: keyword arguments of :func:`mcocl.integrate` that make the
            estimator (``sampler``, ``proposal``, ``proposals``, ...).
        seed, device, lanes: as for :func:`mcocl.integrate`.
    """

    def __init__(self, expression: str, dim: int, exact: float, options: dict[str, Any], seed: int = 1,
                 device: Any = None, lanes: int | None = None) -> None:
        self.expression = expression
        self.dim = dim
        self.exact = exact
        self.options = dict(options)
        self.seed = seed
        self.device = device
        self.lanes = lanes
        self._dir = tempfile.mkdtemp(prefix="mcocl-bench-")
        self.checkpoint = os.path.join(self._dir, "run.ckpt")
        self.seconds = 0.0
        self.last: IntegrationResult | None = None
        self.build_seconds = 0.0
        self.granule = 1

    def _points(self) -> int:
        """Integrand evaluations per unit (one per proposal sample of a combined estimator)."""
        props = self.options.get("proposals")
        if not props or len(props) < 2:
            return 1
        shares = self.options.get("shares")
        return int(sum(shares)) if shares else len(props)

    def _call(self, samples: int, time_cap: float, tick: Tick | None) -> IntegrationResult:
        before = self.seconds

        def progress(p: Progress) -> None:
            if tick is not None:
                tick(before + p.elapsed)

        kw: dict[str, Any] = dict(self.options)
        if self.last is not None:
            kw["resume"] = self.checkpoint
        with warnings.catch_warnings():
            # counted in the result and reported by the bench; not a warning per step
            warnings.simplefilter("ignore", NonFiniteWarning)
            return integrate(self.expression, self.dim, samples, seed=self.seed, time_budget=time_cap,
                             device=self.device, lanes=self.lanes, checkpoint=self.checkpoint,
                             progress=progress, **kw)

    def advance(self, seconds: float, tick: Tick | None = None) -> Observation:
        """Sample for about ``seconds`` more (at least one block or design)."""
        if self.last is None:
            sampler = self.options.get("sampler", "independent")
            # independent: one 64 Ki-unit step is whole blocks; designs: one (two for nrooks)
            first = INDEPENDENT_GRANULE * self._points() if sampler == "independent" else 1
            r = self._call(first, max(4 * seconds, 1.0), tick)
            self.granule = first if sampler == "independent" else max(r.samples // max(r.designs, 1), 1)
        else:
            rate = self.last.samples / self.seconds if self.seconds > 0 else 0.0
            want = rate * seconds
            steps = max(int(math.ceil(want / self.granule)), 1)
            r = self._call(self.last.samples + steps * self.granule, max(4 * seconds, 1.0), tick)
        self.last = r
        self.seconds += r.seconds
        self.build_seconds += r.build_seconds
        est, se = float(r.estimate), float(r.stderr)
        err = est - self.exact if math.isfinite(est) else math.nan
        return Observation(self.seconds, int(r.samples), est, se, err, int(r.nonfinite), r.stopped_by)

    def info(self) -> dict[str, Any]:
        """Facts about the estimator from its last result (for the JSON summary)."""
        r = self.last
        if r is None:
            return {}
        return {"estimator": r.estimator, "variance_method": r.variance_method, "lanes": r.lanes,
                "designs": r.designs, "device": r.device, "build_seconds": self.build_seconds, "notes": list(r.notes)}

    def close(self) -> None:
        """Remove the checkpoint file."""
        shutil.rmtree(self._dir, ignore_errors=True)


class RestartedRun:
    """An estimator of ``mcocl.integrate`` that cannot be resumed in steps, rerun for each checkpoint.

    Each step runs afresh with ``time_budget`` = the checkpoint's cumulative
    seconds (``sampler="vegas"``: its iterations are sized from the time it
    is given, so a run of T seconds is not the first part of one of 2T), so
    every checkpoint is what a run of that many seconds gives.  The bench
    spends about twice the budget on it; the table's seconds are the last run's.

    Args: as :class:`IntegrationRun`.
    """

    def __init__(self, expression: str, dim: int, exact: float, options: dict[str, Any], seed: int = 1,
                 device: Any = None, lanes: int | None = None) -> None:
        self.expression = expression
        self.dim = dim
        self.exact = exact
        self.options = dict(options)
        self.seed = seed
        self.device = device
        self.lanes = lanes
        self.seconds = 0.0
        self.last: IntegrationResult | None = None
        self.build_seconds = 0.0

    def advance(self, seconds: float, tick: Tick | None = None) -> Observation:
        """A fresh run of (the seconds so far + ``seconds``)."""
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NonFiniteWarning)
            r = integrate(self.expression, self.dim, None, seed=self.seed, time_budget=self.seconds + seconds,
                          device=self.device, lanes=self.lanes, **self.options)
        if tick is not None:
            tick(r.seconds)
        self.last = r
        self.seconds = r.seconds
        self.build_seconds += r.build_seconds
        return self._observe(r)

    def _observe(self, r: IntegrationResult) -> Observation:
        """The checkpoint a finished run gives."""
        est, se = float(r.estimate), float(r.stderr)
        err = est - self.exact if math.isfinite(est) else math.nan
        return Observation(float(r.seconds), int(r.samples), est, se, err, int(r.nonfinite), r.stopped_by)

    def info(self) -> dict[str, Any]:
        """Facts about the estimator from its last result (for the JSON summary)."""
        r = self.last
        if r is None:
            return {}
        return {"estimator": r.estimator, "variance_method": r.variance_method, "lanes": r.lanes,
                "device": r.device, "build_seconds": self.build_seconds, "notes": list(r.notes)}

    def close(self) -> None:
        """Nothing to release."""


class DoublingRun(RestartedRun):
    """A randomised QMC estimator of ``mcocl.integrate`` (``sampler="sobol"``), rerun with doubled samples.

    Each replicate's error falls faster than 1/sqrt(points) only when its
    points grow, but resuming adds replicates of a fixed size; so each step
    runs afresh with the sample count doubled while the run is expected to
    end within 1.5x the checkpoint's cumulative seconds (the rate measured
    on the last run), as scipy-sobol's replicates double
    (:class:`mcocl.bench.integrate_peers.ScipySobolRun`).  Each checkpoint is
    then a whole run of R x 2^m samples; the bench spends about twice the
    budget on it.
    """

    FIRST_SAMPLES = 16 << 10
    SLACK = 1.5

    def advance(self, seconds: float, tick: Tick | None = None) -> Observation:
        """The largest doubling of the last run's samples that fits, run afresh (the last state if none fits)."""
        target = self.seconds + seconds
        r = self.last
        n = self.FIRST_SAMPLES if r is None else int(r.samples)
        if r is not None:
            rate = r.samples / r.seconds if r.seconds > 0 else math.inf
            grown = n
            while 2 * grown / rate <= self.SLACK * target:
                grown *= 2
            if grown == n:
                return self._observe(r)
            n = grown
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NonFiniteWarning)
            r = integrate(self.expression, self.dim, n, seed=self.seed, device=self.device, lanes=self.lanes,
                          **self.options)
        if tick is not None:
            tick(r.seconds)
        self.last = r
        self.seconds = r.seconds
        self.build_seconds += r.build_seconds
        return self._observe(r)
