"""The integration bench's peers: scipy's scrambled Sobol' and the ``vegas`` package (``--peers``).

A user who does not pick mcocl would pick one of these two, so
``mcocl bench integrate --peers`` times them on the same problems, in the
same process and for the same wall time as the engine's estimators, and
prints their rows (samples/s, variance per sample, efficiency, error) in the
same table.  Both evaluate the problem's NumPy twin (float64; given, or
translated by :mod:`.numpy_expression`'s whitelisting parser).

``scipy-sobol``
    R = 16 independent scramblings (``scipy.stats.qmc.Sobol(scramble=True)``,
    LMS + digital shift), each advanced by doubling its points so every
    checkpoint sees 2^k points per scrambling (the balanced sizes); estimate
    the mean of the replicate means, standard error their spread / sqrt(R)
    (the randomised QMC estimate as mcocl's ``sobol`` computes it).
``vegas-package``
    ``vegas.Integrator`` over [0, 1]^d with its defaults, iterations of a
    fixed size (the evaluations that fill 1/20 of the budget, measured on a
    first iteration); the first quarter of the budget only adapts the map,
    later iterations are combined by inverse-variance weights (as the
    package's own ``RAvg``).

The packages are optional (``pip install mcocl[peers]``; scipy also comes
with the ``test`` extra): a peer whose package is missing is listed as
skipped with the reason, never an error.
"""

from __future__ import annotations

import importlib.util
import math
import time
import warnings
from collections.abc import Callable

import numpy as np

from .suite import Observation, Tick

SOBOL_REPLICATES = 16
SOBOL_FIRST_LOG2 = 10  # points per scrambling of the first step
SOBOL_CHUNK = 1 << 18  # points evaluated at once (memory)
VEGAS_ITERATIONS_PER_BUDGET = 20
VEGAS_WARMUP_SHARE = 0.25
VEGAS_FIRST_NEVAL = 10_000

# peer name -> (the module it needs, the install hint)
PEER_PACKAGES = {
    "scipy-sobol": ("scipy", "pip install scipy"),
    "vegas-package": ("vegas", "pip install 'mcocl[peers]' (the vegas package)"),
}

Integrand = Callable[[np.ndarray], np.ndarray]


def missing_peers() -> dict[str, str]:
    """Peer name -> why it cannot run here (its package is not installed)."""
    out = {}
    for name, (module, hint) in PEER_PACKAGES.items():
        if importlib.util.find_spec(module) is None:
            out[name] = f"the {module!r} package is not installed ({hint})"
    return out


def _finite_sum(v: np.ndarray) -> tuple[float, int, int]:
    """(sum of the finite values, how many, how many were not finite)."""
    ok = np.isfinite(v)
    good = int(np.count_nonzero(ok))
    return float(v[ok].sum()) if good < v.size else float(v.sum()), good, int(v.size - good)


