"""The plain Monte Carlo estimator in vectorised NumPy: the engine's yardstick.

Every bench table shows how much faster the OpenCL engine is than what a
careful NumPy user would write: float64, ``Generator(PCG64)``, points drawn
in chunks (10^6 by default) into a preallocated array, the integrand
evaluated on whole columns, sums of f and f^2 in float64 (shifted by the
first chunk's mean so the variance does not cancel catastrophically).  It is
timed in the same process as the engine, right after it, so the two see the
same machine load.

The integrand is a NumPy expression over ``x`` of shape ``(dim, n)``
(``x[i]`` is coordinate i of every point).  Built-in problems carry one; for
a user's OpenCL C expression :func:`translate_opencl` tries a conservative
token-by-token translation and says why when it cannot.
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Callable

import numpy as np

from .numpy_expression import CONSTANTS, OPENCL_FUNCTIONS, parse_numpy_expression
from .suite import Observation, Tick

DEFAULT_CHUNK = 1_000_000

_TOKEN = re.compile(
    r"\s*(?:(?P<num>(?:\d+\.\d*|\.\d+|\d+)(?:[eE][+-]?\d+)?[fF]?)|(?P<ident>[A-Za-z_]\w*)"
    r"|(?P<op><=|>=|==|!=|&&|\|\||[-+*/()\[\],<>!?:;{}=%&|^~]))"
)


class TranslationError(ValueError):
    """An OpenCL C expression that has no safe NumPy translation."""


def translate_opencl(code: str) -> str:
    """A NumPy expression over ``x`` (shape ``(dim, n)``) for an OpenCL C expression.

    Only plain arithmetic expressions are translated: numbers (an ``f``
    suffix is dropped, integer literals become real numbers), ``x[k]``, the
    operators ``+ - * / ( )`` and comparisons, and the built-ins in
    ``OPENCL_FUNCTIONS``.  Function bodies, ternaries, ``&&``/``||`` (whose
    precedence differs in Python) and anything else raise
    :class:`TranslationError` naming what stopped the translation.
    """
    out: list[str] = []
    pos = 0
    text = code.strip()
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if not m or m.end() == pos:
            raise TranslationError(f"cannot translate the character {text[pos:].strip()[:1]!r}")
        pos = m.end()
        if m.group("num"):
            num = m.group("num").rstrip("fF")
            real = any(c in num for c in ".eE")
            if out and out[-1] == "[":
                if real:
                    raise TranslationError(f"a non-integer index {m.group('num')!r}")
                out.append(num)  # an index x[k] stays an integer
            else:
                out.append(num if real else num + ".0")
        elif m.group("ident"):
            name = m.group("ident")
            if name == "x" or name in OPENCL_FUNCTIONS or name in CONSTANTS:
                out.append(name)
            elif name == "return":
                raise TranslationError("function bodies (with return) are not translated")
            else:
                raise TranslationError(f"unknown name {name!r}")
        else:
            op = m.group("op")
            if op in ("+", "-", "*", "/", "(", ")", "[", "]", ",", "<", ">", "<=", ">=", "==", "!="):
                out.append(op)
            else:
                raise TranslationError(f"the operator {op!r} is not translated")
    if not out:
        raise TranslationError("empty expression")
    return " ".join(out)


def compile_numpy(expression: str, dim: int) -> Callable[[np.ndarray], np.ndarray]:
    """A function of ``x`` (shape ``(dim, n)``) returning ``n`` float64 values.

    The expression is parsed by the whitelisting translator of
    :mod:`mcocl.bench.numpy_expression` (arithmetic, comparisons, ``x[k]``,
    numbers and a fixed set of NumPy functions; never ``eval``) and checked
    on a few points.

    Raises:
        ValueError: it is refused by the translator, fails on the check
            points, or does not give one value per point.
    """
    g = parse_numpy_expression(expression, dim)

    def f(x: np.ndarray) -> np.ndarray:
        return np.asarray(g(x), dtype=np.float64)

    probe = np.random.default_rng(0).random((dim, 7))
    try:
        with np.errstate(all="ignore"):
            v = f(probe)
    except (ArithmeticError, ValueError, TypeError) as e:
        raise ValueError(f"fails on test points: {type(e).__name__}: {e}") from None
    if v.shape not in ((7,), ()):
        raise ValueError(f"gives shape {v.shape} for 7 points; expected one value per point (7,)")
    if v.shape == ():
        return lambda x: np.full(x.shape[1], float(f(x)))
    return f


class NumpyPlainRun:
    """The plain (secondary) estimator in NumPy, advanced in chunks (a :class:`ProgressiveRun`).

    Args:
        func: the integrand over ``x`` of shape ``(dim, n)``.
        dim: the dimension.
        exact: the reference value (for the actual error).
        seed: seed of ``Generator(PCG64)``.
        chunk: points per chunk.
    """

    def __init__(self, func: Callable[[np.ndarray], np.ndarray], dim: int, exact: float, seed: int = 1,
                 chunk: int = DEFAULT_CHUNK) -> None:
        self.func = func
        self.dim = dim
        self.exact = exact
        self.rng = np.random.Generator(np.random.PCG64(seed))
        self.chunk = int(chunk)
        self.buf = np.empty((dim, self.chunk), dtype=np.float64)
        self.n = 0
        self.nonfinite = 0
        self.shift: float | None = None
        self.s1 = 0.0
        self.s2 = 0.0
        self.seconds = 0.0
        # CPU time of this thread only: the process's would include idle OpenCL worker threads
        self.cpu_seconds = 0.0

    def _chunk(self) -> None:
        self.rng.random(out=self.buf)
        with np.errstate(all="ignore"):
            v = self.func(self.buf)
        ok = np.isfinite(v)
        bad = int(v.size - np.count_nonzero(ok))
        if bad:
            self.nonfinite += bad
            v = v[ok]
        if self.shift is None and v.size:
            self.shift = float(v.mean())
        d = v - (self.shift or 0.0)
        self.s1 += float(d.sum())
        self.s2 += float(np.dot(d, d))
        self.n += int(v.size)

    def observe(self) -> Observation:
        """The cumulative state."""
        n = self.n
        if n < 2:
            return Observation(self.seconds, n, math.nan, math.nan, math.nan, self.nonfinite)
        mean_d = self.s1 / n
        var = max(self.s2 / n - mean_d * mean_d, 0.0) * n / (n - 1)
        est = (self.shift or 0.0) + mean_d
        return Observation(self.seconds, n + self.nonfinite, est, math.sqrt(var / n), est - self.exact, self.nonfinite)

    def advance(self, seconds: float, tick: Tick | None = None) -> Observation:
        """Run whole chunks for about ``seconds`` (at least one chunk)."""
        t0 = time.perf_counter()
        c0 = time.thread_time()
        while True:
            self._chunk()
            el = time.perf_counter() - t0
            if tick is not None:
                tick(self.seconds + el)
            if el >= seconds:
                break
        self.seconds += time.perf_counter() - t0
        self.cpu_seconds += time.thread_time() - c0
        return self.observe()

    def run_samples(self, samples: int) -> Observation:
        """Run exactly ``ceil(samples / chunk)`` chunks."""
        t0 = time.perf_counter()
        c0 = time.thread_time()
        for _ in range(-(-int(samples) // self.chunk)):
            self._chunk()
        self.seconds += time.perf_counter() - t0
        self.cpu_seconds += time.thread_time() - c0
        return self.observe()

    def close(self) -> None:
        """Drop the point buffer."""
        self.buf = np.empty((self.dim, 0))
