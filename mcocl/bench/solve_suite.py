"""The ``solve`` bench suite: random-walk estimators on integral equations with known solutions.

Each problem is f = g + integral K f on [0, 1]^dim with f known in closed form
(f chosen first, g derived from it) or, for a non-separable kernel, from the
Nyström solver at high order.  The estimators are those of
``mcocl.solve_fredholm``: ``truncated`` (fixed depth 8, biased: its error
stops falling, and the bench's consistency column says so), ``roulette``
(uniform moves, weight-driven Russian roulette), ``subcritical`` (moves
~ |K|) and ``nee`` (next-event estimation of g).

A problem has several query points; the bench's scalar figures aggregate
them: error = RMS over the points of (value - exact), stderr = RMS of the
reported standard errors, samples = walks over all points.  Efficiency =
1 / (stderr^2 * seconds) as everywhere.

===================== === ===================================================
problem               dim what it shows
===================== === ===================================================
separable-1d           1  K = (x + y)/2, f = x^2 (issue 3's example)
constant-1d            1  K = 1/2, f = sin(pi x)
peaked-source-1d       1  K = 1/2, g a narrow peak: NEE samples it directly
peaked-kernel-1d       1  K(x, y) peaked in y: subcritical moves follow it
separable-2d           2  K = x0 y1 / 2 + 1/4, f = x0 + x1^2
smooth-kernel-1d       1  K = exp(-2 (x - y)^2) / 2, g = cos 3x: Nyström reference
===================== === ===================================================
"""

from __future__ import annotations

import fnmatch
import math
import os
import shutil
import tempfile
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..engine.contract import Progress
from ..errors import InputError
from ..integration import NonFiniteWarning
from ..walks import FredholmResult, nystrom, solve_fredholm
from ..walks.job import WALKS_PER_BLOCK
from .genz import c_float
from .numpy_walks import NumpyWalkRun, compile_walk_expressions
from .suite import BaselineSpec, BenchOptions, EstimatorSpec, Observation, Tick

ESTIMATORS: dict[str, dict[str, Any]] = {
    "truncated": {"estimator": "truncated", "depth": 8},
    "roulette": {"estimator": "roulette"},
    "subcritical": {"estimator": "subcritical"},
    "nee": {"estimator": "nee"},
}
DESCRIPTIONS = {
    "truncated": "uniform moves, Neumann series cut after 8 moves (biased)",
    "roulette": "uniform moves, Russian roulette with P = min(1, |weight|)",
    "subcritical": "moves ~ |K(x, .)| (tabulated), survival min(1, int |K|)",
    "nee": "subcritical walk plus next-event estimation of g (~ |g|, tabulated)",
}
QUICK = {
    "peaked-source-1d": ["roulette", "nee"],
    "peaked-kernel-1d": ["roulette", "subcritical"],
}
# the first step's walks per point: whole blocks, so that every resume is accepted
FIRST_WALKS = 16 * WALKS_PER_BLOCK


class WalkRun:
    """One estimator of ``solve_fredholm`` on one problem, advanced by checkpoint and resume.

    As :class:`~.integrate_run.IntegrationRun`: each step asks for a walk
    count (whole blocks) that the measured rate says fills the step.
    """

    def __init__(self, problem: WalkProblem, options: dict[str, Any]) -> None:
        self.problem = problem
        self.options = dict(options)
        self._dir = tempfile.mkdtemp(prefix="mcocl-bench-")
        self.checkpoint = os.path.join(self._dir, "walk.ckpt")
        self.seconds = 0.0
        self.last: FredholmResult | None = None
        self.build_seconds = 0.0

    def advance(self, seconds: float, tick: Tick | None = None) -> Observation:
        """Walk for about ``seconds`` more."""
        p = self.problem
        if self.last is None:
            walks = FIRST_WALKS
        else:
            rate = self.last.walks / self.seconds if self.seconds > 0 else 0.0
            blocks = max(int(math.ceil(rate * seconds / WALKS_PER_BLOCK)), 1)
            walks = self.last.walks + blocks * WALKS_PER_BLOCK
        before = self.seconds

        def progress(pr: Progress) -> None:
            if tick is not None:
                tick(before + pr.elapsed)

        kw = dict(self.options)
        if self.last is not None:
            kw["resume"] = self.checkpoint
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NonFiniteWarning)  # counted in the result, reported by the bench
            r = solve_fredholm(p.kernel, p.source, p.dim, [list(a) for a in p.at], walks, seed=p.seed,
                               time_budget=max(4 * seconds, 1.0), device=p.device, lanes=p.lanes,
                               checkpoint=self.checkpoint, progress=progress, **kw)
        self.last = r
        self.seconds += r.seconds
        self.build_seconds += r.build_seconds
        values, stderr = np.asarray(r.values, dtype=np.float64), np.asarray(r.stderr, dtype=np.float64)
        err = float(np.sqrt(np.mean((values - p.exact) ** 2)))
        return Observation(self.seconds, int(r.walks) * len(values), float(values.mean()),
                           float(np.sqrt(np.mean(stderr**2))), err, int(sum(r.nonfinite)), r.stopped_by, len(values))

    def info(self) -> dict[str, Any]:
        """Facts from the last result."""
        r = self.last
        if r is None:
            return {}
        return {"estimator": r.description, "mean_walk_length": r.mean_walk_length, "lanes": r.lanes,
                "device": r.device, "build_seconds": self.build_seconds, "notes": list(r.notes),
                "values": [float(v) for v in r.values], "stderr": [float(v) for v in r.stderr]}

    def close(self) -> None:
        """Remove the checkpoint."""
        shutil.rmtree(self._dir, ignore_errors=True)


