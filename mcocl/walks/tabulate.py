"""Tabulated transition and next-event densities of the walks.

Without the user's own samplers, ``subcritical`` and ``nee`` sample

- the move from x with a density ~ |K(x, .)|: one piecewise-constant density
  per *cell* of x (``cells`` per axis), over ``bins`` per axis of y;
- next-event points zeta with a density ~ |g|, over the same bins of y.

The weights are means of |K| (|g|) over a few sub-points per cell and bin,
evaluated on the device (``kernels/walks/tabulate.cl``).  Every density is a
*defensive mixture* (Hesterberg 1995): ``(1 - DEFENSIVE)`` of the tabulated
shape plus ``DEFENSIVE`` of the uniform density, so that every bin has positive
probability — the tabulation sees K only at its sub-points, and a bin it found
empty may not be empty for every x of the cell.  The walk weighs each move by
the exact K / (q p) (``transition.cl``), so the estimate stays unbiased
whatever the table: the table only decides the variance.

The survival probability of a cell is ``q = clip(A, Q_FLOOR, 1)`` with A the
table's row integral (the mean weight); the floor keeps cells whose sub-points
all saw K = 0 reachable by an unbiased (if rare) continuation.

Sampling a bin: an alias table (Walker 1977, Vose 1991) built in integers.
A density is first quantised to counts out of 2^23, the resolution of the
engine's uniforms (rng/uniform.cl); with ``nb = 2^k`` bins every alias column
holds ``M = 2^23 / nb`` counts, and a 23-bit uniform c picks column
``c >> (23 - k)`` and compares ``c mod M`` with the column's threshold.  Bin
b is then chosen with probability exactly ``counts[b] / 2^23``, which is the
mass the walk divides by: no rounding can bias the estimate.  That is why
``bins`` per axis must be a power of two.  Sampling costs two table reads
instead of the log2(nb) of a CDF search (measured: the search was half of a
subcritical walk's time).

Tables are stored in one uint32 buffer (see ``kernels/walks/table.cl``)::

    [trans_off, q_off)   per cell: nb alias words, then nb counts (transition)
    [q_off, src_off)     ncells survival probabilities (float32 bits)
    [src_off, end)       nb alias words, nb counts (next-event source)

An alias word is ``threshold * nb + alias`` (at most 24 bits).
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import asdict, dataclass

import numpy as np

from ..layouts import WALK_TABLE_GEOMETRY
from ..rng import GRID_CELLS

DEFENSIVE = 0.05  # share of the uniform density in every tabulated density
Q_FLOOR = 1.0 / 64.0  # smallest tabulated survival probability
TOTAL = GRID_CELLS  # counts of a quantised density: the resolution of the engine's uniforms
MAX_BINS = 1 << 16  # bins of y (all axes together) a table may have
MAX_CELLS = 1 << 12  # cells of x (all axes together)


@dataclass(frozen=True)
class TableGrid:
    """The tabulation grid: ``cells`` per axis of x, ``bins`` per axis of y (a power of two).

    ``sub_x`` / ``sub_y``: sub-points per axis at which K is averaged in a
    cell / bin.
    """

    dim: int
    cells: int
    bins: int
    sub_x: int = 2
    sub_y: int = 2

    @property
    def ncells(self) -> int:
        """Cells of x, all axes together."""
        return self.cells**self.dim

    @property
    def nbins(self) -> int:
        """Bins of y, all axes together."""
        return self.bins**self.dim

    @property
    def log2_nbins(self) -> int:
        """k with nbins = 2^k."""
        return self.nbins.bit_length() - 1

    def to_dict(self) -> dict[str, int]:
        """JSON-ready fields (checkpoint metadata)."""
        return asdict(self)


def default_grid(dim: int, cells: int | None = None, bins: int | None = None) -> TableGrid:
    """The grid used unless the caller chooses: at most 4096 bins and about 256 cells in all.

    1-D: 128 cells x 256 bins (4 sub-points per bin); 2-D: 16 x 16 cells,
    32 x 32 bins; higher dimensions fewer per axis (bins a power of two).
    """
    if dim == 1:
        c, b, sy = 128, 256, 4
    elif dim == 2:
        c, b, sy = 16, 32, 2
    else:
        c = max(1, int(math.floor(256 ** (1.0 / dim) + 1e-9)))
        b = 1 << max(1, int(math.floor(math.log2(4096) / dim + 1e-9)))
        sy = 1 if dim > 3 else 2
    return TableGrid(dim, cells if cells is not None else c, bins if bins is not None else b, 2 if dim <= 3 else 1, sy)


@dataclass
class WalkTables:
    """The walk's table buffer and where each part starts."""

    data: np.ndarray  # uint32
    grid: TableGrid
    trans_off: int = 0
    q_off: int = 0
    src_off: int = 0
    nonfinite_kernel: int = 0  # tabulation weights of K that were NaN/Inf
    nonfinite_source: int = 0  # of g

    def digest(self) -> str:
        """A hash of the tables (a resumed run must sample the same densities)."""
        return hashlib.sha256(np.ascontiguousarray(self.data).tobytes()).hexdigest()[:16]

    def geometry(self) -> np.ndarray:
        """The ``walk_table_geometry`` record (mcocl/layouts.py) the walk kernels take by value."""
        g = self.grid
        rec = np.zeros((), WALK_TABLE_GEOMETRY.dtype())
        rec["nxa"], rec["nya"], rec["nb"], rec["lognb"] = g.cells, g.bins, g.nbins, g.log2_nbins
        rec["trans_off"], rec["q_off"], rec["src_off"] = self.trans_off, self.q_off, self.src_off
        return rec

    def transition_mass(self, cell: int) -> np.ndarray:
        """Probability of every bin of the transition density of ``cell``."""
        nb = self.grid.nbins
        start = self.trans_off + cell * 2 * nb + nb
        return self.data[start: start + nb].astype(np.int64) / TOTAL

    def survival(self, cell: int) -> float:
        """The survival probability q of ``cell``."""
        return float(self.data[self.q_off + cell: self.q_off + cell + 1].view(np.float32)[0])

    def source_mass(self) -> np.ndarray:
        """Probability of every bin of the next-event density."""
        nb = self.grid.nbins
        return self.data[self.src_off + nb: self.src_off + 2 * nb].astype(np.int64) / TOTAL


