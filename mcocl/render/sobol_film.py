"""The render sampler ``sobol``: per-pixel randomised quasi-Monte Carlo, and its honest variance.

The samples of a pixel are Owen-scrambled Sobol' points
(kernels/samplers/sobol_sampler.cl): sample s of batch b in pixel p is point s
of the scrambling (b, p) (kernels/render/integrator.cl, ``RENDER_SOBOL``),
every dimension of which has its own scrambling seed, a Philox word of
(seed, b * W * H + p, dimension).  So pixels and dimensions are decorrelated
(as the per-pixel seeds of Burley 2020, "Practical Hash-based Owen
Scrambling", JCGT 9(4), and pbrt-v4's ZSobolSampler), and the
``spp_per_block`` samples of a batch are one RQMC replicate of the pixel.

The variance.  Within a batch the samples of a pixel are *not* independent
(that is what makes them better), so the per-sample variance of
:mod:`mcocl.render.film` would be wrong.  The batches are independent
scramblings, so, as the splatting film of :mod:`mcocl.render.splat_film` does
for light tracing, :func:`block_batches` turns every block's sums into one
**batch** per pixel of the block: ``Y_b = (sum of its finite samples) / (their number)``, stored as
one "sample" of the film's columns (sum Y_b, sum Y_b^2, count 1).  With B
batches, :func:`mcocl.render.film.film_image` then gives the mean of the Y_b
and var(Y_b) / B, the variance of that mean; ``count`` is the number of
batches.  The Y_b are independent with the pixel's mean as their common
expectation, so E[var(Y_b)] is the average of their variances and var(Y_b) / B
is unbiased for the variance of the pixel mean, also when a last partial
batch is shorter than the others.

How many batches.  Every batch is a net of its own, and small nets keep
little stratification: at 64 spp, 16 batches of 4 samples left the Cornell box
3.3x the MSE of one 64-sample net (bench/render_sobol_batches.py, README).
So a render of ``spp`` samples takes :data:`DEFAULT_BATCHES` batches of
ceil(spp / B) samples (:func:`sobol_spp_per_block`; ``batches`` of
mcocl/render/api.py, ``--batches`` of the CLI, scene key ``integrator.batches``): B - 1 degrees of freedom per
pixel, an unbiased but noisy per-pixel variance.  The relative error that
``target_error`` bounds is a mean over pixels of sqrt(variance) / mean, and
E[sqrt(s^2)] = c4(B) sigma < sigma for B normal batch means
(:func:`stderr_bias`: 0.92 for B = 4); :func:`batch_relative_error` divides
it out (exact for normal batch means; heavy-tailed pixels still read low).

Blocks and batches.  One of B = 4 batches is many paths (1024 spp on 256 x 256
pixels: 2^24 a batch), too many for one scheduler block, the kernel launch that Ctrl-C,
a time budget and a checkpoint wait for and that devices share.  So
:func:`sobol_block_pixels` cuts a batch into T blocks of consecutive pixels,
each about the paths of an independent-sampler block: block k renders the
pixel range t = k mod T of batch b = k // T (the same scrambling (b, p) and
points as one whole-film block would), and :func:`block_batches` gives it Y_b,
Y_b^2 and count 1 on its pixels, zeros elsewhere.  The ranges are disjoint and
adding a zero changes no bit, so the block-order fold of a batch's T blocks is
exactly the whole batch's statistics: the image is bit-identical whatever T.
The zeros are never made: a block reaches the fold as its range's rows
(:class:`mcocl.accumulate.RowRanges`), since a whole-film array per block made
the host's fold cost T times the film per batch (quadratic in the pixels).
A run that stops inside a batch (Ctrl-C) leaves the pixels of
its missing ranges one batch short: ``count`` is per pixel, so their mean and
variance come from their own batches (a pixel of one batch has the variance
NaN, as any pixel of count < 2, and is left out of the relative error).
Time- or noise-halted runs keep whole-film batches of the default size (their
number of batches is what the variance needs, so they are not made larger).
"""

from __future__ import annotations

import math

import numpy as np

from ..layouts import FilmStat

# Sobol' dimensions in the table of a render build (32 KiB of constant memory):
# the camera's 4 and 8 per vertex, so paths up to depth 30 draw Sobol' coordinates
# and deeper vertices the padded ones of kernels/samplers/sobol_sampler.cl.
RENDER_TABLE_DIMS = 256
# log2 of the points per scrambling of every render build with blocks of at most 2^12 samples
# (time-halted blocks have at most 64: mcocl/render/job.py, default_spp_per_block; renders of up
# to 16,384 spp in DEFAULT_BATCHES batches share the build).  The images do not depend on it
# (sobol_render_defines); 8 before the batches grew, with the same bits.
RENDER_LOG2_POINTS = 12
# Batches (independent scramblings) per pixel of a render with a given spp: 3 degrees of freedom
# for the variance, nets of spp / 4 samples (bench/render_sobol_batches.py measures the trade).
DEFAULT_BATCHES = 4
# The fewest batches a variance can come from (var(Y_b) needs two).
MIN_BATCHES = 2
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