@dataclass
class WalkProblem:
    """f = g + integral K f on [0, 1]^dim with known f at the query points.

    Attributes:
        name, description: as in the tables.
        kernel, source: OpenCL C (``float x[dim], y[dim]``; ``float x[dim]``).
        dim: dimension.
        at: query points.
        exact: f at the query points.
        numpy_kernel, numpy_source: NumPy twins over ``(dim, n)`` arrays ``x``, ``y``.
        reference: how ``exact`` was obtained.
        only_estimators: the quick subset, None: all.
        seed, device, lanes: filled in by the suite.
    """

    name: str
    description: str
    kernel: str
    source: str
    dim: int
    at: tuple[tuple[float, ...], ...]
    exact: np.ndarray
    numpy_kernel: str
    numpy_source: str
    reference: str = "closed form"
    only_estimators: list[str] | None = None
    seed: int = 1
    device: Any = None
    lanes: int | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    def estimators(self) -> list[EstimatorSpec]:
        """The four walk estimators (or the quick subset)."""
        out = []
        for name, kw in ESTIMATORS.items():
            if self.only_estimators is not None and name not in self.only_estimators:
                continue

            def start(kw: dict[str, Any] = kw) -> WalkRun:
                return WalkRun(self, kw)

            out.append(EstimatorSpec(name, start, DESCRIPTIONS[name]))
        return out

    def baseline(self) -> BaselineSpec:
        """The roulette walk in NumPy."""
        try:
            k, g = compile_walk_expressions(self.numpy_kernel, self.numpy_source, self.dim)
        except ValueError as e:
            return BaselineSpec(None, unavailable=f"NumPy twin: {e}")

        def start() -> NumpyWalkRun:
            return NumpyWalkRun(k, g, np.asarray(self.at), self.exact, self.seed)

        return BaselineSpec(start, "NumPy float64 roulette walk (uniform moves, P = min(1, |W|)), PCG64")

    def summary(self) -> dict[str, Any]:
        """JSON facts (the exact values are per query point; ``exact`` is their mean)."""
        return {"name": self.name, "dim": self.dim, "kernel": self.kernel, "source": self.source,
                "at": [list(a) for a in self.at], "exact_values": [float(v) for v in self.exact],
                "exact": float(np.mean(self.exact)), "reference": self.reference, "description": self.description}


AT1 = ((0.1,), (0.5,), (0.9,))
AT2 = ((0.2, 0.7), (0.5, 0.5), (0.9, 0.1))


def _pts(at: tuple[tuple[float, ...], ...]) -> np.ndarray:
    return np.asarray(at, dtype=np.float64)


def _gauss_mass(c: float, s: float) -> float:
    """int_0^1 exp(-(y - c)^2 / (2 s^2)) dy."""
    return s * math.sqrt(math.pi / 2) * (math.erf((1 - c) / (s * math.sqrt(2))) + math.erf(c / (s * math.sqrt(2))))


def _peaked_source() -> WalkProblem:
    # K = 1/2: f = g + (1/2) int f, so int f = 2 G and f = g + G, G = int g.
    c, s = 0.3, 0.03
    k = 1.0 / (2 * s * s)
    at = ((0.1,), (0.3,), (0.7,))
    g_np: Callable[[np.ndarray], np.ndarray] = lambda x: np.exp(-k * (x - c) ** 2)  # noqa: E731
    exact = g_np(_pts(at)[:, 0]) + _gauss_mass(c, s)
    return WalkProblem("peaked-source-1d", "K = 1/2, g a Gaussian peak of width 0.03 at 0.3: f = g + int g",
                       "0.5f", f"exp(-{c_float(k)}*(x[0] - {c_float(c)})*(x[0] - {c_float(c)}))", 1, at, exact,
                       "0.5", f"np.exp(-{k!r}*(x[0] - {c!r})**2)")


