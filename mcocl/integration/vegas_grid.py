"""The VEGAS grid: a separable piecewise-constant density on [0, 1]^dim and its refinement.

Lepage, "A new algorithm for adaptive multidimensional integration",
J. Comput. Phys. 27 (1978) 192-203.  Each dimension is cut into ``bins``
intervals of equal probability 1/bins; a narrow bin is a high density.  The
device applies the map (kernels/sampling/vegas_grid.cl) and returns, per
dimension and bin, the sum of (f J)^2 over the samples that fell in the bin;
:meth:`VegasGrid.refine` turns those sums into the next grid:

1. smoothing (Lepage 1978): m_i <- (m_{i-1} + m_i + m_{i+1}) / 3, the
   end bins averaged with their one neighbour;
2. normalisation r_i = m_i / sum m and damping with exponent alpha
   (Lepage 1978): r_i <- ((1 - r_i) / ln(1 / r_i))^alpha, which
   compresses the range of r and so slows the adaptation and keeps it stable;
3. a floor: every r_i at least FLOOR times the mean, so no region the
   training happened to miss loses its density (an estimator stays unbiased
   only where the density is positive, and bounded weights keep its variance
   finite);
4. new edges that give every new bin the same share of sum r, the weight of
   an old bin spread uniformly across it (a piecewise-linear CDF, inverted).

The fixed point of 1-4 with alpha -> 0 weights would be uniform; with the
(f J)^2 sums it is p_d proportional to the square root of the marginal of f^2/p
over the other dimensions, the separable density of least variance.

Edges are kept as float32 values (the device reads float); the widths are
differences of those rounded edges, so the bins tile [0, 1] exactly as the
device sees them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError

FLOOR = 1e-3
MIN_BINS = 2
MAX_BINS = 4096


def check_bins(bins: object) -> int:
    """``bins`` as an int: a power of two in [MIN_BINS, MAX_BINS] (the device map is exact for powers of two)."""
    if isinstance(bins, bool) or not isinstance(bins, (int, np.integer)):
        raise InputError(f"vegas_bins must be a power of two from {MIN_BINS} to {MAX_BINS}, got {bins!r}")
    b = int(bins)
    if not MIN_BINS <= b <= MAX_BINS or b & (b - 1):
        raise InputError(f"vegas_bins must be a power of two from {MIN_BINS} to {MAX_BINS}, got {b}")
    return b


@dataclass(frozen=True)
class VegasGrid:
    """Bin edges per dimension: ``edges[d]`` = 0 = e_0 < e_1 < ... < e_bins = 1 (float32 values)."""

    edges: np.ndarray  # (dim, bins + 1) float64 holding float32 values

    @classmethod
    def uniform(cls, dim: int, bins: int) -> VegasGrid:
        """Equal bins: the map is the identity and J = 1."""
        e = np.linspace(0.0, 1.0, bins + 1)
        return cls(_float_edges(np.tile(e, (dim, 1))))

    @classmethod
    def from_list(cls, edges: list[list[float]]) -> VegasGrid:
        """The grid saved by :meth:`to_list` (checkpoints)."""
        return cls(_float_edges(np.asarray(edges, dtype=np.float64)))

    def to_list(self) -> list[list[float]]:
        """JSON form (float32 values print and parse back exactly as float64)."""
        return self.edges.tolist()

    @property
    def dim(self) -> int:
        """Dimensions."""
        return self.edges.shape[0]

    @property
    def bins(self) -> int:
        """Bins per dimension."""
        return self.edges.shape[1] - 1

    def widths(self) -> np.ndarray:
        """(dim, bins) bin widths as the device uses them (float32 differences of the edges)."""
        e = self.edges.astype(np.float32)
        return (e[:, 1:] - e[:, :-1]).astype(np.float64)

    def device_table(self) -> np.ndarray:
        """The float32 buffer of kernels/sampling/vegas_grid.cl: all bin starts, then all widths."""
        e = self.edges.astype(np.float32)
        return np.concatenate([e[:, :-1].ravel(), (e[:, 1:] - e[:, :-1]).ravel()]).astype(np.float32)

    def refine(self, train: np.ndarray, alpha: float) -> VegasGrid:
        """The next grid from the per-bin sums of (f J)^2, ``train`` of shape (dim, bins) (module docstring)."""
        train = np.asarray(train, dtype=np.float64).reshape(self.dim, self.bins)
        rows = [self._refine_row(self.edges[d], train[d], alpha) for d in range(self.dim)]
        return VegasGrid(_float_edges(np.array(rows)))

    @staticmethod
    def _refine_row(edges: np.ndarray, m: np.ndarray, alpha: float) -> np.ndarray:
        if not np.all(np.isfinite(m)) or m.sum() <= 0:
            return edges  # nothing learnt in this dimension: keep it
        s = np.empty_like(m)
        if len(m) == 1:
            s[:] = m
        else:
            s[1:-1] = (m[:-2] + m[1:-1] + m[2:]) / 3.0
            s[0] = (m[0] + m[1]) / 2.0
            s[-1] = (m[-2] + m[-1]) / 2.0
        r = s / s.sum()
        damped = np.zeros_like(r)
        inner = (r > 0) & (r < 1)
        damped[inner] = ((1.0 - r[inner]) / np.log(1.0 / r[inner])) ** alpha
        damped[r >= 1] = 1.0
        damped = np.maximum(damped, FLOOR * damped.mean())
        cum = np.concatenate([[0.0], np.cumsum(damped)])
        targets = np.arange(1, len(m)) * (cum[-1] / len(m))
        return np.concatenate([[0.0], np.interp(targets, cum, edges), [1.0]])


def _float_edges(edges: np.ndarray) -> np.ndarray:
    """Edges rounded to float32, 0 and 1 at the ends, strictly increasing in float32."""
    e = np.asarray(edges, dtype=np.float64).astype(np.float32)
    e[:, 0] = 0.0
    e[:, -1] = 1.0
    bins = e.shape[1] - 1
    for row in e:
        if np.all(row[1:] > row[:-1]):
            continue
        for k in range(1, bins + 1):
            if row[k] <= row[k - 1]:
                row[k] = np.nextafter(row[k - 1], np.float32(2.0))
        if row[-1] > 1.0:  # pushed past 1 by a crowd of equal edges: give the room back from the top
            row[-1] = 1.0
            for k in range(bins - 1, 0, -1):
                if row[k] >= row[k + 1]:
                    row[k] = np.nextafter(row[k + 1], np.float32(-1.0))
    return e.astype(np.float64)
