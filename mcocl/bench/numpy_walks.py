"""The plain random walk of ``solve_fredholm(estimator="roulette")`` in vectorised NumPy.

The yardstick of the ``solve`` suite, as :mod:`.numpy_baseline` is for
integrals: float64, ``Generator(PCG64)``, a chunk of walks per query point
advanced together, one array operation per step over the walks still alive
(compacted every step).  The walk is the engine's (``kernels/walks/walk.cl``,
lecture "Ruská ruleta pro integrální rovnice"): from xi_0 = x, W_0 = 1,
S = g(x); each step draws y uniform on [0, 1]^dim, sets W' = W K(xi, y),
survives with P = min(1, |W'|), then W = W' / P and S += W g(y); the walk
ends when it does not survive.

``kernel`` is a NumPy expression over ``x`` and ``y`` (each of shape
``(dim, n)``), ``source`` over ``x``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from .suite import Observation, Tick

DEFAULT_WALKS = 1 << 16
MAX_STEPS = 10_000


def compile_walk_expressions(kernel: str, source: str, dim: int) -> tuple[Callable[..., np.ndarray], Callable[..., np.ndarray]]:
    """(K(x, y), g(x)) as vectorised functions of ``(dim, n)`` arrays.

    Raises:
        ValueError: an expression does not parse or fails on test points.
    """
    scope: dict[str, object] = {"__builtins__": {}, "np": np, "math": math}
    try:
        kc = compile(kernel, "<numpy kernel>", "eval")
        gc = compile(source, "<numpy source>", "eval")
    except SyntaxError as e:
        raise ValueError(f"not a Python expression: {e.msg}") from None

    def k(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return np.broadcast_to(np.asarray(eval(kc, scope, {"x": x, "y": y}), dtype=np.float64), (x.shape[1],))  # noqa: S307

    def g(x: np.ndarray) -> np.ndarray:
        return np.broadcast_to(np.asarray(eval(gc, scope, {"x": x}), dtype=np.float64), (x.shape[1],))  # noqa: S307

    probe = np.random.default_rng(0).random((2, dim, 5))
    try:
        k(probe[0], probe[1])
        g(probe[0])
    except Exception as e:  # noqa: BLE001 - reported with the expression's name by the caller
        raise ValueError(f"fails on test points: {type(e).__name__}: {e}") from None
    return k, g


class NumpyWalkRun:
    """Weight-driven Russian-roulette walks in NumPy at every query point (a :class:`ProgressiveRun`).

    Args:
        kernel, source: NumPy callables (see :func:`compile_walk_expressions`).
        at: query points, shape ``(nq, dim)``.
        exact: f at the query points.
        seed: seed of ``Generator(PCG64)``.
        walks: walks per query point per chunk.
    """

    def __init__(self, kernel: Callable[..., np.ndarray], source: Callable[..., np.ndarray], at: np.ndarray,
                 exact: np.ndarray, seed: int = 1, walks: int = DEFAULT_WALKS) -> None:
        self.k, self.g = kernel, source
        self.at = np.asarray(at, dtype=np.float64)
        self.exact = np.asarray(exact, dtype=np.float64)
        self.rng = np.random.Generator(np.random.PCG64(seed))
        self.walks = int(walks)
        nq = len(self.at)
        self.n = np.zeros(nq)
        self.s1 = np.zeros(nq)
        self.s2 = np.zeros(nq)
        self.shift = np.full(nq, math.nan)
        self.nonfinite = 0
        self.seconds = 0.0
        self.steps = 0

    def _chunk_at(self, q: int) -> None:
        dim, m = self.at.shape[1], self.walks
        x = np.repeat(self.at[q][:, None], m, axis=1)
        s = self.g(x).copy()
        w = np.ones(m)
        alive = np.arange(m)
        for _ in range(MAX_STEPS):
            if alive.size == 0:
                break
            y = self.rng.random((dim, alive.size))
            wn = w[alive] * self.k(x[:, alive], y)
            p = np.minimum(np.abs(wn), 1.0)
            go = self.rng.random(alive.size) < p
            alive, y, wn, p = alive[go], y[:, go], wn[go], p[go]
            wn = wn / p
            w[alive] = wn
            x[:, alive] = y
            s[alive] += wn * self.g(y)
            self.steps += int(alive.size)
        ok = np.isfinite(s)
        self.nonfinite += int(m - np.count_nonzero(ok))
        if math.isnan(self.shift[q]) and np.any(ok):
            self.shift[q] = float(s[ok].mean())  # sums of v - shift: no cancellation in the variance
        v = s[ok] - self.shift[q]
        self.n[q] += v.size
        self.s1[q] += float(v.sum())
        self.s2[q] += float(np.dot(v, v))

    def observe(self) -> Observation:
        """Cumulative state aggregated over the query points (RMS error and stderr)."""
        n = self.n
        if n.min() < 2:
            return Observation(self.seconds, int(n.sum()), math.nan, math.nan, math.nan, self.nonfinite,
                               points=len(self.at))
        mean_d = self.s1 / n
        var = np.maximum(self.s2 / n - mean_d**2, 0.0) * n / (n - 1)
        values = self.shift + mean_d
        stderr = np.sqrt(var / n)
        return Observation(self.seconds, int(n.sum()) + self.nonfinite, float(values.mean()),
                           float(np.sqrt(np.mean(stderr**2))), float(np.sqrt(np.mean((values - self.exact) ** 2))),
                           self.nonfinite, points=len(self.at))

    def advance(self, seconds: float, tick: Tick | None = None) -> Observation:
        """Run chunks (every query point) for about ``seconds`` (at least one chunk)."""
        t0 = time.perf_counter()
        while True:
            for q in range(len(self.at)):
                self._chunk_at(q)
            el = time.perf_counter() - t0
            if tick is not None:
                tick(self.seconds + el)
            if el >= seconds:
                break
        self.seconds += time.perf_counter() - t0
        return self.observe()

    def info(self) -> dict[str, object]:
        """Mean walk length so far."""
        return {"mean_walk_length": self.steps / max(float(self.n.sum()) + self.nonfinite, 1.0)}

    def close(self) -> None:
        """Nothing to release."""