def _peaked_kernel() -> WalkProblem:
    # K(x, y) = lam b(y) / B with b a narrow Gaussian at mu, g = x:
    # f = x + lam c, c = int b f / B = m + lam c  =>  f = x + lam m / (1 - lam), m = int y b / B.
    lam, mu, s = 0.5, 0.7, 0.03
    mass = _gauss_mass(mu, s)
    first = s * s * (math.exp(-mu * mu / (2 * s * s)) - math.exp(-(1 - mu) ** 2 / (2 * s * s)))  # int (y - mu) b
    m = (first + mu * mass) / mass
    k = 1.0 / (2 * s * s)
    exact = _pts(AT1)[:, 0] + lam * m / (1 - lam)
    return WalkProblem("peaked-kernel-1d", "K(x, y) = b(y)/(2B), b a Gaussian peak of width 0.03 at 0.7, g = x",
                       f"{c_float(lam / mass)}*exp(-{c_float(k)}*(y[0] - {c_float(mu)})*(y[0] - {c_float(mu)}))",
                       "x[0]", 1, AT1, exact,
                       f"{lam / mass!r}*np.exp(-{k!r}*(y[0] - {mu!r})**2)", "x[0]")


def _smooth_kernel(device: Any) -> WalkProblem:
    kernel, source = "0.5f*exp(-2.0f*(x[0] - y[0])*(x[0] - y[0]))", "cos(3.0f*x[0])"
    sol = nystrom(kernel, source, 1, order=64, device=device)
    exact = np.asarray(sol([list(a) for a in AT1]), dtype=np.float64)
    return WalkProblem("smooth-kernel-1d", "K = exp(-2 (x - y)^2)/2, g = cos 3x (non-separable)", kernel, source, 1,
                       AT1, exact, "0.5*np.exp(-2.0*(x[0] - y[0])**2)", "np.cos(3.0*x[0])",
                       reference="Nyström, 64 Gauss-Legendre nodes (float32 expressions)")


def builtin_problems(device: Any = None, with_reference: bool = True) -> list[WalkProblem]:
    """Every built-in problem; the Nyström-referenced one only ``with_reference``."""
    p1 = _pts(AT1)[:, 0]
    p2 = _pts(AT2)
    probs = [
        WalkProblem("separable-1d", "K = (x + y)/2, f = x^2", "0.5f*(x[0] + y[0])", "x[0]*x[0] - x[0]/6.0f - 0.125f",
                    1, AT1, p1**2, "0.5*(x[0] + y[0])", "x[0]*x[0] - x[0]/6.0 - 0.125"),
        WalkProblem("constant-1d", "K = 1/2, f = sin(pi x)", "0.5f", "sin(M_PI_F*x[0]) - 0.318309886f", 1, AT1,
                    np.sin(math.pi * p1), "0.5", "np.sin(math.pi*x[0]) - 1/math.pi"),
        _peaked_source(),
        _peaked_kernel(),
        WalkProblem("separable-2d", "K = x0 y1/2 + 1/4, f = x0 + x1^2", "0.5f*x[0]*y[1] + 0.25f",
                    "0.75f*x[0] + x[1]*x[1] - 0.208333333f", 2, AT2, p2[:, 0] + p2[:, 1] ** 2,
                    "0.5*x[0]*y[1] + 0.25", "0.75*x[0] + x[1]*x[1] - 5/24"),
    ]
    if with_reference:
        probs.append(_smooth_kernel(device))
    return probs


class SolveSuite:
    """The ``solve`` suite (see the module docstring)."""

    name = "solve"
    error_kind = "rmse"
    reference_estimator = "roulette"

    def problems(self, options: BenchOptions) -> list[WalkProblem]:
        """Built-in problems (filtered by ``only``; the quick subset)."""
        if options.problem_files:
            raise InputError("--problem files are for the integrate suite; the solve suite has built-in problems only")
        probs = builtin_problems(options.device, with_reference=not options.quick)
        if options.quick:
            probs = [p for p in probs if p.name in QUICK]
            for p in probs:
                p.only_estimators = QUICK[p.name]
        if options.only:
            unmatched = [pat for pat in options.only if not any(fnmatch.fnmatchcase(p.name, pat) for p in probs)]
            if unmatched:
                raise InputError(f"--only: no problem matches {unmatched}; problems: {', '.join(p.name for p in probs)}")
            probs = [p for p in probs if any(fnmatch.fnmatchcase(p.name, pat) for pat in options.only)]
        for p in probs:
            p.seed, p.device, p.lanes = options.seed, options.device, options.lanes
        return probs


SUITE = SolveSuite()
