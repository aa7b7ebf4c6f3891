"""The render sampler ``sobol``: per-pixel randomised quasi-Monte Carlo, and its honest variance.

The samples of a pixel are Owen-scrambled Sobol' points
(kernels/samplers/sobol_sampler.cl): sample s of block b in pixel p is point s
of the scrambling (b, p) (kernels/render/integrator.cl, ``RENDER_SOBOL``),
every dimension of which has its own scrambling seed, a Philox word of
(seed, b * W * H + p, dimension).  So pixels and dimensions are decorrelated
(as the per-pixel seeds of Burley 2020, "Practical Hash-based Owen
Scrambling", JCGT 9(4), and pbrt-v4's ZSobolSampler), and the
``spp_per_block`` samples of a block are one RQMC replicate of the pixel.

The variance.  Within a block the samples of a pixel are *not* independent
(that is what makes them better), so the per-sample variance of
:mod:`mcocl.render.film` would be wrong.  The blocks are independent
scramblings, so, as the splatting film of :mod:`mcocl.render.splat_film` does
for light tracing, :func:`block_batches` turns every block into one **batch**
per pixel: ``Y_b = (sum of its finite samples) / (their number)``, stored as
one "sample" of the film's columns (sum Y_b, sum Y_b^2, count 1).  With B
blocks, :func:`mcocl.render.film.film_image` then gives the mean of the Y_b
and var(Y_b) / B, the variance of that mean; ``count`` is the number of
batches.  A render therefore needs at least two blocks for a variance:
:func:`sobol_spp_per_block` picks blocks small enough for MIN_BATCHES of them,
and ``target_error`` halting waits for MIN_BATCHES (mcocl/render/api.py).
"""

from __future__ import annotations

import numpy as np

from ..layouts import FilmStat
from .splat_film import MIN_BATCHES, splat_spp_per_block

# Sobol' dimensions in the table of a render build (32 KiB of constant memory):
# the camera's 4 and 8 per vertex, so paths up to depth 30 draw Sobol' coordinates
# and deeper vertices the padded ones of kernels/samplers/sobol_sampler.cl.
RENDER_TABLE_DIMS = 256
# log2 of the points per scrambling of every render build with blocks of at most 2^8 samples
# (default blocks have at most 64: mcocl/render/job.py, default_spp_per_block).
RENDER_LOG2_POINTS = 8
_SUM = slice(FilmStat.SUM_R, FilmStat.SUM_B + 1)
_SUMSQ = slice(FilmStat.SUMSQ_R, FilmStat.SUMSQ_B + 1)


def sobol_render_defines(spp_per_block: int) -> list[str]:
    """The build options of the Sobol' render: 2^m >= spp_per_block points per scrambling.

    m is at least RENDER_LOG2_POINTS whatever the block, so renders of different ``spp`` (whose
    blocks differ: :func:`sobol_spp_per_block`) share one build instead of compiling the megakernel
    again (seconds on PoCL; it was most of a 64-spp render's cost after a 1-spp one).  The numbers
    do not depend on m: the index is ((b * W * H + p) << m) + s with s < spp_per_block, so the
    scrambling is (b, p) and the point s for every m >= log2(spp_per_block), and the point's bits
    above its top set bit add nothing to the Sobol' coordinate (kernels/samplers/sobol_sampler.cl).
    """
    log2 = max(max(int(spp_per_block) - 1, 0).bit_length(), RENDER_LOG2_POINTS)
    return ["-DRENDER_SOBOL=1", "-DSAMPLER_BACKEND=SAMPLER_BACKEND_SOBOL", f"-DSOBOL_LOG2_POINTS={log2}",
            f"-DSOBOL_TABLE_DIMS={RENDER_TABLE_DIMS}"]


def sobol_spp_per_block(default: int, spp: int | None) -> int:
    """Samples per pixel of a block: a power of two (a whole (0, m, 2)-net per replicate), at most
    ``default``, small enough for MIN_BATCHES batches when ``spp`` allows; a quarter of ``default``
    for time or noise halting (spp None), so that a short run still has batches to estimate from."""
    n = splat_spp_per_block(default, spp) if spp is not None else max(1, default // 4)
    return 1 << (n.bit_length() - 1)


def block_batches(stats: np.ndarray) -> np.ndarray:
    """(nblocks, H, W, STATS) per-block sums -> the same shape of batch statistics (see the module docstring).

    A pixel whose block has no finite sample gets count 0 (its non-finite count is kept).
    """
    t = np.asarray(stats, dtype=np.float64)
    n = t[..., FilmStat.SAMPLES:FilmStat.SAMPLES + 1]
    y = np.where(n > 0, t[..., _SUM] / np.where(n > 0, n, 1.0), 0.0)
    out = np.zeros_like(t)
    out[..., _SUM] = y
    out[..., _SUMSQ] = y * y
    out[..., FilmStat.SAMPLES] = (n[..., 0] > 0).astype(np.float64)
    out[..., FilmStat.NONFINITE] = t[..., FilmStat.NONFINITE]
    return out.astype(stats.dtype)


__all__ = ["MIN_BATCHES", "RENDER_TABLE_DIMS", "block_batches", "sobol_render_defines", "sobol_spp_per_block"]
