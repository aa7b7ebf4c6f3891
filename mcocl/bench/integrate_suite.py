"""The ``integrate`` bench suite: built-in integrands with exact integrals.

The problems cover what the lecture's estimators are about (smooth, peaked,
discontinuous, singular, additive, two peaks) in 1 to 10 dimensions, with
the six Genz families (:mod:`.genz`) as the standard test set, and carry
proposals and control variates where the problem calls for them:

===================== === =========================================================
problem               dim what it shows
===================== === =========================================================
smooth-gauss-4d        4  issue 2's integrand; stratification, IS with a near-match
                          density, a control variate, Russian roulette
additive-6d            6  sum of 1-D functions: N-rooks removes almost all variance
two-peak-2d            2  one proposal per peak: balance/power beat either alone
singular-1d            1  x^-0.4 e^-x: infinite 4th moment; IS with x^a removes it
disk-2d                2  indicator of the quarter disc (pi/4): a jump on a curve
genz-oscillatory-5d    5  Genz 1
genz-product-peak-3d   3  Genz 2; IS with a wider Cauchy-shaped analytic density
genz-corner-peak-4d    4  Genz 3; IS with exponential factors
genz-gaussian-8d       8  Genz 4; IS with truncated normals
genz-continuous-3d     3  Genz 5 (kinks)
genz-discontinuous-10d 10 Genz 6 (jumps), the 10-D case
===================== === =========================================================

Users' problems come from JSON files (:mod:`.problems`) and replace these.
"""

from __future__ import annotations

import fnmatch
import math

from ..errors import InputError
from . import genz
from .genz import c_float
from .integrate_problem import IntegrationProblem
from .problems import load_problem_files
from .suite import BenchOptions

# The quick subset (``mcocl bench --quick``, used by the tests): one problem
# per ordering the lecture promises, with only the estimators compared.
QUICK = {
    "smooth-gauss-4d": ["independent", "stratified"],
    "additive-6d": ["independent", "nrooks"],
    "two-peak-2d": ["independent", "peak-a", "peak-b", "balance", "power"],
}
QUICK_CHUNK = 1 << 17


def _lower_gamma(s: float, x: float) -> float:
    """gamma(s, x) = x^s e^-x sum_k x^k / (s (s+1) ... (s+k)) (converges for every x > 0)."""
    term = 1.0 / s
    total = term
    k = 0
    while abs(term) > 1e-17 * abs(total):
        k += 1
        term *= x / (s + k)
        total += term
    return x**s * math.exp(-x) * total


def _peak_mass(c: float, s: float) -> float:
    """int_0^1 exp(-(x - c)^2 / (2 s^2)) dx."""
    return s * math.sqrt(math.pi / 2) * (math.erf((1 - c) / (s * math.sqrt(2))) + math.erf(c / (s * math.sqrt(2))))


def _smooth() -> IntegrationProblem:
    d = 4
    sq = " + ".join(f"x[{i}]*x[{i}]" for i in range(d))
    # Taylor polynomial of exp(-t^2) per axis: 1 - t^2 + t^4/2, integral 1 - 1/3 + 1/10 = 23/30.
    g = " * ".join(f"(1.0f - x[{i}]*x[{i}] + 0.5f*x[{i}]*x[{i}]*x[{i}]*x[{i}])" for i in range(d))
    return IntegrationProblem(
        "smooth-gauss-4d", f"exp(-({sq}))", d, (math.sqrt(math.pi) / 2 * math.erf(1.0)) ** d,
        "smooth: exp(-|x|^2), issue 2's throughput integrand",
        numpy="np.exp(-(" + " + ".join(f"x[{i}]*x[{i}]" for i in range(d)) + "))",
        # exp(-t^2) is N(0, 1/2) restricted to [0, 1]; sigma 0.6 instead of 0.707 keeps it imperfect
        proposals=["truncnorm:mu=0,sigma=0.6"], control=g, control_integral=(23 / 30) ** d,
        extra={"roulette": {"roulette": 0.5}},
    )


def _additive() -> IntegrationProblem:
    d = 6
    return IntegrationProblem(
        "additive-6d", "(" + " + ".join(f"exp(x[{i}])" for i in range(d)) + f") / {c_float(d)}", d, math.e - 1,
        "additive: mean of exp(x_i); every 1-D projection stratified by N-rooks",
        numpy="(" + " + ".join(f"np.exp(x[{i}])" for i in range(d)) + f") / {float(d)!r}",
    )


def _two_peak() -> IntegrationProblem:
    s, c1, c2, sp = 0.07, (0.3, 0.35), (0.7, 0.65), 0.15
    k = 1.0 / (2 * s * s)

    def peak_c(c: tuple[float, float]) -> str:
        return f"exp(-{c_float(k)}*((x[0] - {c_float(c[0])})*(x[0] - {c_float(c[0])}) + (x[1] - {c_float(c[1])})*(x[1] - {c_float(c[1])})))"

    def peak_p(c: tuple[float, float]) -> str:
        return f"np.exp(-{k!r}*((x[0] - {c[0]!r})**2 + (x[1] - {c[1]!r})**2))"

    exact = sum(_peak_mass(c[0], s) * _peak_mass(c[1], s) for c in (c1, c2))
    return IntegrationProblem(
        "two-peak-2d", f"{peak_c(c1)} + {peak_c(c2)}", 2, exact,
        "two Gaussian peaks; one truncated-normal proposal per peak, combined estimators",
        numpy=f"{peak_p(c1)} + {peak_p(c2)}",
        proposals=[[f"truncnorm:mu={c[0]},sigma={sp}", f"truncnorm:mu={c[1]},sigma={sp}"] for c in (c1, c2)],
        proposal_names=["peak-a", "peak-b"], shares=[1, 1],
    )


