"""The Genz test families: integrands on [0, 1]^d with closed-form integrals.

A. Genz, "Testing multidimensional integration routines" (1984) defines six
families, each with a difficulty vector ``a`` and a shift vector ``u``:

==============  ===============================================  ============
family          f(x)                                             feature
==============  ===============================================  ============
oscillatory     cos(2 pi u_1 + sum a_i x_i)                      oscillation
product peak    prod 1 / (a_i^-2 + (x_i - u_i)^2)                peak
corner peak     (1 + sum a_i x_i)^-(d+1)                         corner peak
gaussian        exp(-sum a_i^2 (x_i - u_i)^2)                    smooth peak
continuous      exp(-sum a_i |x_i - u_i|)                        kink
discontinuous   0 if x_1 > u_1 or x_2 > u_2, else exp(sum a_i x_i) jump
==============  ===============================================  ============

Each builder returns the OpenCL C integrand, a NumPy twin over ``x`` of shape
``(d, n)`` (``x[i]`` is the i-th coordinate of every point) and the exact
integral, computed in float64 from the closed forms below (each factorises
over the dimensions except the oscillatory and the corner peak).
"""

from __future__ import annotations

import cmath
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction


@dataclass(frozen=True)
class GenzIntegrand:
    """One member of a Genz family.

    Attributes:
        family: the family's name.
        opencl: OpenCL C integrand over ``float x[d]`` (expression or body).
        numpy: NumPy expression over ``x`` of shape ``(d, n)``.
        exact: the integral over [0, 1]^d.
    """

    family: str
    opencl: str
    numpy: str
    exact: float


def c_float(v: float) -> str:
    """A float literal for OpenCL C (``1.5f``)."""
    return f"{float(v)!r}f"


def py_float(v: float) -> str:
    """A float literal for the NumPy twin."""
    return repr(float(v))


def _check(a: Sequence[float], u: Sequence[float]) -> int:
    if len(a) != len(u) or not a:
        raise ValueError("a and u must be non-empty and of the same length")
    return len(a)


def oscillatory(a: Sequence[float], u: Sequence[float]) -> GenzIntegrand:
    """cos(2 pi u_1 + a . x); integral Re[e^(2 pi i u_1) prod (e^(i a_j) - 1) / (i a_j)]."""
    d = _check(a, u)
    lin_c = " + ".join(f"{c_float(ai)}*x[{i}]" for i, ai in enumerate(a))
    lin_p = " + ".join(f"{py_float(ai)}*x[{i}]" for i, ai in enumerate(a))
    phase = 2 * math.pi * u[0]
    z = cmath.exp(1j * phase)
    for aj in a:
        z *= (cmath.exp(1j * aj) - 1) / (1j * aj)
    return GenzIntegrand("oscillatory", f"cos({c_float(phase)} + {lin_c})", f"np.cos({py_float(phase)} + {lin_p})",
                         z.real if d else math.nan)


def product_peak(a: Sequence[float], u: Sequence[float]) -> GenzIntegrand:
    """prod 1/(a^-2 + (x - u)^2); each factor integrates to a (atan(a (1-u)) + atan(a u))."""
    _check(a, u)
    terms_c = [f"({c_float(ai ** -2)} + (x[{i}] - {c_float(ui)})*(x[{i}] - {c_float(ui)}))" for i, (ai, ui) in enumerate(zip(a, u))]
    terms_p = [f"({py_float(ai ** -2)} + (x[{i}] - {py_float(ui)})**2)" for i, (ai, ui) in enumerate(zip(a, u))]
    exact = math.prod(ai * (math.atan(ai * (1 - ui)) + math.atan(ai * ui)) for ai, ui in zip(a, u))
    return GenzIntegrand("product peak", "1.0f / (" + " * ".join(terms_c) + ")", "1.0 / (" + " * ".join(terms_p) + ")", exact)


def corner_peak(a: Sequence[float]) -> GenzIntegrand:
    """(1 + a . x)^-(d+1).

    Integrating one coordinate at a time, int_0^1 (c + a x)^-(k+1) dx =
    (c^-k - (c + a)^-k) / (k a), so the integral is the inclusion-exclusion sum
    1/(d! prod a) * sum over subsets S of (-1)^|S| / (1 + sum_{i in S} a_i).
    The sum cancels to a small fraction of its terms (10^-4 of them in 10-D),
    so it is added in exact rationals (the a_i as the floats they are).
    """
    d = len(a)
    if not d:
        raise ValueError("a must be non-empty")
    lin_c = " + ".join(f"{c_float(ai)}*x[{i}]" for i, ai in enumerate(a))
    lin_p = " + ".join(f"{py_float(ai)}*x[{i}]" for i, ai in enumerate(a))
    power = " * ".join(["r"] * (d + 1))
    opencl = f"float r = 1.0f / (1.0f + {lin_c}); return {power};"
    total = Fraction(0)
    for k in range(d + 1):
        for s in itertools.combinations([Fraction(float(ai)) for ai in a], k):
            total += Fraction((-1) ** k) / (1 + sum(s))  # Fraction: 1 / 1 would be a float
    exact = float(total / (math.factorial(d) * math.prod(Fraction(float(ai)) for ai in a)))
    return GenzIntegrand("corner peak", opencl, f"(1.0 + {lin_p}) ** {py_float(-(d + 1))}", exact)