def mixture_counts(weights: np.ndarray) -> np.ndarray:
    """Counts out of 2^23 (rows of ``nb``) of the defensive mixtures of weight rows.

    Row r of ``weights`` (``(rows, nb)``) becomes the density
    ``(1 - DEFENSIVE) w / sum(w) + DEFENSIVE / nb``; non-finite weights count
    as 0 and a row without positive weight gives the uniform density.  The
    counts are differences of the rounded cumulative sums, so they add up to
    2^23 exactly, and every bin holds at least ``DEFENSIVE * 2^23 / nb - 1 >= 5``
    counts (nb <= MAX_BINS): no bin is ever impossible.
    """
    w = np.atleast_2d(np.asarray(weights, dtype=np.float64))
    w = np.where(np.isfinite(w), np.abs(w), 0.0)
    nb = w.shape[1]
    total = w.sum(axis=1, keepdims=True)
    ok = (total > 0) & np.isfinite(total)
    shape = np.divide(w, total, out=np.full_like(w, 1.0 / nb), where=ok)
    p = (1.0 - DEFENSIVE) * shape + DEFENSIVE / nb
    cum = np.zeros((len(w), nb + 1), dtype=np.float64)
    cum[:, 1:] = np.cumsum(p, axis=1)
    cum /= cum[:, -1:]
    c = np.rint(cum * TOTAL).astype(np.int64)
    c[:, 0] = 0
    c[:, -1] = TOTAL
    counts = np.diff(c, axis=1)
    if not np.all(counts > 0):
        raise AssertionError("a quantised mixture lost a bin")
    return counts


