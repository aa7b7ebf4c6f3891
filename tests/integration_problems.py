"""Integrands with closed-form integrals over [0, 1]^d, and the estimators under test.

Each case is chosen so that the estimator's primary estimates have light
tails (a bounded or nearly bounded f/p): the reported standard error must then
match the actual spread of the estimates, which is what the calibration test
checks.  Exact values come from the one-dimensional integrals, so they are
independent of the engine.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np


def _phi(z: float) -> float:
    return 0.5 * math.erfc(-z / math.sqrt(2))


@dataclass(frozen=True)
class Case:
    """One estimator configuration on one integrand family."""

    name: str
    expr: str  # a product over dimensions, "{j}" replaced by the index
    exact_1d: float  # the integral of one factor
    kwargs: dict[str, Any] = field(default_factory=dict)
    join: str = "*"

    def integrand(self, dim: int) -> str:
        return self.join.join(f"({self.expr.format(j=j)})" for j in range(dim))

    def exact(self, dim: int) -> float:
        return self.exact_1d**dim

    def options(self, dim: int) -> dict[str, Any]:
        kw = dict(self.kwargs)
        if "control_1d" in kw:
            g, jg = kw.pop("control_1d")
            kw["control"] = "*".join(f"({g.format(j=j)})" for j in range(dim))
            kw["control_integral"] = jg**dim
        return kw


SMOOTH = ("1.0f + 0.5f*sin(6.2831853f*x[{j}] + {j})", 1.0)  # exact 1 in every dimension

CASES = [
    Case("independent", *SMOOTH),
    Case("stratified", *SMOOTH, {"sampler": "stratified"}),
    Case("nrooks", *SMOOTH, {"sampler": "nrooks"}),
    Case("importance-exponential", "exp(-1.5f*x[{j}])", (1 - math.exp(-1.5)) / 1.5, {"proposal": "exponential:rate=2"}),
    Case("importance-power", "pow(x[{j}], -0.3f)", 1 / 0.7, {"proposal": "power:a=-0.2"}),
    Case(
        "importance-truncnorm",
        "exp(-0.5f*(x[{j}]-0.3f)*(x[{j}]-0.3f)/0.04f)",
        0.2 * math.sqrt(2 * math.pi) * (_phi(0.7 / 0.2) - _phi(-0.3 / 0.2)),
        {"proposal": "truncnorm:mu=0.3,sigma=0.25"},
    ),
    Case("importance-analytic", "x[{j}] + x[{j}]*x[{j}]", 5 / 6, {"proposal": {"type": "analytic", "pdf": "2*x", "inverse": "sqrt(u)"}}),
    Case("importance-tabulated", "1.0f + x[{j}]", 1.5, {"proposal": list(1.0 + (np.arange(16) + 0.5) / 16)}),
    Case("stratified-importance", "exp(-1.5f*x[{j}])", (1 - math.exp(-1.5)) / 1.5,
         {"sampler": "stratified", "proposal": "exponential:rate=2"}),
    Case("nrooks-importance", "exp(-1.5f*x[{j}])", (1 - math.exp(-1.5)) / 1.5,
         {"sampler": "nrooks", "proposal": "exponential:rate=2"}),
    *[
        # f is not proportional to p1 + p2 (that would make balance zero-variance)
        Case(f"combined-{h}", "exp(-2.0f*x[{j}]) + exp(2.0f*x[{j}] - 2.0f)", 1 - math.exp(-2),
             {"proposals": ["exponential:rate=1", "exponential:rate=-1"], "heuristic": h})
        for h in ("average", "max", "balance", "power")
    ],
    Case("combined-shares", "exp(-2.0f*x[{j}]) + exp(2.0f*x[{j}] - 2.0f)", 1 - math.exp(-2),
         {"proposals": ["exponential:rate=1", "uniform"], "shares": [2, 1], "heuristic": "power", "beta": 3.0}),
    Case("control-variate", "exp(0.3f*x[{j}])", (math.exp(0.3) - 1) / 0.3, {"control_1d": ("1.0f + 0.3f*x[{j}]", 1.15)}),
    Case("roulette", *SMOOTH, {"roulette": 0.7}),
]


def tabulated2d_case(dim: int) -> tuple[str, float, dict[str, Any]]:
    """Pairs of dimensions sampled from an 8x8 table close to 1 + a*b (a leftover dimension uniform)."""
    c = (np.arange(8) + 0.5) / 8
    table = 1.0 + np.outer(c, c)
    factors: list[Any] = []
    terms = []
    for k in range(dim // 2):
        factors.append({"type": "tabulated2d", "weights": table.tolist()})
        terms.append(f"(1.0f + x[{2 * k}]*x[{2 * k + 1}])")
    if dim % 2:
        factors.append("uniform")
    expr = "*".join(terms) if terms else "1.0f"
    return expr, 1.25 ** (dim // 2), {"proposal": factors}
