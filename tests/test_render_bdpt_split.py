"""bdpt's splitting of the first camera vertex's two delta branches (kernels/render/bdpt.cl, split_first_vertex).

A pinhole sees a glass ball that reflects a bright lamp (the lamp itself out of view) before a diffuse floor
and wall.
The emission seen right after the ball (paths camera, glass, lamp of 2 segments, which only the strategy
(0, 3) samples) is estimated by both branches of the glass at once:

- the image agrees with ``mis`` per 8 x 8-pixel block (Sidak-corrected z-tests), for the smooth dielectric
  without and the thin sheet under a constant environment (the other branch's ray escaping into it);
- the weighted strategies of paths up to 2 segments still sum to the full render (one seed);
- strategy (0, 3) alone, unweighted, agrees with ``mis`` at max_depth 2 (the lamp out of view: every
  path of that render has 2 segments) per pixel on the ball, where a wrong branch weight would be off by
  the Fresnel factor, also with the camera walk's roulette acting at the glass;
- the glint's reported variance is a small fraction of what the same render has through a thin lens of
  negligible aperture (which the split leaves out: its camera subpaths do not start at a pinhole);
- the image is bit-identical on two sub-devices.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
from scipy import stats
from test_render_lt import assert_blocks_agree

from mcocl.render.api import render
from mcocl.render.compiled import compile_scene
from mcocl.render.scene import parse_scene

# The ball (radius 1 at the origin) fills the middle of a 32 x 32 image; the lamp (radius 0.5) stands up
# and to the right in front of it, outside the 35 degree field of view, so its reflection is a glint of a
# few pixels in the ball's upper right.
GLINT = {
    "camera": {"origin": [0, 0.3, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 35, "width": 32, "height": 32},
    "materials": {"floor": {"type": "diffuse", "reflectance": 0.5},
                  "glass": {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0},
                  "shell": {"type": "diffuse", "reflectance": 0.0}},
    "shapes": [
        {"name": "floor", "type": "rectangle", "material": "floor",
         "transform": [{"scale": 4}, {"rotate": {"axis": [1, 0, 0], "angle": -90}}, {"translate": [0, -1, 0]}]},
        {"name": "wall", "type": "rectangle", "material": "floor",
         "transform": [{"scale": 4}, {"translate": [0, 0, -3]}]},
        {"name": "ball", "type": "sphere", "material": "glass", "center": [0, 0, 0], "radius": 1.0},
        {"name": "lamp", "type": "sphere", "material": "shell", "center": [2, 2, 2.5], "radius": 0.5,
         "emitter": {"type": "area", "radiance": [30, 30, 30]}},
    ],
}


@pytest.fixture(autouse=True)
def _scalar_build(monkeypatch) -> None:
    """The scalar build, as tests/test_render_bdpt.py (half the compile time; the lane builds are held to it)."""
    monkeypatch.setenv("MCOCL_LANES", "1")


def glint_scene(glass: str = "dielectric", environment: bool = False, aperture: float = 0.0, floor: float = 0.5):
    """The compiled glint scene: the ball's material `glass`, optionally a constant environment, a thin lens
    of radius `aperture` focused on the ball (0: the pinhole), and the floor's and wall's reflectance."""
    data = copy.deepcopy(GLINT)
    data["materials"]["glass"]["type"] = glass
    data["materials"]["floor"]["reflectance"] = floor
    if environment:
        data["environment"] = {"type": "constant", "radiance": 0.2}
    if aperture > 0:
        data["camera"].update(aperture_radius=aperture, focus_distance=5.0)
    return compile_scene(parse_scene(data))


@pytest.mark.parametrize(("glass", "environment"), [("dielectric", False), ("thindielectric", True)])
def test_split_agrees_with_mis(glass: str, environment: bool) -> None:
    cs = glint_scene(glass, environment)
    a = render(cs, spp=512, integrator="mis", seed=1)
    b = render(cs, spp=128, integrator="bdpt", seed=2, spp_per_block=2)
    assert b.nonfinite == 0
    assert_blocks_agree(a, b)


def test_weighted_strategies_still_sum_to_the_full_render() -> None:
    """With the split, strategy (0, 3)'s image holds both branches of the glass (float rounding apart)."""
    cs = glint_scene()
    kw = {"spp": 16, "integrator": "bdpt", "max_depth": 2, "seed": 5}
    full = render(cs, roulette=False, **kw).mean.astype(np.float64)
    parts = [render(cs, strategy=st, **kw).mean.astype(np.float64) for st in [(0, 2), (1, 1), (0, 3), (1, 2), (2, 1)]]
    np.testing.assert_allclose(sum(parts), full, rtol=1e-5, atol=1e-6)