def _singular() -> IntegrationProblem:
    a = -0.4
    return IntegrationProblem(
        "singular-1d", f"pow(x[0], {c_float(a)}) * exp(-x[0])", 1, _lower_gamma(1 + a, 1.0),
        "singular at 0: x^-0.4 e^-x (finite variance, infinite 4th moment); IS with (a+1) x^a",
        numpy=f"x[0]**{a!r} * np.exp(-x[0])", proposals=[f"power:a={a}"],
    )


def _disk() -> IntegrationProblem:
    return IntegrationProblem(
        "disk-2d", "(x[0]*x[0] + x[1]*x[1] < 1.0f) ? 1.0f : 0.0f", 2, math.pi / 4,
        "discontinuous: indicator of the quarter disc",
        numpy="np.where(x[0]*x[0] + x[1]*x[1] < 1.0, 1.0, 0.0)",
    )


def _cauchy_factor(a: float, u: float) -> dict[str, str]:
    """Analytic proposal proportional to 1/(a^-2 + (x - u)^2) on [0, 1] (the product peak's own shape)."""
    lo, hi = math.atan(-a * u), math.atan(a * (1 - u))
    norm = a / (hi - lo)  # pdf = norm / (1 + a^2 (x - u)^2)
    return {
        "type": "analytic",
        "pdf": f"{c_float(norm)} / (1.0f + {c_float(a * a)}*(x - {c_float(u)})*(x - {c_float(u)}))",
        "inverse": f"{c_float(u)} + tan({c_float(lo)} + u*{c_float(hi - lo)}) / {c_float(a)}",
    }


def _genz() -> list[IntegrationProblem]:
    out = []
    g = genz.oscillatory([1.2, 0.8, 1.5, 0.6, 1.0], [0.3] * 5)
    out.append(IntegrationProblem("genz-oscillatory-5d", g.opencl, 5, g.exact, "Genz oscillatory: cos(2 pi u + a.x)",
                                  numpy=g.numpy))
    a, u = [5.0, 5.0, 5.0], [0.3, 0.6, 0.45]
    g = genz.product_peak(a, u)
    out.append(IntegrationProblem("genz-product-peak-3d", g.opencl, 3, g.exact,
                                  "Genz product peak; IS with Cauchy-shaped factors of width 1/3 (f has 1/5)",
                                  numpy=g.numpy, proposals=[[_cauchy_factor(3.0, ui) for ui in u]]))
    g = genz.corner_peak([1.0] * 4)
    out.append(IntegrationProblem("genz-corner-peak-4d", g.opencl, 4, g.exact,
                                  "Genz corner peak (1 + sum x)^-5; IS with exponential factors",
                                  numpy=g.numpy, proposals=["exponential:rate=1.5"]))
    g = genz.gaussian([2.0] * 8, [0.5] * 8)
    out.append(IntegrationProblem("genz-gaussian-8d", g.opencl, 8, g.exact,
                                  "Genz Gaussian peak in 8-D; IS with truncated normals (sigma 0.4, f's is 0.35)",
                                  numpy=g.numpy, proposals=["truncnorm:mu=0.5,sigma=0.4"]))
    g = genz.continuous([2.0, 3.0, 4.0], [0.4, 0.5, 0.6])
    out.append(IntegrationProblem("genz-continuous-3d", g.opencl, 3, g.exact, "Genz continuous: kinks at u",
                                  numpy=g.numpy))
    g = genz.discontinuous([0.3] * 10, [0.6, 0.7] + [0.5] * 8)
    out.append(IntegrationProblem("genz-discontinuous-10d", g.opencl, 10, g.exact,
                                  "Genz discontinuous in 10-D: zero outside x0 < 0.6, x1 < 0.7",
                                  numpy=g.numpy))
    return out


def builtin_problems() -> list[IntegrationProblem]:
    """Every built-in problem, in report order."""
    return [_smooth(), _additive(), _two_peak(), _singular(), _disk(), *_genz()]


class IntegrateSuite:
    """The ``integrate`` suite (see the module docstring)."""

    name = "integrate"
    error_kind = "signed"
    reference_estimator = "independent"

    def problems(self, options: BenchOptions) -> list[IntegrationProblem]:
        """Built-in problems (filtered by ``only``; the quick subset), or the users' files."""
        if options.problem_files:
            probs = load_problem_files(options.problem_files)
        else:
            probs = builtin_problems()
            if options.quick:
                probs = [p for p in probs if p.name in QUICK]
                for p in probs:
                    p.only_estimators = QUICK[p.name]
                    p.chunk = QUICK_CHUNK
        if options.only:
            chosen = [p for p in probs if any(fnmatch.fnmatchcase(p.name, pat) for pat in options.only)]
            unmatched = [pat for pat in options.only if not any(fnmatch.fnmatchcase(p.name, pat) for p in probs)]
            if unmatched:
                raise InputError(f"--only: no problem matches {unmatched}; problems: {', '.join(p.name for p in probs)}")
            probs = chosen
        for p in probs:
            p.seed, p.device, p.lanes = options.seed, options.device, options.lanes
            p.peers, p.budget = options.peers, options.budget or p.budget
        if options.problem_files:
            for p in probs:  # compile everything before anything runs
                p.check()
        return probs


SUITE = IntegrateSuite()
