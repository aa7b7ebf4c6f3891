"""bdpt with the sobol sampler (kernels/render/bdpt.cl, "Quasi-Monte Carlo").

- Agreement with ``mis`` (independent samples) per 8 x 8-pixel block and per pixel (Sidak-corrected
  z-tests in units of the reported standard errors) on the Cornell box, through glass (delta vertices
  and the split at z_1), with a thin lens (the lens dimensions) and under a tent filter.
- The variance layer stays honest: over 12 seeds the spread of the pixel means matches the
  variance the renders report from their independent batches (chi-square range, as lt's test;
  measured ratio 1.00): a batch's light subpaths are one net over all pixels, so pixels are
  correlated within a batch, but batches are independent.
- A block holds at most 2^24 samples (one scrambling's points for the light subpaths).
- The nets help: on the Cornell box the summed per-pixel variance at equal spp is well below the
  independent sampler's (2.3x lower measured at batches of 16 spp, 1.7x before the light subpaths
  became one net per batch; the bound asks for 1.3x).
- Determinism: bit-identical images across launch splits, sub-devices and a resume.
- The sampler is reported (RenderResult.sampler, --json, the EXR header); ``independent`` keeps
  bdpt's images of before (the same bits as the independent build's film strata).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from interrupting import interrupt_after_first_fold
from test_render_bdpt import thin_lens_cornell
from test_render_lt import assert_blocks_agree, assert_pixels_agree, assert_variance_is_honest, downscaled

from mcocl.errors import InputError
from mcocl.render.api import render
from mcocl.render.compiled import compile_scene
from mcocl.render.image_io import read_exr
from mcocl.render.pixel_filter import make_filter
from mcocl.render.scene_file import load_scene
from mcocl.render.splat_film import BDPT_SOBOL_BLOCK, splat_spp_per_block

SCENES = Path(__file__).resolve().parent.parent / "scenes"


@pytest.fixture(autouse=True)
def _scalar_build(monkeypatch) -> None:
    """The scalar build compiles fastest; the numbers of a sample do not depend on LANES."""
    monkeypatch.setenv("MCOCL_LANES", "1")


def test_sobol_bdpt_agrees_with_mis_on_cornell() -> None:
    cs = downscaled("cornell.json", 32)
    a = render(cs, spp=1024, integrator="mis", seed=1, sampler="independent")
    # 64 batches of 2 (nets of 2 points): a per-pixel variance good enough for per-pixel z-scores
    b = render(cs, spp=128, integrator="bdpt", seed=2, spp_per_block=2, sampler="sobol")
    assert b.sampler == "sobol" and b.nonfinite == 0 and np.all(b.count == 64)
    assert_blocks_agree(a, b)
    assert_pixels_agree(a, b)
    # batches of 16: 8 per pixel, too few degrees of freedom per pixel for the pixel test, blocks only
    c = render(cs, spp=128, integrator="bdpt", seed=3, spp_per_block=16, sampler="sobol")
    assert_blocks_agree(a, c)


def test_sobol_bdpt_agrees_with_mis_through_glass() -> None:
    cs = downscaled("caustic.json", 32)
    a = render(cs, spp=1024, integrator="mis", seed=1, sampler="independent")
    b = render(cs, spp=128, integrator="bdpt", seed=2, spp_per_block=8, sampler="sobol")
    assert b.nonfinite == 0
    assert_blocks_agree(a, b)


def test_thin_lens_sobol_bdpt_agrees_with_mis() -> None:
    cs = thin_lens_cornell()
    a = render(cs, spp=1024, integrator="mis", seed=3, sampler="independent")
    b = render(cs, spp=128, integrator="bdpt", seed=4, spp_per_block=8, sampler="sobol")
    assert_blocks_agree(a, b)


def test_sobol_bdpt_agrees_with_mis_under_a_filter() -> None:
    """The film point drawn from a tent filter around the pixel (render/pixel_filter.cl) with the Sobol'
    coordinates, the t = 1 splats with the filter's weight: 8 x 8-pixel blocks agree with mis."""
    sc = load_scene(SCENES / "cornell.json")
    sc.camera.width = sc.camera.height = 32
    sc.camera.pixel_filter = make_filter("tent", radius=1.5)
    cs = compile_scene(sc)
    a = render(cs, spp=1024, integrator="mis", seed=3, sampler="independent")
    b = render(cs, spp=256, integrator="bdpt", seed=2, spp_per_block=8, sampler="sobol")
    assert b.nonfinite == 0
    assert_blocks_agree(a, b)


def test_reported_stderr_matches_the_spread_over_seeds() -> None:
    """Per pixel, the spread of 12 seeds' means against the variance each render reports from its 4
    batches of 8 (the nets' own variance, not the independent sampler's)."""
    cs = downscaled("cornell.json", 16)
    runs = [render(cs, spp=32, integrator="bdpt", sampler="sobol", spp_per_block=8, seed=s) for s in range(500, 512)]
    assert all(np.all(r.count == 4) for r in runs)
    assert_variance_is_honest(runs)