def sobol_spp_per_block(default: int, spp: int | None, batches: int, bounded_by_spp: bool) -> int:
    """Samples per pixel of a batch (one scrambling per pixel; its blocks: :func:`sobol_block_pixels`).

    A render bounded by its ``spp`` alone gets ``batches`` batches of ceil(spp / batches) samples
    (fewer when spp < batches).  Under time or noise halting (``bounded_by_spp`` False) the
    run's length is unknown: batches are ``default`` samples (a power of two, a whole net of about
    2^20 paths: mcocl/render/job.py, default_spp_per_block), and fewer when an upper bound ``spp``
    would leave less than ``batches`` of them; the number of batches then grows with the run.
    """
    if spp is None:
        return default
    whole = -(-int(spp) // int(batches))
    return whole if bounded_by_spp else max(1, min(default, whole))


def sobol_block_pixels(spp_per_block: int, paths_per_block: int, width: int, height: int, tile_pixels: int) -> int:
    """The pixels of one block of a batch of ``spp_per_block`` samples (0: the whole film, T = 1).

    A block gets about ``paths_per_block`` paths (an independent-sampler block's:
    mcocl/render/job.py, default_spp_per_block): T = ceil(spp_per_block * W * H / paths_per_block)
    ranges of equal length, rounded up to whole work-item tiles of ``tile_pixels``.
    """
    npix = int(width) * int(height)
    ranges = -(-int(spp_per_block) * npix // max(int(paths_per_block), 1))
    if ranges <= 1:
        return 0
    pixels = -(-npix // ranges)
    pixels = -(-pixels // tile_pixels) * tile_pixels
    return pixels if pixels < npix else 0


def stderr_bias(batches: np.ndarray | int) -> np.ndarray:
    """c4(B) = E[s] / sigma for the sample standard deviation s of B independent normal values.

    c4(B) = sqrt(2 / (B - 1)) Gamma(B / 2) / Gamma((B - 1) / 2) (s^2 (B - 1) / sigma^2 is chi-square
    with B - 1 degrees of freedom); NaN below B = 2.  0.798 for B = 2, 0.921 for 4, 0.984 for 16.
    """
    b = np.asarray(batches, dtype=np.float64)
    ok = b >= 2
    bb = np.where(ok, b, 2.0)
    def log_gamma_ratio(v: float) -> float:  # log(Gamma(v / 2) / Gamma((v - 1) / 2))
        return math.lgamma(v / 2.0) - math.lgamma((v - 1.0) / 2.0)

    whole = bb.astype(np.int64)
    if bb.size and np.array_equal(whole, bb) and whole.max() <= 1 << 16:
        # batch counts are whole numbers: one lgamma per count up to the largest, then a lookup
        # (np.vectorize over a 256 x 256 film took 4 ms of every render's epilogue)
        table = np.zeros(whole.max() + 1)
        table[2:] = [log_gamma_ratio(float(v)) for v in range(2, whole.max() + 1)]
        lg = table[whole]
    else:
        lg = np.vectorize(log_gamma_ratio, otypes=[np.float64])(bb)
    c4 = np.sqrt(2.0 / (bb - 1.0)) * np.exp(lg)
    return np.where(ok, c4, np.nan)


def batch_relative_error(mean: np.ndarray, variance: np.ndarray, count: np.ndarray) -> float:
    """The relative error of :func:`mcocl.render.film.relative_error` with each pixel's stderr divided by c4(B).

    ``count`` (H, W) is the pixel's number of batches B: sqrt(var(Y_b) / B) underestimates the standard
    error by the factor :func:`stderr_bias` on average (normal batch means), which matters for few batches.
    Mean over pixels and channels with a positive mean and a finite variance; NaN if there are none.
    """
    m = np.asarray(mean, dtype=np.float64)
    v = np.asarray(variance, dtype=np.float64)
    c4 = np.broadcast_to(stderr_bias(np.asarray(count, dtype=np.float64))[..., None], m.shape)
    ok = (m > 0) & np.isfinite(v) & np.isfinite(c4)
    if not ok.any():
        return math.nan
    return float(np.mean(np.sqrt(v[ok]) / (c4[ok] * m[ok])))


def block_batches(stats: np.ndarray) -> np.ndarray:
    """(nblocks, H, W, STATS) per-block sums -> the same shape of batch statistics (see the module docstring).

    A pixel whose block has no finite sample gets count 0 (its non-finite count is kept).
    """
    t = np.asarray(stats)
    # only the sums and counts go through float64, not the whole film (2.3 -> 1.6 ms of host time per
    # 256 x 256 fold); the same bits
    n = t[..., FilmStat.SAMPLES:FilmStat.SAMPLES + 1].astype(np.float64)
    seen = n > 0
    y = np.divide(t[..., _SUM], n, out=np.zeros(t.shape[:-1] + (3,)), where=seen)
    out = np.empty_like(t)
    out[..., _SUM] = y
    out[..., _SUMSQ] = y * y
    out[..., FilmStat.SAMPLES] = seen[..., 0]
    out[..., FilmStat.NONFINITE] = t[..., FilmStat.NONFINITE]
    return out


__all__ = ["DEFAULT_BATCHES", "MIN_BATCHES", "RENDER_TABLE_DIMS", "batch_relative_error", "block_batches",
           "sobol_block_pixels", "sobol_render_defines", "sobol_spp_per_block", "stderr_bias"]