def glint_pixels(variance: np.ndarray, n: int = 5) -> np.ndarray:
    """A mask of the n pixels of largest variance (summed over channels): the glint's, at max_depth 2."""
    v = variance.sum(axis=2)
    return v >= np.sort(v.ravel())[-n]


@pytest.mark.parametrize("rr_depth", [5, 1])
def test_strategy_03_alone_is_the_length_2_image(rr_depth: int) -> None:
    """Unweighted (0, 3) estimates every path of 2 segments; so does mis at max_depth 2 when the camera sees
    no emitter.  With a black floor and wall those paths are the ball's reflections (the glint, and the
    environment around it; their variance is reported reliably, unlike a diffuse surface's rare hits of
    the lamp), compared per pixel (Sidak-corrected over the lit pixels and channels).  rr_depth 1: the
    camera walk's roulette acts at the glass, on the branch it took only (the other branch's term is
    exact either way)."""
    cs = glint_scene(environment=True, floor=0.0)
    assert np.all(render(cs, spp=4, integrator="mis", max_depth=1, seed=1).mean == 0)
    # per-pixel normal z-tests: mis's variance from independent samples, not 4 sobol batches
    a = render(cs, spp=1024, integrator="mis", max_depth=2, seed=1, sampler="independent")
    b = render(cs, spp=256, integrator="bdpt", max_depth=2, rr_depth=rr_depth, seed=2, strategy=(0, 3),
               unweighted=True, spp_per_block=2)
    assert b.nonfinite == 0
    lit = a.variance + b.variance > 0
    assert lit.sum() > 3 * 100  # the ball's pixels
    assert np.all(glint_pixels(a.variance)[..., None] <= lit)
    z = (a.mean[lit] - b.mean[lit]) / np.sqrt(a.variance[lit] + b.variance[lit])
    assert 2 * stats.norm.sf(np.abs(z).max()) > 1 - (1 - 1e-3) ** (1 / z.size), np.abs(z).max()


def test_split_cuts_the_glints_variance() -> None:
    """The Fresnel coin flip at the glass is gone: the glint's variance (same seed, same samples per pixel,
    max_depth 2) is a small fraction of the unsplit render's through a thin lens of negligible aperture
    (1e-4), whose image is the pinhole's.  Unsplit, a glint sample is Bernoulli(F c) times L_e (variance
    ~ L_e^2 F c); split, F L_e times Bernoulli(c) (~ L_e^2 F^2 c (1 - c)), F about 0.05 here: measured 0.013
    of the unsplit variance."""
    kw = {"spp": 256, "integrator": "bdpt", "seed": 3, "spp_per_block": 2, "max_depth": 2}
    split = render(glint_scene(), **kw)
    unsplit = render(glint_scene(aperture=1e-4), **kw)
    g = glint_pixels(unsplit.variance)
    ratio = split.variance[g].sum() / unsplit.variance[g].sum()
    assert ratio < 0.1, ratio


def test_split_is_the_same_on_two_sub_devices() -> None:
    """The extra ray draws no random numbers: the glint scene's image is bit-identical on two sub-devices."""
    cs = glint_scene(environment=True)
    one = render(cs, spp=8, seed=4, integrator="bdpt", spp_per_block=2)
    two = render(cs, spp=8, seed=4, integrator="bdpt", spp_per_block=2, split=2)
    np.testing.assert_array_equal(one.mean, two.mean)
    np.testing.assert_array_equal(one.variance, two.variance)
