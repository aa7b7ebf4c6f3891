"""Proposal densities for importance sampling and combined estimators.

A proposal on [0, 1]^dim is a product of *factors*, each covering one or two
consecutive dimensions (lecture: "Vzorkování podle důležitosti": draw
xi = P^-1(tau) with tau uniform, estimate f(xi) / p(xi)).  The factors:

==================  =====  ============================================  ==============================
factor              dims   density on [0, 1]                             parameters
==================  =====  ============================================  ==============================
``uniform()``       1      1                                             —
``exponential(r)``  1      r e^(-r x) / (1 - e^(-r))                     rate r != 0, abs(r) <= 80
``power(a)``        1      (a + 1) x^a                                   a > -1
``truncnorm(m, s)`` 1      normal(m, s) restricted to [0, 1]             s > 0
``analytic(p, q)``  1      user OpenCL: pdf ``p`` over ``x``,            must integrate to 1; ``q`` the
                           inverse CDF ``q`` over ``u``                  inverse of the CDF of ``p``
``tabulated(w)``    1      piecewise constant, bin i has weight w[i]     w >= 0, finite, not all 0
``tabulated2d(w)``  2      piecewise constant on a grid, w[i, j] on      same
                           cell (i, j) of dims (k, k+1)
==================  =====  ============================================  ==============================

Each factor knows how to emit its OpenCL warp and pdf (``kernels/sampling``)
and has NumPy twins of its pdf and CDF, used by tests as an independent
reference.  Parameters are baked into the generated source as literals; tables
travel in one ``uint`` buffer.
"""

from __future__ import annotations

import json
import math
import re
from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..errors import InputError
from ..rng import GRID_CELLS
from ..usercode import UserFunction

CDF_TOTAL = GRID_CELLS  # the resolution of the engine's uniforms (rng/uniform.cl)


def _f(v: float) -> str:
    """A float literal that round-trips."""
    return f"{float(v)!r}f".replace("inf", "INFINITY")


def _d(v: float) -> str:
    """A double literal that round-trips."""
    return repr(float(v))


