"""White furnace: a closed enclosure that emits Le and reflects with albedo rho.

Radiance is the same everywhere, L = Le sum_{k<D} rho^k (max_depth D, Mitsuba 3's
convention) and Le / (1 - rho) unbounded; the scenes' comments derive it.  Every
integrator, with both a triangle box and an analytic sphere as the enclosure
(the sphere puts every shading point on a spherical light), must reproduce it
within 5 reported standard errors, and the reported standard error must match
the spread of independent renders.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy import stats

import mcocl
from mcocl.render.api import render

SCENES = Path(__file__).resolve().parent.parent / "scenes"
RHO = np.array([0.8, 0.5, 0.2])
LE = np.array([0.2, 0.5, 0.8])


def closed_form(max_depth: int) -> np.ndarray:
    """L = Le (1 - rho^D) / (1 - rho) (0 for D = 0, a black image as in Mitsuba), or Le / (1 - rho) for D = -1."""
    if max_depth < 0:
        return LE / (1 - RHO)
    return LE * (1 - RHO**max_depth) / (1 - RHO)


def image_mean(r) -> tuple[np.ndarray, np.ndarray]:
    """Mean over pixels and its standard error (pixels are independent)."""
    m = r.mean.reshape(-1, 3).astype(np.float64)
    v = r.variance.reshape(-1, 3).astype(np.float64)
    return m.mean(axis=0), np.sqrt(v.sum(axis=0)) / len(m)


@pytest.mark.parametrize("scene", ["furnace.json", "furnace_sphere.json"])
@pytest.mark.parametrize("integrator", ["path", "nee", "mis"])
@pytest.mark.parametrize("max_depth", [-1, 0, 1, 3])
def test_furnace_closed_form(scene: str, integrator: str, max_depth: int) -> None:
    r = render(SCENES / scene, spp=16, integrator=integrator, max_depth=max_depth, seed=11, sampler="independent")
    assert r.spp == 16 and r.nonfinite == 0
    assert np.all(r.count == 16)
    est, se = image_mean(r)
    want = closed_form(max_depth)
    # zero-variance cases (e.g. path tracing at max_depth 3: every path carries exactly
    # Le + rho Le + rho^2 Le) are held to float rounding instead
    assert np.all(np.abs(est - want) <= 5 * se + 2e-6 * want), (est, want, se)


def test_furnace_scalar_build() -> None:
    r = render(SCENES / "furnace.json", spp=16, integrator="mis", seed=5, lanes=1)
    assert r.lanes == 1
    est, se = image_mean(r)
    want = closed_form(-1)
    assert np.all(np.abs(est - want) <= 5 * se), (est, want, se)


def test_reported_stderr_matches_the_spread_over_seeds() -> None:
    """20 seeds: per pixel, the variance of the means over seeds against the reported variance of the mean."""
    seeds = range(100, 120)
    runs = [render(SCENES / "furnace.json", spp=8, integrator="mis", seed=s) for s in seeds]
    means = np.stack([r.mean for r in runs]).astype(np.float64)  # (20, H, W, 3)
    reported = np.stack([r.variance for r in runs]).astype(np.float64).mean(axis=0)
    spread = means.var(axis=0, ddof=1)
    ratio = spread.sum() / reported.sum()
    # many pixels pool into a tight ratio; 19 degrees of freedom per pixel
    npix = spread.size
    lo = stats.chi2.ppf(1e-4, 19 * npix) / (19 * npix)
    hi = stats.chi2.ppf(1 - 1e-4, 19 * npix) / (19 * npix)
    # pixels are not exactly Gaussian and the variance estimate has its own noise: allow 10 % more
    assert 0.9 * lo < ratio < 1.1 * hi, ratio
    # the image-level error: means over pixels across seeds against the reported stderr
    im = means.reshape(20, -1, 3).mean(axis=1)
    se = np.sqrt(reported.reshape(-1, 3).sum(axis=0)) / reported.reshape(-1, 3).shape[0]
    z = (im - closed_form(-1)) / se
    assert np.all(np.abs(z) < 5)
    assert 0.2 < np.std(z) < 2.0


def test_render_is_exported() -> None:
    assert callable(mcocl.render) and mcocl.render.render is render
    r = mcocl.render(SCENES / "furnace.json", spp=2)
    assert isinstance(r, mcocl.RenderResult) and r.mean.shape == (24, 32, 3)