def test_the_nets_lower_the_variance_on_cornell() -> None:
    """The summed per-pixel variance of the mean at 64 spp, batches of 16, from 12 seeds each: the
    spread over seeds, not the reported variance, so that the comparison does not lean on it."""
    cs = downscaled("cornell.json", 16)
    spread = {}
    for sampler in ("sobol", "independent"):
        means = np.stack([render(cs, spp=64, integrator="bdpt", sampler=sampler, spp_per_block=16, seed=s).mean
                          for s in range(600, 612)]).astype(np.float64)
        spread[sampler] = means.var(axis=0, ddof=1).sum()
    # each sum is a chi-square of 11 x 768 degrees of freedom (pixels nearly independent): a few % noise
    assert spread["independent"] > 1.3 * spread["sobol"], spread


# Launch splits: tests/test_render_lt.py, test_image_does_not_depend_on_how_blocks_are_launched (bdpt-sobol).


def test_sub_devices_give_the_same_image() -> None:
    cs = downscaled("cornell.json", 12)
    one = render(cs, spp=16, seed=4, integrator="bdpt", spp_per_block=4, sampler="sobol")
    two = render(cs, spp=16, seed=4, integrator="bdpt", spp_per_block=4, sampler="sobol", split=2)
    np.testing.assert_array_equal(one.mean, two.mean)
    np.testing.assert_array_equal(one.variance, two.variance)


def test_resumed_render_is_identical(tmp_path: Path) -> None:
    cs = downscaled("cornell.json", 16)
    whole = render(cs, spp=24, seed=7, integrator="bdpt", spp_per_block=4, sampler="sobol")
    ckpt = tmp_path / "run.ckpt"
    part = render(cs, spp=24, seed=7, integrator="bdpt", spp_per_block=4, sampler="sobol", checkpoint=ckpt,
                  progress=interrupt_after_first_fold())
    assert part.stopped_by == "interrupt" and 0 < part.spp < 24
    rest = render(cs, spp=24, seed=7, integrator="bdpt", resume=ckpt)  # auto: the checkpoint's sampler
    assert rest.sampler == "sobol" and rest.spp == 24
    np.testing.assert_array_equal(rest.mean, whole.mean)
    np.testing.assert_array_equal(rest.variance, whole.variance)


def test_the_sampler_is_reported_and_independent_is_unchanged(tmp_path: Path) -> None:
    cs = downscaled("cornell.json", 8)
    q = render(cs, spp=16, seed=5, integrator="bdpt", sampler="sobol")
    assert q.sampler == "sobol" and q.to_dict()["sampler"] == "sobol" and q.metadata()["sampler"] == "sobol"
    q.save_exr(tmp_path / "q.exr")
    assert read_exr(tmp_path / "q.exr").metadata["sampler"] == "sobol"
    ind = render(cs, spp=16, seed=5, integrator="bdpt", sampler="independent")
    assert ind.sampler == "independent" and not np.array_equal(ind.mean, q.mean)
    # lt has no sobol back end
    with pytest.raises(InputError, match="sampler 'sobol'.*'lt'"):
        render(cs, spp=16, integrator="lt", sampler="sobol")
    # a block's light subpaths are one scrambling's points: at most 2^24 samples
    with pytest.raises(InputError, match="spp_per_block.*at most 16777216"):
        render(cs, spp=1 << 20, integrator="bdpt", sampler="sobol", spp_per_block=1 << 19)


def test_sobol_batches_are_a_quarter_of_the_spp_up_to_the_default_block() -> None:
    """bdpt's sobol batches (mcocl/render/splat_film.py, splat_spp_per_block): ceil(spp / 4) samples, at most
    the default block's (whose paths stay within a sobol block), the default block under time halting."""
    assert splat_spp_per_block(64, 64, "bdpt", 128, 128, "sobol") == 16
    assert splat_spp_per_block(64, 1024, "bdpt", 128, 128, "sobol") == 64
    assert splat_spp_per_block(64, None, "bdpt", 128, 128, "sobol") == 64
    assert splat_spp_per_block(64, 7, "bdpt", 128, 128, "sobol") == 2
    assert splat_spp_per_block(16, 1024, "bdpt", 256, 256, "sobol") == 16
    # the independent sampler's batches are as before (tests/test_render_bdpt_film_strata.py)
    assert splat_spp_per_block(64, 256, "bdpt", 128, 128) == 16
    assert 64 * 128 * 128 <= BDPT_SOBOL_BLOCK


def test_batches_size_bdpt_s_sobol_batches_and_lt_refuses_them() -> None:
    """``batches`` means for bdpt what it means for mis: that many independent scramblings, each a net of
    spp / batches samples per pixel, the variance from their means; lt has no sobol back end."""
    assert splat_spp_per_block(64, 64, "bdpt", 128, 128, "sobol", batches=8) == 8
    cs = downscaled("cornell.json", 16)
    for b in (2, 8):
        r = render(cs, spp=16, seed=1, integrator="bdpt", batches=b)  # auto: batches choose sobol
        assert r.sampler == "sobol" and r.spp == 16
        assert np.all(r.count == b)
    with pytest.raises(InputError, match="not 'lt'"):
        render(cs, spp=16, seed=1, integrator="lt", batches=2)