def _num(name: str, value: Any, where: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{where}: {name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise InputError(f"{where}: {name} must be finite, got {value!r}")
    return v


class Factor(ABC):
    """One factor of a product proposal, covering ``ndim`` consecutive dimensions."""

    ndim: int = 1
    kind: str = ""

    @abstractmethod
    def spec(self) -> dict[str, Any]:
        """A JSON-serialisable description (``{"type": ..., parameters}``)."""

    def users(self, tag: str) -> tuple[UserFunction, ...]:
        """User snippets this factor needs (analytic proposals only)."""
        return ()

    def tables(self) -> list[np.ndarray]:
        """uint32 tables this factor reads on the device."""
        return []

    @abstractmethod
    def warp_code(self, tag: str, u: list[str], x: list[str], pdf: str, tabs: list[str]) -> str:
        """C statements: set ``x[k]`` from uniforms ``u[k]`` and multiply ``pdf`` by the density."""

    @abstractmethod
    def pdf_code(self, tag: str, x: list[str], tabs: list[str]) -> str:
        """A C expression: the density at ``x``."""

    @abstractmethod
    def pdf_np(self, x: np.ndarray) -> np.ndarray:
        """NumPy twin of the density; ``x`` has shape ``(n, ndim)``."""

    def __repr__(self) -> str:
        return f"{type(self).__name__}({json.dumps(self.spec())})"


class Uniform(Factor):
    """The uniform density on [0, 1] (no importance sampling in this dimension)."""

    kind = "uniform"

    def spec(self) -> dict[str, Any]:
        return {"type": "uniform"}

    def warp_code(self, tag, u, x, pdf, tabs):
        return f"{x[0]} = {u[0]};"

    def pdf_code(self, tag, x, tabs):
        return "(floatv)(1.0f)"

    def pdf_np(self, x):
        return np.ones(len(x))

    def cdf_np(self, x: np.ndarray) -> np.ndarray:
        """Exact CDF."""
        return np.clip(x, 0, 1)


class Exponential(Factor):
    """Exponential density with ``rate`` truncated to [0, 1]; a negative rate grows towards 1."""

    kind = "exponential"

    def __init__(self, rate: float) -> None:
        r = _num("rate", rate, "exponential proposal")
        if r == 0 or abs(r) > 80:
            raise InputError(f"exponential proposal: rate must be nonzero with |rate| <= 80, got {rate!r}")
        self.rate = r
        a = abs(r)
        self._em1 = math.expm1(-a)
        self._norm = a / -self._em1

    def spec(self):
        return {"type": "exponential", "rate": self.rate}

    def warp_code(self, tag, u, x, pdf, tabs):
        a = abs(self.rate)
        core = f"warp_exponential({u[0]}, {_f(a)}, {_f(self._em1)}, {_f(self._norm)}, &p_)"
        if self.rate > 0:
            return f"{{ floatv p_; {x[0]} = {core}; {pdf} *= p_; }}"
        return f"{{ floatv p_; {x[0]} = 1.0f - {core}; {pdf} *= p_; }}"

    def pdf_code(self, tag, x, tabs):
        a = abs(self.rate)
        arg = x[0] if self.rate > 0 else f"(1.0f - {x[0]})"
        return f"pdf_exponential({arg}, {_f(a)}, {_f(self._norm)})"

    def _t(self, x: np.ndarray) -> np.ndarray:
        return x if self.rate > 0 else 1.0 - x

    def pdf_np(self, x):
        t = self._t(np.asarray(x)[:, 0])
        return self._norm * np.exp(-abs(self.rate) * t)

    def cdf_np(self, x: np.ndarray) -> np.ndarray:
        """Exact CDF."""
        a = abs(self.rate)
        c = np.expm1(-a * np.clip(x, 0, 1)) / self._em1
        return c if self.rate > 0 else 1.0 - np.expm1(-a * (1 - np.clip(x, 0, 1))) / self._em1


class Power(Factor):
    """Power law ``(a + 1) x^a`` on [0, 1], ``a > -1`` (matches integrable singularities at 0)."""

    kind = "power"

    def __init__(self, a: float) -> None:
        v = _num("a", a, "power proposal")
        if v <= -1:
            raise InputError(f"power proposal: exponent a must be > -1 (the density must be integrable), got {a!r}")
        self.a = v

    def spec(self):
        return {"type": "power", "a": self.a}

    def warp_code(self, tag, u, x, pdf, tabs):
        return f"{{ floatv p_; {x[0]} = warp_power({u[0]}, {_f(self.a)}, &p_); {pdf} *= p_; }}"

    def pdf_code(self, tag, x, tabs):
        return f"pdf_power({x[0]}, {_f(self.a)})"

    def pdf_np(self, x):
        return (self.a + 1) * np.asarray(x)[:, 0] ** self.a

    def cdf_np(self, x: np.ndarray) -> np.ndarray:
        """Exact CDF."""
        return np.clip(x, 0, 1) ** (self.a + 1)


def _phi_cdf(z: float) -> float:
    return 0.5 * math.erfc(-z / math.sqrt(2.0))


class TruncNormal(Factor):
    """Normal density with mean ``mu`` and deviation ``sigma`` restricted to [0, 1]."""

    kind = "truncnorm"

    def __init__(self, mu: float, sigma: float) -> None:
        self.mu = _num("mu", mu, "truncnorm proposal")
        self.sigma = _num("sigma", sigma, "truncnorm proposal")
        if self.sigma <= 0:
            raise InputError(f"truncnorm proposal: sigma must be > 0, got {sigma!r}")
        alpha, beta = (0.0 - self.mu) / self.sigma, (1.0 - self.mu) / self.sigma
        # Sample the lower tail only: mirror z -> -z when [alpha, beta] lies above 0.
        self._sign = -1.0 if alpha > 0 else 1.0
        lo, hi = (-beta, -alpha) if alpha > 0 else (alpha, beta)
        self._plo, self._phi = _phi_cdf(lo), _phi_cdf(hi)
        self._qhi = _phi_cdf(-hi)  # 1 - Phi(hi), accurate in the upper tail
        self._z = self._phi - self._plo
        if not self._z > 1e-12:
            raise InputError(
                f"truncnorm proposal: normal(mu={mu}, sigma={sigma}) has no usable mass on [0, 1] "
                f"(mass {self._z:.3g}); move mu closer to the interval or widen sigma"
            )
        self._norm = 1.0 / (self.sigma * self._z * math.sqrt(2 * math.pi))

    def spec(self):
        return {"type": "truncnorm", "mu": self.mu, "sigma": self.sigma}

    def warp_code(self, tag, u, x, pdf, tabs):
        return (
            f"{{ floatv p_; {x[0]} = warp_truncnorm({u[0]}, {_f(self.mu)}, {_f(self.sigma)}, {_f(self._sign)}, "
            f"{_f(self._plo)}, {_f(self._qhi)}, {_f(self._z)}, {_f(self._norm)}, &p_); {pdf} *= p_; }}"
        )

    def pdf_code(self, tag, x, tabs):
        return f"pdf_truncnorm({x[0]}, {_f(self.mu)}, {_f(1.0 / self.sigma)}, {_f(self._norm)})"

    def pdf_np(self, x):
        z = (np.asarray(x)[:, 0] - self.mu) / self.sigma
        return self._norm * np.exp(-0.5 * z * z)

    def cdf_np(self, x: np.ndarray) -> np.ndarray:
        """Exact CDF (through math.erfc, independent of the kernel's quantile)."""
        from math import erfc, sqrt

        alpha = -self.mu / self.sigma
        pa = 0.5 * erfc(-alpha / sqrt(2))
        vals = [0.5 * erfc(-((v - self.mu) / self.sigma) / sqrt(2)) for v in np.clip(np.ravel(x), 0, 1)]
        return (np.array(vals) - pa) / self._z


class Analytic(Factor):
    """A user density: ``pdf`` (OpenCL C over ``float x``) and its inverse CDF (over ``float u``)."""

    kind = "analytic"

    def __init__(self, pdf: str, inverse: str) -> None:
        for name, v in (("pdf", pdf), ("inverse", inverse)):
            if not isinstance(v, str) or not v.strip():
                raise InputError(f"analytic proposal: {name} must be OpenCL C code, got {v!r}")
        self.pdf = pdf
        self.inverse = inverse

    def spec(self):
        return {"type": "analytic", "pdf": self.pdf, "inverse": self.inverse}

    def users(self, tag: str) -> tuple[UserFunction, ...]:
        return (
            UserFunction(f"{tag}.pdf", self.pdf, f"{tag}_pdf", (("x", 0),)),
            UserFunction(f"{tag}.inverse", self.inverse, f"{tag}_inv", (("u", 0),)),
        )

    def warp_code(self, tag, u, x, pdf, tabs):
        return f"{x[0]} = clamp_open01({tag}_inv({u[0]})); {pdf} *= {tag}_pdf({x[0]});"

    def pdf_code(self, tag, x, tabs):
        return f"{tag}_pdf({x[0]})"

    def pdf_np(self, x):
        raise NotImplementedError("an analytic proposal's pdf is OpenCL code; evaluate it on the device")


def quantised_cdf(weights: np.ndarray, total: int = CDF_TOTAL) -> np.ndarray:
    """Cumulative integer counts (out of ``total``) of a non-negative weight vector.

    Every bin with positive weight keeps at least one count, so the sampled
    density is positive wherever the user's is; the counts are the largest-
    remainder rounding of ``total * w / sum(w)`` otherwise.  An all-zero vector
    gets uniform counts (used for 2-D rows that are never chosen).
    """
    w = np.asarray(weights, dtype=np.float64)
    n = len(w)
    if w.sum() <= 0:
        w = np.ones(n)
    target = w / w.sum() * total
    c = np.floor(target).astype(np.int64)
    pos = w > 0
    c[pos & (c == 0)] = 1
    deficit = total - int(c.sum())
    if deficit > 0:
        rem = np.where(pos, target - np.floor(target), -1.0)
        order = np.argsort(-rem, kind="stable")
        c[order[:deficit]] += 1
    while deficit < 0:
        order = np.argsort(-c, kind="stable")
        take = min(-deficit, int(np.sum(c > 1)))
        c[order[:take]] -= 1
        deficit += take
    cum = np.zeros(n + 1, dtype=np.uint32)
    cum[1:] = np.cumsum(c)
    assert int(cum[-1]) == total
    return cum


def _check_table(w: Any, ndim: int, where: str) -> np.ndarray:
    try:
        a = np.asarray(w, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{where}: the table must be an array of numbers") from None
    if a.ndim != ndim:
        raise InputError(f"{where}: expected a {ndim}-D array, got shape {a.shape}")
    if a.size == 0:
        raise InputError(f"{where}: the table is empty")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{where}: the table has NaN or infinite entries (first at index {np.argwhere(~np.isfinite(a))[0].tolist()})")
    if np.any(a < 0):
        raise InputError(f"{where}: the table has negative weights (first at index {np.argwhere(a < 0)[0].tolist()})")
    if not np.any(a > 0):
        raise InputError(f"{where}: the table is all zero; a density needs positive mass")
    if max(a.shape) > CDF_TOTAL // 2:
        raise InputError(f"{where}: at most {CDF_TOTAL // 2} bins per axis are supported, got {a.shape}")
    return a


def _top(n: int) -> int:
    return 1 << (n.bit_length() - 1)


class Tabulated(Factor):
    """Piecewise-constant density on [0, 1]: bin i = [i/n, (i+1)/n) has weight ``weights[i]``."""

    kind = "tabulated"

    def __init__(self, weights: Any) -> None:
        self.weights = _check_table(weights, 1, "tabulated proposal")
        self.cum = quantised_cdf(self.weights)

    @property
    def nbins(self) -> int:
        """Number of bins."""
        return len(self.weights)

    def spec(self):
        return {"type": "tabulated", "weights": self.weights.tolist()}

    def tables(self):
        return [self.cum]

    def warp_code(self, tag, u, x, pdf, tabs):
        n = self.nbins
        return f"{{ floatv p_; {x[0]} = pc1_warp({tabs[0]}, {n}u, {_top(n)}u, {u[0]}, &p_); {pdf} *= p_; }}"

    def pdf_code(self, tag, x, tabs):
        return f"pc1_pdf({tabs[0]}, {self.nbins}u, {x[0]})"

    def bin_mass(self) -> np.ndarray:
        """The exact probability of each bin as the device samples it."""
        return np.diff(self.cum.astype(np.int64)) / CDF_TOTAL

    def pdf_np(self, x):
        b = np.minimum((np.asarray(x)[:, 0] * self.nbins).astype(np.int64), self.nbins - 1)
        return self.bin_mass()[b] * self.nbins


class Tabulated2D(Factor):
    """Piecewise-constant density on [0, 1]^2: cell (i, j) has weight ``weights[i, j]``.

    Sampled by the marginal over i, then the conditional of j in row i.
    """

    kind = "tabulated2d"
    ndim = 2

    def __init__(self, weights: Any) -> None:
        self.weights = _check_table(weights, 2, "tabulated2d proposal")
        na, nb = self.weights.shape
        self.marg = quantised_cdf(self.weights.sum(axis=1))
        self.cond = np.concatenate([quantised_cdf(row) for row in self.weights])

    def spec(self):
        return {"type": "tabulated2d", "weights": self.weights.tolist()}

    def tables(self):
        return [self.marg, self.cond]

    def warp_code(self, tag, u, x, pdf, tabs):
        na, nb = self.weights.shape
        return (
            f"{{ floatv p_; pc2_warp({tabs[0]}, {tabs[1]}, {na}u, {_top(na)}u, {nb}u, {_top(nb)}u, "
            f"{u[0]}, {u[1]}, &{x[0]}, &{x[1]}, &p_); {pdf} *= p_; }}"
        )

    def pdf_code(self, tag, x, tabs):
        na, nb = self.weights.shape
        return f"pc2_pdf({tabs[0]}, {tabs[1]}, {na}u, {nb}u, {x[0]}, {x[1]})"

    def cell_mass(self) -> np.ndarray:
        """The exact probability of each cell as the device samples it."""
        na, nb = self.weights.shape
        pm = np.diff(self.marg.astype(np.int64)) / CDF_TOTAL
        pc = np.diff(self.cond.astype(np.int64).reshape(na, nb + 1), axis=1) / CDF_TOTAL
        return pm[:, None] * pc

    def pdf_np(self, x):
        na, nb = self.weights.shape
        x = np.asarray(x)
        i = np.minimum((x[:, 0] * na).astype(np.int64), na - 1)
        j = np.minimum((x[:, 1] * nb).astype(np.int64), nb - 1)
        return self.cell_mass()[i, j] * na * nb


# -- constructors (the public API) -------------------------------------------


def uniform() -> Uniform:
    """The uniform factor."""
    return Uniform()


def exponential(rate: float) -> Exponential:
    """Exponential factor ``rate e^(-rate x)``, truncated to [0, 1] and normalised."""
    return Exponential(rate)


def power(a: float) -> Power:
    """Power-law factor ``(a + 1) x^a``, ``a > -1``."""
    return Power(a)


def truncnorm(mu: float, sigma: float) -> TruncNormal:
    """Normal factor N(mu, sigma^2) truncated to [0, 1] and normalised."""
    return TruncNormal(mu, sigma)


def analytic(pdf: str, inverse: str) -> Analytic:
    """User factor: ``pdf`` over ``x`` and inverse CDF over ``u``, both OpenCL C."""
    return Analytic(pdf, inverse)


def tabulated(weights: Any) -> Tabulated:
    """Piecewise-constant 1-D factor from bin weights."""
    return Tabulated(weights)


def tabulated2d(weights: Any) -> Tabulated2D:
    """Piecewise-constant 2-D factor from a grid of cell weights."""
    return Tabulated2D(weights)


_FACTORIES = {
    "uniform": (uniform, ()),
    "exponential": (exponential, ("rate",)),
    "power": (power, ("a",)),
    "truncnorm": (truncnorm, ("mu", "sigma")),
    "analytic": (analytic, ("pdf", "inverse")),
    "tabulated": (tabulated, ("weights",)),
    "tabulated2d": (tabulated2d, ("weights",)),
}
_SHORT = re.compile(r"^\s*([a-z0-9_]+)\s*(?::(.*))?$", re.S)


def factor_from_spec(obj: Any, where: str = "proposal") -> Factor:
    """A factor from a :class:`Factor`, a dict ``{"type": ...}``, a short string or a table.

    Short strings: ``"uniform"``, ``"exponential:rate=3"``, ``"power:a=-0.5"``,
    ``"truncnorm:mu=0.3,sigma=0.1"``.  A 1-D or 2-D numeric array is a table.
    """
    if isinstance(obj, Factor):
        return obj
    if isinstance(obj, np.ndarray):
        return tabulated(obj) if obj.ndim == 1 else tabulated2d(obj)
    if isinstance(obj, str):
        m = _SHORT.match(obj)
        if not m or m.group(1) not in _FACTORIES:
            raise InputError(f"{where}: unknown proposal {obj!r}; known: {', '.join(_FACTORIES)}")
        kw: dict[str, Any] = {}
        for item in filter(None, (m.group(2) or "").split(",")):
            k, eq, v = item.partition("=")
            if not eq:
                raise InputError(f"{where}: expected key=value in {obj!r}, got {item!r}")
            kw[k.strip()] = v.strip()
        obj = {"type": m.group(1), **kw}
    if isinstance(obj, dict):
        kind = obj.get("type")
        if kind not in _FACTORIES:
            raise InputError(f"{where}.type: unknown proposal type {kind!r}; known: {', '.join(_FACTORIES)}")
        fn, keys = _FACTORIES[kind]
        extra = set(obj) - {"type", *keys}
        if extra:
            raise InputError(f"{where}: unknown key(s) {sorted(extra)} for a {kind} proposal (expected {list(keys)})")
        missing = [k for k in keys if k not in obj]
        if missing:
            raise InputError(f"{where}: a {kind} proposal needs {missing}")
        try:
            return fn(**{k: obj[k] for k in keys})
        except InputError as e:
            raise InputError(f"{where}: {e}") from None
    raise InputError(f"{where}: cannot make a proposal from {obj!r}")


class Proposal:
    """A product density on [0, 1]^dim: factors covering consecutive dimensions."""

    def __init__(self, factors: Sequence[Factor], dim: int) -> None:
        self.factors = list(factors)
        covered = sum(f.ndim for f in self.factors)
        if covered != dim:
            raise InputError(f"proposal covers {covered} dimension(s) but the integrand has dim={dim}")
        self.dim = dim

    @classmethod
    def parse(cls, obj: Any, dim: int, where: str = "proposal") -> Proposal:
        """Build from a Proposal, one factor spec (repeated over 1-D dims when it is 1-D) or a list of them."""
        if isinstance(obj, Proposal):
            if obj.dim != dim:
                raise InputError(f"{where}: proposal is {obj.dim}-D but dim={dim}")
            return obj
        is_numeric_list = isinstance(obj, (list, tuple)) and obj and all(isinstance(v, (int, float)) for v in obj)
        if isinstance(obj, (list, tuple)) and not is_numeric_list:
            return cls([factor_from_spec(o, f"{where}[{i}]") for i, o in enumerate(obj)], dim)
        f = factor_from_spec(np.asarray(obj) if is_numeric_list else obj, where)
        if f.ndim == 1 and dim > 1:
            return cls([f] * dim, dim)
        return cls([f], dim)

    def spec(self) -> list[dict[str, Any]]:
        """JSON description, a list of factor specs."""
        return [f.spec() for f in self.factors]

    def pdf_np(self, x: np.ndarray) -> np.ndarray:
        """NumPy twin of the product density; ``x`` has shape ``(n, dim)``."""
        x = np.asarray(x, dtype=np.float64)
        p = np.ones(len(x))
        k = 0
        for f in self.factors:
            p *= f.pdf_np(x[:, k : k + f.ndim])
            k += f.ndim
        return p
