"""Integral equations with known solutions, for the random-walk tests.

Each problem is f = g + ∫ K f on [0, 1]^dim with f chosen first and g derived
by hand from f and a separable (or constant) K, so the exact solution is a
closed form independent of the engine:

- ``sep1``    K = (x + y)/2, f = x^2  (the issue's example): ∫K f = x/6 + 1/8;
- ``const1``  K = 1/2, f = sin(pi x): ∫K f = 1/pi;
- ``sep2``    K = x0 y1 / 2 + 1/4, f = x0 + x1^2: ∫K f = x0/4 + 5/24;
- ``const2``  K = 0.6, f = x0 x1: ∫K f = 0.15;
- ``rowgt1``  K = 3 x (1 - y), g = 1: the row integral 1.5 x exceeds 1 for
  x > 2/3, but the operator's spectral radius is 3 ∫ x(1-x) = 1/2 < 1;
  f = 1 + 3 c x with c = ∫(1 - y) f = 1/2 + c/2, so c = 1 and f = 1 + 3x.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Problem:
    """A problem, its query points and exact solution."""

    name: str
    kernel: str
    source: str
    dim: int
    at: tuple[tuple[float, ...], ...]
    exact: Callable[[np.ndarray], np.ndarray]

    def truth(self) -> np.ndarray:
        """The exact f at the query points."""
        return self.exact(np.asarray(self.at, dtype=np.float64))


AT1 = ((0.1,), (0.5,), (0.9,))
AT2 = ((0.2, 0.7), (0.5, 0.5), (0.9, 0.1))

SEP1 = Problem("sep1", "0.5f*(x[0] + y[0])", "x[0]*x[0] - x[0]/6.0f - 0.125f", 1, AT1, lambda p: p[:, 0] ** 2)
CONST1 = Problem("const1", "0.5f", "sin(M_PI_F*x[0]) - 0.318309886f", 1, AT1, lambda p: np.sin(math.pi * p[:, 0]))
SEP2 = Problem("sep2", "0.5f*x[0]*y[1] + 0.25f", "0.75f*x[0] + x[1]*x[1] - 0.208333333f", 2, AT2,
               lambda p: p[:, 0] + p[:, 1] ** 2)
CONST2 = Problem("const2", "0.6f", "x[0]*x[1] - 0.15f", 2, AT2, lambda p: p[:, 0] * p[:, 1])
ROWGT1 = Problem("rowgt1", "3.0f*x[0]*(1.0f - y[0])", "1.0f", 1, AT1, lambda p: 1.0 + 3.0 * p[:, 0])

CLOSED_FORM = (SEP1, CONST1, SEP2, CONST2)
UNBIASED = ("roulette", "subcritical", "nee")
