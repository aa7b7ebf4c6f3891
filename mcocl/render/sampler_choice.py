"""Which render sampler a render uses: ``auto`` (the default), ``independent`` or ``sobol``.

``sobol`` (per-pixel Owen-scrambled Sobol' nets, :mod:`mcocl.render.sobol_film`)
was 1.8x-8.8x as efficient as ``independent`` (1/(MSE x seconds), one
process) on the bench's scenes whose error is direct light and pixel
coverage (bench/render_throughput.py, bench/bdpt_efficiency.py; README,
*Quasi-Monte Carlo pixels*), as pbrt-v4 (ZSobol) and Cycles, which default
to low-discrepancy samplers, expect; it lost (0.56x) on scenes/caustic.json,
whose error is a caustic through glass that the nets do not stratify, at
20-25 % more time per path, until nee and mis aimed at the glass
(mcocl/render/caster_guiding.py): since then sobol is at 0.73-1.0x of
independent's efficiency there (README, *Caustics: aiming at the glass*;
bench/caster_guiding.py gain).
Its variance comes from a few independent scramblings (batches) per pixel, so
``auto`` takes it where the render can form them and keeps ``independent``
everywhere else (:func:`resolve_auto_sampler`):

- ``lt`` splats independent samples (it has no Sobol' back end): ``independent``;
- ``bdpt`` (its Sobol' back end: kernels/render/bdpt.cl, "Quasi-Monte
  Carlo"): ``sobol`` when its batches hold 2 or more samples, i.e. an
  explicit ``spp_per_block`` of 2 or more that ``spp`` fills twice, or the
  batch sobol gives it (ceil(spp / 4) samples, at most the default block's:
  mcocl/render/splat_film.py, splat_spp_per_block; under time or target-error
  halting the default block's) of 2 or more; else ``independent``.  Measured
  (bench/bdpt_efficiency.py, 128 px, 6-s budget, batches of 64; README's
  bdpt section): sobol / independent bdpt efficiency 1.71 on the Cornell
  box with spheres, 2.27 on the plain one, 1.44 on ``veach_mis``, and on
  ``caustic`` 0.58 in one run, 1.78 in another (heavy-tailed; bdpt stays
  13x-28x ``mis`` there);
- ``batches`` given: they are sobol's alone, so ``sobol``;
- an explicit ``spp_per_block`` is the size of a batch: ``sobol`` when it
  holds at least 2 samples, at most 2^31 (a scrambling's points,
  kernels/samplers/sobol_sampler.cl), and ``spp`` (when given) fills at least
  2 batches of it; else ``independent``, whose blocks are any size;
- otherwise ``sobol`` when the default :data:`DEFAULT_BATCHES` batches each
  hold at least 2 samples (spp >= 8), or the render is halted by time or
  target error alone (no spp: batches of the default block size, their
  number growing with the run, as explicit sobol does); ``independent`` for
  spp < 8, whose 4 batches cannot all hold 2 samples (a batch of one sample
  is no net: sobol would only cost a variance of few degrees of freedom).
- a batch auto chooses is **one block over the whole film**, at most
  :data:`AUTO_BATCH_PATHS` paths: ceil(spp / 4) samples per pixel, or the
  largest power of two that fits (more batches, each a smaller net), and
  ``independent`` when not even 2 samples per pixel fit (more than 2^21
  pixels; under time or target-error halting, when the default block holds
  fewer than 2).  An explicit sobol batch larger than a block is cut into
  pixel ranges, and a render stopped inside its first batch then has pixels
  with no sample; the default must not trade a whole image at Ctrl-C (or a
  checkpoint) for stratification.  2^22 paths take about a CPU-second.

A resumed checkpoint keeps the sampler it was written with (the checkpoint's
``sampler`` key: none for ``independent``, as before the option existed), so
resuming ``auto`` reproduces the bits of the uninterrupted run, and a
checkpoint written before ``auto`` existed continues with ``independent``.
"""

from __future__ import annotations

from .job import SPLAT_INTEGRATORS, default_spp_per_block
from .sobol_film import DEFAULT_BATCHES, MIN_BATCHES
from .splat_film import BDPT_SOBOL_BLOCK, splat_spp_per_block

# The most points of one scrambling (kernels/samplers/sobol_sampler.cl: SOBOL_LOG2_POINTS <= 31).
MAX_BATCH_SPP = 1 << 31
# The fewest samples of a batch for auto to choose sobol (one point is no net).
MIN_BATCH_SPP = 2
# The most paths of a batch auto chooses: one whole-film block (the module docstring).
AUTO_BATCH_PATHS = 1 << 22