class ScipySobolRun:
    """scipy's scrambled Sobol' points, R replicates, advanced by doubling (a :class:`ProgressiveRun`).

    Args:
        func: the integrand over ``x`` of shape ``(dim, n)``.
        dim: the dimension.
        exact: the reference value.
        seed: seeds the R scramblings.
        replicates: R.
    """

    def __init__(self, func: Integrand, dim: int, exact: float, seed: int = 1,
                 replicates: int = SOBOL_REPLICATES) -> None:
        from scipy.stats import qmc

        self.func = func
        self.dim = dim
        self.exact = exact
        seeds = np.random.SeedSequence(seed).spawn(replicates)
        self.engines = [qmc.Sobol(dim, scramble=True, seed=np.random.default_rng(s)) for s in seeds]
        self.sums = np.zeros(replicates)
        self.good = np.zeros(replicates)
        self.points = 0  # per replicate
        self.nonfinite = 0
        self.seconds = 0.0

    def _grow(self, target: int) -> None:
        """Draw and evaluate points ``points .. target`` of every replicate."""
        with warnings.catch_warnings():
            # only the totals at the end of a step matter, and they are powers of two
            warnings.filterwarnings("ignore", message=".*balance properties.*")
            for i, engine in enumerate(self.engines):
                left = target - self.points
                while left > 0:
                    k = min(left, SOBOL_CHUNK)
                    with np.errstate(all="ignore"):
                        v = self.func(engine.random(k).T)
                    s, good, bad = _finite_sum(np.asarray(v, dtype=np.float64))
                    self.sums[i] += s
                    self.good[i] += good
                    self.nonfinite += bad
                    left -= k
        self.points = target

    def observe(self) -> Observation:
        """The cumulative state: mean and spread of the replicate means."""
        r = len(self.engines)
        samples = self.points * r
        if self.points == 0 or np.any(self.good == 0):
            return Observation(self.seconds, samples, math.nan, math.nan, math.nan, self.nonfinite)
        means = self.sums / self.good
        est = float(means.mean())
        se = float(means.std(ddof=1) / math.sqrt(r))
        return Observation(self.seconds, samples, est, se, est - self.exact, self.nonfinite)

    def advance(self, seconds: float, tick: Tick | None = None) -> Observation:
        """Double the points per replicate while the doubling fits in about ``seconds``.

        A doubling costs as much as everything before it, so one that would
        end more than twice past ``seconds`` waits for a later checkpoint
        (keeping the peer's total time near the budget).
        """
        t0 = time.perf_counter()
        did = False
        while True:
            elapsed = time.perf_counter() - t0
            target = 1 << SOBOL_FIRST_LOG2 if self.points == 0 else 2 * self.points
            rate = self.points / self.seconds if self.seconds > 0 and self.points else 0.0
            cost = (target - self.points) / rate if rate > 0 else 0.0
            if self.points and (elapsed + cost > (seconds if did else 2 * seconds)):
                break
            self._grow(target)
            self.seconds += time.perf_counter() - t0 - elapsed
            did = True
            if tick is not None:
                tick(self.seconds)
        return self.observe()

    def close(self) -> None:
        """Nothing to release."""


class VegasPackageRun:
    """The ``vegas`` package's adaptive integrator in fixed-size iterations (a :class:`ProgressiveRun`).

    Args:
        func: the integrand over ``x`` of shape ``(dim, n)``.
        dim: the dimension.
        exact: the reference value.
        seed: seeds the package's uniforms (``ran_array_generator``).
        budget: the bench's seconds per estimator (sizes the iterations and the warm-up).
    """

    def __init__(self, func: Integrand, dim: int, exact: float, seed: int = 1, budget: float = 1.0) -> None:
        import vegas

        rng = np.random.default_rng(seed)
        self.vegas = vegas
        self.batch = vegas.lbatchintegrand(lambda x: func(np.ascontiguousarray(x.T)))
        self.integ = vegas.Integrator([[0.0, 1.0]] * dim, ran_array_generator=lambda size: rng.random(size))
        self.exact = exact
        self.budget = budget
        self.neval = 0
        self.samples = 0
        self.seconds = 0.0
        self.weights = 0.0
        self.weighted = 0.0
        self.last: tuple[float, float] = (math.nan, math.nan)

    def _iteration(self) -> None:
        t0 = time.perf_counter()
        r = self.integ(self.batch, nitn=1, neval=self.neval or VEGAS_FIRST_NEVAL)
        dt = time.perf_counter() - t0
        used = int(getattr(r, "sum_neval", 0) or (self.neval or VEGAS_FIRST_NEVAL))
        if self.neval == 0:  # size the iterations from the first one's rate
            self.neval = max(int(used / max(dt, 1e-6) * self.budget / VEGAS_ITERATIONS_PER_BUDGET), VEGAS_FIRST_NEVAL)
        self.samples += used
        self.seconds += dt
        mean, sdev = float(r.mean), float(r.sdev)
        self.last = (mean, sdev)
        if self.seconds > VEGAS_WARMUP_SHARE * self.budget and sdev > 0 and math.isfinite(mean):
            self.weights += 1.0 / sdev**2
            self.weighted += mean / sdev**2

    def observe(self) -> Observation:
        """The combined iterations after the warm-up (before it: the latest iteration)."""
        if self.weights > 0:
            est, se = self.weighted / self.weights, 1.0 / math.sqrt(self.weights)
        else:
            est, se = self.last
        return Observation(self.seconds, self.samples, est, se, est - self.exact)

    def advance(self, seconds: float, tick: Tick | None = None) -> Observation:
        """Run iterations for about ``seconds`` (at least one)."""
        end = self.seconds + seconds
        while True:
            self._iteration()
            if tick is not None:
                tick(self.seconds)
            per = self.seconds / max(self.samples / max(self.neval, 1), 1)
            if self.seconds + 0.5 * per >= end:
                break
        return self.observe()

    def close(self) -> None:
        """Nothing to release."""