def gaussian(a: Sequence[float], u: Sequence[float]) -> GenzIntegrand:
    """exp(-sum a^2 (x - u)^2); each factor integrates to sqrt(pi)/(2a) (erf(a (1-u)) + erf(a u))."""
    _check(a, u)
    sq_c = " + ".join(f"{c_float(ai * ai)}*(x[{i}] - {c_float(ui)})*(x[{i}] - {c_float(ui)})" for i, (ai, ui) in enumerate(zip(a, u)))
    sq_p = " + ".join(f"{py_float(ai * ai)}*(x[{i}] - {py_float(ui)})**2" for i, (ai, ui) in enumerate(zip(a, u)))
    exact = math.prod(math.sqrt(math.pi) / (2 * ai) * (math.erf(ai * (1 - ui)) + math.erf(ai * ui)) for ai, ui in zip(a, u))
    return GenzIntegrand("gaussian", f"exp(-({sq_c}))", f"np.exp(-({sq_p}))", exact)


def continuous(a: Sequence[float], u: Sequence[float]) -> GenzIntegrand:
    """exp(-sum a |x - u|); each factor integrates to (2 - e^(-a u) - e^(-a (1-u))) / a."""
    _check(a, u)
    s_c = " + ".join(f"{c_float(ai)}*fabs(x[{i}] - {c_float(ui)})" for i, (ai, ui) in enumerate(zip(a, u)))
    s_p = " + ".join(f"{py_float(ai)}*np.abs(x[{i}] - {py_float(ui)})" for i, (ai, ui) in enumerate(zip(a, u)))
    exact = math.prod((2 - math.exp(-ai * ui) - math.exp(-ai * (1 - ui))) / ai for ai, ui in zip(a, u))
    return GenzIntegrand("continuous", f"exp(-({s_c}))", f"np.exp(-({s_p}))", exact)


def discontinuous(a: Sequence[float], u: Sequence[float]) -> GenzIntegrand:
    """0 if x_1 > u_1 or x_2 > u_2, else exp(a . x).

    The integral factorises: prod (e^(a_i w_i) - 1) / a_i with w_i = u_i for
    the first two coordinates (the box the function lives in) and 1 otherwise.
    """
    d = _check(a, u)
    cut = min(d, 2)
    lin_c = " + ".join(f"{c_float(ai)}*x[{i}]" for i, ai in enumerate(a))
    lin_p = " + ".join(f"{py_float(ai)}*x[{i}]" for i, ai in enumerate(a))
    cond_c = " || ".join(f"x[{i}] > {c_float(u[i])}" for i in range(cut))
    cond_p = " | ".join(f"(x[{i}] > {py_float(u[i])})" for i in range(cut))
    w = [u[i] if i < cut else 1.0 for i in range(d)]
    exact = math.prod(math.expm1(ai * wi) / ai for ai, wi in zip(a, w))
    return GenzIntegrand("discontinuous", f"({cond_c}) ? 0.0f : exp({lin_c})",
                         f"np.where({cond_p}, 0.0, np.exp({lin_p}))", exact)


def singular(p: Sequence[float], corner: Sequence[int]) -> GenzIntegrand:
    """prod (1 - p_i) |x_i - c_i|^-p_i, c_i in {0, 1}: a power singularity at a corner (not a Genz family).

    Each factor integrates to 1, so the integral is 1; the variance is
    finite for p_i < 1/2.
    """
    if len(p) != len(corner) or not p or any(c not in (0, 1) for c in corner):
        raise ValueError("p and corner must be non-empty, of the same length, corners 0 or 1")
    dist_c = [f"x[{i}]" if c == 0 else f"(1.0f - x[{i}])" for i, c in enumerate(corner)]
    dist_p = [f"x[{i}]" if c == 0 else f"(1.0 - x[{i}])" for i, c in enumerate(corner)]
    scale = math.prod(1 - pi for pi in p)
    log_c = " + ".join(f"{c_float(pi)}*log({t})" for pi, t in zip(p, dist_c))
    log_p = " + ".join(f"{py_float(pi)}*np.log({t})" for pi, t in zip(p, dist_p))
    return GenzIntegrand("singular", f"{c_float(scale)}*exp(-({log_c}))", f"{py_float(scale)}*np.exp(-({log_p}))", 1.0)
