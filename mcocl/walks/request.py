"""Checking the arguments of :func:`mcocl.solve_fredholm` (one error per mistake, naming it)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import InputError
from ..validate import whole_number
from .codegen import ESTIMATORS
from .tabulate import MAX_BINS, MAX_CELLS, TableGrid, default_grid

MAX_DIM = 8
MAX_WALK_LENGTH = (1 << 31) - 1
MAX_TABLE = 1 << 24  # entries of the transition tables (64 MiB)


def _code(name: str, v: Any) -> str:
    if not isinstance(v, str) or not v.strip():
        raise InputError(f"{name} must be OpenCL C code (an expression or a body that returns), got {v!r}")
    return v


def query_points(at: Any, dim: int) -> np.ndarray:
    """The query points as an ``(nq, dim)`` float64 array inside [0, 1]^dim.

    A flat list is accepted for dim 1 (``[0.1, 0.5]``) and as one point for dim > 1.
    """
    try:
        a = np.asarray(at, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"at must be a list of query points (each {dim} numbers), got {at!r}") from None
    if a.ndim == 0:
        a = a.reshape(1, 1)
    elif a.ndim == 1:
        a = a[:, None] if dim == 1 else a[None, :]
    if a.ndim != 2 or a.shape[0] == 0:
        raise InputError(f"at must be a non-empty list of query points, got shape {np.shape(at)}")
    if a.shape[1] != dim:
        raise InputError(f"at: the query points have {a.shape[1]} coordinates but the problem has dim={dim}")
    bad = ~np.isfinite(a) | (a < 0.0) | (a > 1.0)
    if np.any(bad):
        i = int(np.argwhere(bad)[0][0])
        raise InputError(f"at[{i}] = {a[i].tolist()} is not a point of the domain [0, 1]^{dim}")
    if len(a) > 1 << 16:
        raise InputError(f"at most {1 << 16} query points are supported, got {len(a)}")
    return a


def _samplers(name: str, v: Any, dim: int) -> list[str]:
    if isinstance(v, str):
        v = [v]
    if not isinstance(v, Sequence) or len(v) != dim:
        raise InputError(f"{name} must give one OpenCL C expression per coordinate ({dim}), got {v!r}")
    return [_code(f"{name}[{k}]", c) for k, c in enumerate(v)]


@dataclass
class WalkRequest:
    """A validated request (everything that defines the estimator)."""

    kernel: str
    source: str
    dim: int
    at: np.ndarray
    estimator: str
    seed: int
    depth: int
    survival: float  # <= 0: from the weight
    row_integral: str | None
    transition_sampler: list[str] | None
    source_integral: float | None
    source_sampler: list[str] | None
    max_walk_length: int
    grid: TableGrid

    def meta(self) -> dict[str, Any]:
        """What a checkpoint must match to be resumed by this request."""
        return {
            "kind": "solve_fredholm",
            "kernel": self.kernel,
            "source": self.source,
            "dim": self.dim,
            "at": self.at.tolist(),
            "estimator": self.estimator,
            "seed": self.seed,
            "depth": self.depth if self.estimator == "truncated" else None,
            "survival": self.survival if self.estimator == "roulette" else None,
            "row_integral": self.row_integral,
            "transition_sampler": self.transition_sampler,
            "source_integral": self.source_integral,
            "source_sampler": self.source_sampler,
            "max_walk_length": self.max_walk_length,
            "grid": self.grid.to_dict() if self.uses_tables else None,
        }

    @property
    def uses_tables(self) -> bool:
        """True when some density is tabulated."""
        if self.estimator == "subcritical":
            return self.transition_sampler is None
        if self.estimator == "nee":
            return self.transition_sampler is None or self.source_sampler is None
        return False

    def describe(self) -> str:
        """One line naming the estimator and its options."""
        if self.estimator == "truncated":
            return f"truncated Neumann series, depth {self.depth} (biased), uniform moves"
        if self.estimator == "roulette":
            p = "min(1, |weight|)" if self.survival <= 0 else f"{self.survival:g}"
            return f"Russian roulette, survival P = {p}, uniform moves"
        moves = ("user's transition sampler and row integral" if self.transition_sampler
                 else f"tabulated |K(x, .)| ({self.grid.cells}^{self.dim} cells, {self.grid.bins}^{self.dim} bins)")
        s = f"subcritical moves ~ |K| ({moves}), survival min(1, integral |K|)"
        if self.estimator == "nee":
            src = "user's source sampler" if self.source_sampler else "tabulated |g|"
            s = f"next-event estimation (zeta ~ |g|, {src}), " + s
        return s


def validate(
    kernel: Any, source: Any, dim: Any, at: Any, estimator: Any, seed: Any, depth: Any, survival: Any,
    row_integral: Any, transition_sampler: Any, source_integral: Any, source_sampler: Any,
    max_walk_length: Any, table_cells: Any, table_bins: Any,
) -> WalkRequest:
    """Check every argument; raise :class:`InputError` naming the first bad one."""
    kernel = _code("kernel", kernel)
    source = _code("source", source)
    dim = whole_number("dim", dim, 1, MAX_DIM)
    pts = query_points(at, dim)
    if estimator not in ESTIMATORS:
        raise InputError(f"estimator: unknown estimator {estimator!r}; choose one of {', '.join(ESTIMATORS)}")
    seed = whole_number("seed", seed, 0, 2**64 - 1)
    if seed >= 2**64:
        raise InputError(f"seed must be below 2**64, got {seed}")
    depth = whole_number("depth", depth, 0, 1 << 20)
    if estimator != "roulette" and survival not in (None, "weight"):
        raise InputError(f"survival applies to estimator='roulette' only (got estimator={estimator!r})")
    if survival is None or survival == "weight":
        surv = 0.0
    else:
        try:
            surv = float(survival)
        except (TypeError, ValueError):
            raise InputError(f"survival must be 'weight' or a probability in (0, 1], got {survival!r}") from None
        if not 0.0 < surv <= 1.0:
            raise InputError(f"survival must be 'weight' or a probability in (0, 1], got {survival!r}")
    if (row_integral is None) != (transition_sampler is None):
        raise InputError("a transition sampler needs both row_integral= (A(x) = integral of |K(x, y)| dy) "
                         "and transition_sampler= (the inverse CDF of |K(x, .)| / A(x), one expression per coordinate)")
    if row_integral is not None:
        if estimator not in ("subcritical", "nee"):
            raise InputError(f"row_integral/transition_sampler apply to the subcritical and nee estimators, not {estimator!r}")
        row_integral = _code("row_integral", row_integral)
        transition_sampler = _samplers("transition_sampler", transition_sampler, dim)
    if (source_integral is None) != (source_sampler is None):
        raise InputError("a source sampler needs both source_integral= (G = integral of |g|) and "
                         "source_sampler= (the inverse CDF of |g| / G, one expression per coordinate)")
    if source_integral is not None:
        if estimator != "nee":
            raise InputError(f"source_integral/source_sampler apply to the nee estimator, not {estimator!r}")
        try:
            source_integral = float(source_integral)
        except (TypeError, ValueError):
            raise InputError(f"source_integral must be a positive number, got {source_integral!r}") from None
        if not (math.isfinite(source_integral) and source_integral > 0):
            raise InputError(f"source_integral must be a positive number, got {source_integral!r}")
        source_sampler = _samplers("source_sampler", source_sampler, dim)
    max_len = whole_number("max_walk_length", max_walk_length, 1, MAX_WALK_LENGTH)
    if estimator == "truncated" and depth > max_len:
        raise InputError(f"depth ({depth}) exceeds max_walk_length ({max_len})")
    cells = whole_number("table_cells", table_cells, 1) if table_cells is not None else None
    bins = whole_number("table_bins", table_bins, 1) if table_bins is not None else None
    if bins is not None and bins & (bins - 1):
        raise InputError(f"table_bins must be a power of two (the tables are exact alias tables), got {bins}")
    grid = default_grid(dim, cells, bins)
    if grid.ncells > MAX_CELLS:
        raise InputError(f"table_cells: {grid.cells}^{dim} = {grid.ncells} cells; at most {MAX_CELLS} are supported")
    if grid.nbins > MAX_BINS:
        raise InputError(f"table_bins: {grid.bins}^{dim} = {grid.nbins} bins; at most {MAX_BINS} are supported")
    if grid.ncells * grid.nbins > MAX_TABLE:
        raise InputError(f"table_cells x table_bins: {grid.ncells} cells x {grid.nbins} bins is more than "
                         f"{MAX_TABLE} table entries")
    return WalkRequest(kernel, source, dim, pts, estimator, seed, depth, surv, row_integral, transition_sampler,
                       source_integral, source_sampler, max_len, grid)