def alias_words(counts: np.ndarray) -> np.ndarray:
    """Alias tables (packed words ``threshold * nb + alias``) of integer count rows.

    Vose's algorithm, all rows in lock-step: a column that holds fewer than M
    counts ("small") is topped up from a "large" one, which becomes its alias.
    Everything is integer, so leftover columns hold exactly M.
    """
    counts = np.atleast_2d(np.asarray(counts, dtype=np.int64))
    rows, nb = counts.shape
    if nb & (nb - 1) or TOTAL % nb:
        raise ValueError(f"alias tables need a power-of-two number of bins, got {nb}")
    m = TOTAL // nb
    c = counts.copy()
    thr = np.full((rows, nb), m, dtype=np.int64)
    alias = np.tile(np.arange(nb, dtype=np.int64), (rows, 1))
    is_small = c < m
    order = np.argsort(~is_small, axis=1, kind="stable")  # small columns first
    ns = is_small.sum(axis=1)
    nl = nb - ns
    small = order.copy()
    large = np.take_along_axis(order, np.minimum(np.arange(nb)[None, :] + ns[:, None], nb - 1), axis=1)
    while True:
        r = np.nonzero((ns > 0) & (nl > 0))[0]
        if len(r) == 0:
            break
        ns[r] -= 1
        nl[r] -= 1
        s = small[r, ns[r]]
        big = large[r, nl[r]]
        thr[r, s] = c[r, s]
        alias[r, s] = big
        c[r, big] -= m - c[r, s]
        to_small = c[r, big] < m
        rs, rl = r[to_small], r[~to_small]
        small[rs, ns[rs]] = big[to_small]
        ns[rs] += 1
        large[rl, nl[rl]] = big[~to_small]
        nl[rl] += 1
    # every bin's probability must be exactly its counts / 2^23
    implied = thr + np.bincount((np.arange(rows)[:, None] * nb + alias).ravel(), weights=(m - thr).ravel(),
                                minlength=rows * nb).reshape(rows, nb).astype(np.int64)
    if not np.array_equal(implied, counts):
        raise AssertionError("alias table does not reproduce its counts")
    return (thr * nb + alias).astype(np.uint32)


def _table(weights: np.ndarray) -> np.ndarray:
    """Rows of [nb alias words, nb counts] for weight rows."""
    counts = mixture_counts(weights)
    return np.concatenate([alias_words(counts), counts.astype(np.uint32)], axis=1)


def build_tables(kernel_weights: np.ndarray | None, source_weights: np.ndarray | None, grid: TableGrid) -> WalkTables:
    """The table buffer from raw weights.

    Args:
        kernel_weights: ``(ncells, nbins)`` mean |K| per cell of x and bin of y, or None.
        source_weights: ``(nbins,)`` mean |g| per bin, or None.
        grid: the grid both were computed on.
    """
    parts: list[np.ndarray] = []
    nb = grid.nbins
    trans_off = 0
    bad_k = bad_g = 0
    if kernel_weights is not None:
        kw = np.asarray(kernel_weights, dtype=np.float64).reshape(grid.ncells, nb)
        bad_k = int(np.sum(~np.isfinite(kw)))
        parts.append(_table(kw).ravel())
        a = np.where(np.isfinite(kw), kw, 0.0).mean(axis=1)
        q = np.clip(a, Q_FLOOR, 1.0).astype(np.float32)
        q_off = sum(len(p) for p in parts)
        parts.append(q.view(np.uint32))
    else:
        q_off = 0
    src_off = sum(len(p) for p in parts)
    if source_weights is not None:
        sw = np.asarray(source_weights, dtype=np.float64).reshape(1, nb)
        bad_g = int(np.sum(~np.isfinite(sw)))
        parts.append(_table(sw).ravel())
    data = np.concatenate(parts).astype(np.uint32) if parts else np.zeros(1, np.uint32)
    return WalkTables(data, grid, trans_off, q_off, src_off, bad_k, bad_g)