def _auto_bdpt(spp: int | None, spp_per_block: int | None, pixels: int) -> tuple[str, str, None]:
    """bdpt's auto: ``sobol`` when its batches (blocks: splat_film.splat_spp_per_block) hold 2 or more samples."""
    pixels = max(int(pixels), 1)
    if spp_per_block is not None:
        n = int(spp_per_block)
        if n * pixels > BDPT_SOBOL_BLOCK:
            return "independent", f"a block of {n} x {pixels} samples exceeds bdpt's sobol block", None
        if MIN_BATCH_SPP <= n and (spp is None or int(spp) >= MIN_BATCHES * n):
            return "sobol", f"batches of spp_per_block={n} samples", None
        return "independent", (f"spp_per_block={n} does not make {MIN_BATCHES} sobol batches of {MIN_BATCH_SPP} "
                               "or more samples" + (f" within {spp} spp" if spp is not None else "")), None
    n = splat_spp_per_block(default_spp_per_block(pixels, 1), spp, "bdpt", pixels, 1, "sobol")
    if n >= MIN_BATCH_SPP:
        return "sobol", f"batches of {n} samples", None
    return "independent", f"batches of {n} sample per pixel are no net", None


def resolve_auto_sampler(integrator: str, spp: int | None, spp_per_block: int | None,
                         batches: int | None, pixels: int,
                         bounded_by_spp: bool = True) -> tuple[str, str, int | None]:
    """(``"sobol"`` or ``"independent"``, why, batch) for ``sampler="auto"`` (the module docstring's rule).

    ``spp`` is the render's spp bound (None when only time or target error halt it),
    ``spp_per_block`` and ``batches`` the caller's (None when not given), ``pixels`` the film's;
    ``bounded_by_spp`` False when time or target error halt the render (``spp`` then an upper bound).
    ``batch``: the samples per pixel of a batch when the rule itself sized it (sobol by spp or by
    time with neither ``spp_per_block`` nor ``batches`` given: one whole-film block), else None.
    """
    if integrator == "bdpt":
        if batches is not None:
            return "sobol", "batches are the sobol sampler's", None
        return _auto_bdpt(spp, spp_per_block, pixels)
    if integrator in SPLAT_INTEGRATORS:
        return "independent", f"{integrator} has no sobol back end", None
    if batches is not None:
        return "sobol", "batches are the sobol sampler's", None
    if spp_per_block is not None:
        n = int(spp_per_block)
        if MIN_BATCH_SPP <= n <= MAX_BATCH_SPP and (spp is None or int(spp) >= MIN_BATCHES * n):
            return "sobol", f"batches of spp_per_block={n} samples", None
        why = (f"spp_per_block={n} does not make {MIN_BATCHES} sobol batches of {MIN_BATCH_SPP} or more samples"
               + (f" within {spp} spp" if spp is not None else ""))
        return "independent", why, None
    pixels = max(int(pixels), 1)
    if spp is None or not bounded_by_spp:
        n = default_spp_per_block(pixels, 1)  # the film's shape does not matter, its pixels do
        if spp is not None:  # an upper bound: still DEFAULT_BATCHES batches within it
            n = min(n, -(-int(spp) // DEFAULT_BATCHES))
        if n >= MIN_BATCH_SPP:
            return "sobol", f"time- or noise-halted: batches of {n} samples (the default block)", n
        return "independent", f"time- or noise-halted: batches of {n} sample per pixel are no net", None
    least = MIN_BATCH_SPP * DEFAULT_BATCHES
    if int(spp) < least:
        return "independent", f"{spp} spp is below the {least} that {DEFAULT_BATCHES} sobol batches of 2 samples need", None
    fits = AUTO_BATCH_PATHS // pixels  # samples per pixel of one whole-film block of at most AUTO_BATCH_PATHS
    if fits < MIN_BATCH_SPP:
        return "independent", (f"{pixels} pixels: a batch of {MIN_BATCH_SPP} samples per pixel would exceed one "
                               f"block of {AUTO_BATCH_PATHS} paths"), None
    n = -(-int(spp) // DEFAULT_BATCHES)
    if n > fits:
        n = 1 << (fits.bit_length() - 1)
    return "sobol", f"{-(-int(spp) // n)} batches of {n} samples", n


__all__ = ["AUTO_BATCH_PATHS", "MAX_BATCH_SPP", "MIN_BATCH_SPP", "resolve_auto_sampler"]
