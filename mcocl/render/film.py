"""The film: per-pixel sums of radiance and of its square, turned into an image.

Every block of a render job adds, for every pixel, the statistics of its
samples (``STATS`` numbers, see :data:`STAT_NAMES`); the accumulator folds the
blocks in order in float64.  From the totals:

- mean          m = s1 / n                         (box filter: the plain mean of the pixel's samples)
- variance      v = (s2 - s1^2 / n) / (n - 1) / n  (the variance *of the mean*, per channel;
                                                   lecture: sigma_sec^2 = sigma_prim^2 / N)
- relative error: the mean over pixels of stderr / mean (per channel, over
  channels and pixels whose mean is positive) — the ``noise`` halting rule.

Non-finite samples (NaN or Inf in any channel) are counted in their own
column and appear in no sum.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..layouts import FilmStat

# The columns, in the order of mcocl/layouts.py's FilmStat (kernels/layouts.cl's FILM_*).
STAT_NAMES = tuple(s.name.lower() for s in FilmStat)
STATS = len(STAT_NAMES)
_N, _NONFINITE = FilmStat.SAMPLES, FilmStat.NONFINITE
_SUM = slice(FilmStat.SUM_R, FilmStat.SUM_B + 1)
_SUMSQ = slice(FilmStat.SUMSQ_R, FilmStat.SUMSQ_B + 1)


@dataclass
class FilmImage:
    """An image estimate from film totals.

    Attributes:
        mean: (H, W, 3) float32 radiance.
        variance: (H, W, 3) float32 variance of the mean (NaN where fewer than 2 samples).
        count: (H, W) float32 finite samples per pixel.
        nonfinite: total non-finite samples left out.
    """

    mean: np.ndarray
    variance: np.ndarray
    count: np.ndarray
    nonfinite: int


def film_image(totals: np.ndarray) -> FilmImage:
    """Mean, variance of the mean and sample counts from (H, W, STATS) totals."""
    t = np.asarray(totals, dtype=np.float64)
    n = t[..., _N:_N + 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(n > 0, t[..., _SUM] / np.where(n > 0, n, 1.0), np.nan)
        dev = np.maximum(t[..., _SUMSQ] - t[..., _SUM] ** 2 / np.where(n > 0, n, 1.0), 0.0)
        var = np.where(n > 1, dev / np.maximum(n - 1.0, 1.0) / np.where(n > 0, n, 1.0), np.nan)
    return FilmImage(
        mean=mean.astype(np.float32),
        variance=var.astype(np.float32),
        count=t[..., _N].astype(np.float32),
        nonfinite=int(round(float(t[..., _NONFINITE].sum()))),
    )


def relative_error(mean: np.ndarray, variance: np.ndarray) -> float:
    """Mean over pixels and channels with a positive mean of stderr / mean (NaN if there are none)."""
    m = np.asarray(mean, dtype=np.float64)
    v = np.asarray(variance, dtype=np.float64)
    ok = (m > 0) & np.isfinite(v)
    if not ok.any():
        return math.nan
    return float(np.mean(np.sqrt(v[ok]) / m[ok]))


__all__ = ["STATS", "STAT_NAMES", "FilmImage", "film_image", "relative_error"]
