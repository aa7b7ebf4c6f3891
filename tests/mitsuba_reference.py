"""Reference images rendered by Mitsuba 3, and the 8 x 8-block z-test that compares mcocl with them.

The references live in tests/data/mitsuba/ (made by bench/make_mitsuba_references.py,
described in tests/data/README.md): ``<name>.xml`` is the scene, read by both
renderers; ``<name>.npz`` holds Mitsuba's mean image, its per-pixel standard
error and the standard error of every 8 x 8 block mean, all from the spread
of independent batches; ``manifest.json`` says how each was made.

The comparison: for every 8 x 8 block and channel, the difference of the
block means of mcocl's render and the reference, divided by the standard
error of that difference (mcocl's: its pixels are independent, so the block
mean's variance is the sum of the pixels' variances of the mean / 64²; the
reference's: its block standard error; a floor of 1e-5 of the value for
float32 rounding where both are exact), is a z-score.  A scene passes when
no block is beyond the two-sided Šidák level of the family (every block and
channel of every scene of the test file) at family-wise level
:data:`FAMILY_ALPHA`, as the suite's other 8 x 8-block z-tests do.  Per pixel,
:func:`pixel_z` and :func:`outlier_fraction` see what block means hide (a
reconstruction filter's blur of an outline): at most :data:`PIXEL_OUTLIERS` of
the pixels may lie beyond :data:`PIXEL_LIMIT` standard errors.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from chi2 import sidak_alpha
from scipy import stats

from mcocl.render.api import RenderResult, render

DATA = Path(__file__).resolve().parent / "data" / "mitsuba"
BLOCK = 8
# The family-wise level of the suite's 8 x 8-block z-tests (tests/test_render_sobol.py and others).
FAMILY_ALPHA = 1e-3
# Relative standard-error floor of a block.  Where neither renderer has noise (a constant sky seen directly)
# they still differ by float32 rounding: Mitsuba's film sums a pixel's samples in float32, and a sky of 0.7
# comes out 0.69999826 at 256 spp (2.5e-6 low).
ROUNDING = 1e-5
# The per-pixel check: at most PIXEL_OUTLIERS of the pixel-and-channel z-scores beyond PIXEL_LIMIT.  A normal
# puts 6e-5 beyond 4; the measured tails are heavier (a rare bright path makes an outlier, and the reference's
# per-pixel error comes from its batches alone): 0.5-0.8 % on smooth_gaussian over three seeds.  A box filter
# on that scene's Gaussian-filtered reference puts about a quarter of its pixels beyond.
PIXEL_LIMIT = 4.0
PIXEL_OUTLIERS = 0.02


@dataclass(frozen=True)
class Reference:
    """One stored Mitsuba reference: (H, W, 3) mean and stderr, (H/8, W/8, 3) block_stderr, its manifest entry."""

    name: str
    mean: np.ndarray
    stderr: np.ndarray
    block_stderr: np.ndarray
    made: dict

    @property
    def xml(self) -> Path:
        """The scene file both renderers read."""
        return DATA / f"{self.name}.xml"

    def blocks(self) -> int:
        """How many 8 x 8-block-and-channel z-tests a comparison with this reference runs."""
        return int(self.block_stderr.size)


def reference_names() -> list[str]:
    """Names of the scene files in tests/data/mitsuba/."""
    return sorted(p.stem for p in DATA.glob("*.xml"))


def load_reference(name: str) -> Reference:
    """The stored reference of ``tests/data/mitsuba/<name>.xml``.

    Raises:
        AssertionError: no reference, or the XML changed since the reference was made
            (rerun bench/make_mitsuba_references.py for it).
    """
    manifest = json.loads((DATA / "manifest.json").read_text())
    assert name in manifest, f"{name}: no entry in tests/data/mitsuba/manifest.json; run bench/make_mitsuba_references.py"
    made = manifest[name]
    digest = hashlib.sha256((DATA / f"{name}.xml").read_bytes()).hexdigest()
    assert digest == made["xml_sha256"], f"{name}.xml changed after its reference was made; rerun the script for it"
    with np.load(DATA / f"{name}.npz") as z:
        arrays = {k: z[k].astype(np.float64) for k in ("mean", "stderr", "block_stderr")}
    return Reference(name, made=made, **arrays)


def render_like_reference(ref: Reference, spp: int, seed: int, **kw) -> RenderResult:
    """mcocl's render of the reference's XML (its integrator settings; ``mis`` unless ``kw`` says otherwise)."""
    return render(ref.xml, spp=spp, seed=seed, **{"integrator": "mis", **kw})


def block_means(x: np.ndarray) -> np.ndarray:
    """Means of the 8 x 8 pixel blocks of an (H, W, 3) image, in float64."""
    h, w, c = x.shape
    return np.asarray(x, np.float64).reshape(h // BLOCK, BLOCK, w // BLOCK, BLOCK, c).mean(axis=(1, 3))


def block_z(result: RenderResult, ref: Reference) -> np.ndarray:
    """(H/8, W/8, 3) z-scores of mcocl's block means against the reference's, with both standard errors."""
    assert result.mean.shape == ref.mean.shape, f"{ref.name}: mcocl {result.mean.shape} vs reference {ref.mean.shape}"
    ours_var = np.asarray(result.variance, np.float64).reshape(ref.block_stderr.shape[0], BLOCK,
                                                               ref.block_stderr.shape[1], BLOCK, 3).sum(axis=(1, 3))
    theirs = block_means(ref.mean)
    # A block both renderers compute exactly (a constant sky seen directly) has no variance: it must agree to
    # float32 rounding, which the floor of ROUNDING x its value allows.
    var = ours_var / BLOCK**4 + ref.block_stderr**2 + (ROUNDING * np.abs(theirs)) ** 2 + np.finfo(np.float64).tiny
    return (block_means(result.mean) - theirs) / np.sqrt(var)


def pixel_z(result: RenderResult, ref: Reference) -> np.ndarray:
    """(H, W, 3) z-scores of mcocl's pixel means against the reference's, with both per-pixel standard errors.

    Unlike :func:`block_z` this sees a difference that leaves block means alone (a wrong reconstruction filter
    blurs an outline differently but keeps its block's mean); the reference's per-pixel standard error comes
    from its batches, so it is right under any filter.  The same float32-rounding floor as the blocks'.
    """
    assert result.mean.shape == ref.mean.shape, f"{ref.name}: mcocl {result.mean.shape} vs reference {ref.mean.shape}"
    var = (np.asarray(result.variance, np.float64) + ref.stderr**2 + (ROUNDING * np.abs(ref.mean)) ** 2
           + np.finfo(np.float64).tiny)
    return (np.asarray(result.mean, np.float64) - ref.mean) / np.sqrt(var)


def outlier_fraction(result: RenderResult, ref: Reference, limit: float = PIXEL_LIMIT) -> float:
    """The share of mcocl's noisy pixels and channels whose :func:`pixel_z` is beyond ``limit`` in absolute value.

    Pixels mcocl computes exactly (variance 0: a constant sky seen directly) are left out: under a filter wider
    than a pixel, Mitsuba's normalisation by the summed filter weights leaves them up to about 1e-4 off, far
    beyond their tiny batch spread, while the block test already holds them to its rounding floor.  (Normal
    noise puts 6e-5 of the z-scores beyond 4.)
    """
    noisy = np.asarray(result.variance) > 0
    return float(np.mean(np.abs(pixel_z(result, ref)[noisy]) > limit)) if noisy.any() else 0.0


def z_bound(tests: int, family_alpha: float = FAMILY_ALPHA) -> float:
    """Two-sided |z| bound of one test in a Šidák family of ``tests`` tests."""
    return float(stats.norm.isf(sidak_alpha(family_alpha, tests) / 2.0))


def describe_worst(z: np.ndarray, result: RenderResult, ref: Reference, worst: int = 4) -> str:
    """The blocks with the largest |z|: position, channel, both block means and z."""
    ours, theirs = block_means(result.mean), block_means(ref.mean)
    lines = []
    for i in np.argsort(-np.abs(z), axis=None)[:worst]:
        by, bx, c = np.unravel_index(i, z.shape)
        lines.append(f"  block (row {by}, col {bx}) channel {'RGB'[c]}: mcocl {ours[by, bx, c]:.5g}, "
                     f"Mitsuba {theirs[by, bx, c]:.5g}, z {z[by, bx, c]:+.2f}")
    return "\n".join(lines)
