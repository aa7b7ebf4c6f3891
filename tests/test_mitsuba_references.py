"""mcocl against Mitsuba 3 reference images (tests/data/mitsuba/, made as tests/data/README.md says).

- Every scene of tests/data/mitsuba/ is one Mitsuba XML file that both renderers read: Mitsuba 3
  (scalar_rgb, many independent batches) made the stored mean and standard errors; mcocl renders the
  same file here (``mis``, a fixed seed) and every 8 x 8 block and channel must agree within the
  Šidák-corrected z bound of the whole family (tests/mitsuba_reference.py).
- Light tracing and BDPT agree with the same reference of an all-diffuse, area-lit scene.
- A known difference (KNOWN_DIFFERENCES) is an expected failure that fails loudly once it is fixed.
- Per pixel, at most 2 % of the pixels and channels lie beyond 4 standard errors, and under a box filter none beyond
  the Šidák bound of all those pixels; a box filter on the Gaussian-filtered smooth_gaussian scene (the negative
  control) puts far more than 2 % beyond 4: the reconstruction filter is seen.
- Every XML file has its reference, made from the file as it is now, with the manifest saying how; `mcocl convert`
  keeps the materials of new_materials.xml.
- The comparison can fail: one 8 x 8 block of a reference darkened by 2 % is caught (POWER_BLOCKS: four scenes).
"""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

import numpy as np
import pytest
from mitsuba_reference import (
    PIXEL_OUTLIERS,
    block_means,
    block_z,
    describe_worst,
    load_reference,
    outlier_fraction,
    pixel_z,
    reference_names,
    render_like_reference,
    z_bound,
)

from mcocl.cli import main
from mcocl.render.api import render
from mcocl.render.compiled import compile_scene
from mcocl.render.pixel_filter import BOX, make_filter

# scene name (tests/data/mitsuba/<name>.xml) -> mcocl's samples per pixel (one to five seconds each on PoCL)
SCENES = {
    "box_diffuse": 2048,
    "camera_dialect": 2048,
    "conductors": 4096,
    "emitters_direct": 4096,
    "envmap_scene": 4096,
    "glass": 4096,
    "new_materials": 8192,
    "plastic_twosided": 4096,
    "shapes": 2048,
    "spectra": 1024,
    "textures": 4096,
    "smooth_gaussian": 8192,
}
# scene name -> (spp, why): references mcocl is known not to match yet; strict xfail, so that the fix
# shows (move the scene to SCENES then)
KNOWN_DIFFERENCES: dict[str, tuple[int, str]] = {}
# (integrator, scene, spp): the other integrators on scenes they can render (light tracing and BDPT: area
# lights, no delta surface seen directly), against the same references
OTHER_INTEGRATORS = [("lt", "box_diffuse", 1024), ("bdpt", "box_diffuse", 128)]
SEED = 20261201


@functools.cache
def _render(name: str):
    """mcocl's render of a reference scene (once per session: two tests use box_diffuse's)."""
    return render_like_reference(load_reference(name), SCENES[name], SEED)


def _family_size() -> int:
    """Block tests of the whole file: every scene with mis, and the OTHER_INTEGRATORS runs."""
    return sum(load_reference(name).blocks() for name in [*SCENES, *(s for _, s, _ in OTHER_INTEGRATORS)])


def test_every_scene_file_is_tested_and_has_its_reference() -> None:
    assert sorted([*SCENES, *KNOWN_DIFFERENCES]) == reference_names(), "list every tests/data/mitsuba/*.xml in SCENES or KNOWN_DIFFERENCES"
    for name in [*SCENES, *KNOWN_DIFFERENCES]:
        ref = load_reference(name)  # fails when the XML changed after its reference was made
        assert ref.made["renderer"] == "Mitsuba 3" and ref.made["variant"] == "scalar_rgb"
        assert ref.made["batches"] >= 16 and ref.made["spp_per_batch"] * ref.made["batches"] >= 4096
        assert ref.mean.shape == ref.stderr.shape == (ref.made["height"], ref.made["width"], 3)
        assert np.all(np.isfinite(ref.mean)) and np.all(ref.stderr >= 0)
        # blocks of independent pixels (box filter): the block stderr from the batch spread matches the pixels';
        # a wider filter splats a sample into neighbouring pixels, whose errors then add up with the same sign
        pixel_based = np.sqrt(block_means(ref.stderr**2) / 64)
        noisy = pixel_based > 0
        ratio = np.median(ref.block_stderr[noisy] / pixel_based[noisy])
        if compile_scene(ref.xml).pixel_filter == BOX:
            assert 0.6 < ratio < 1.4, (name, ratio)
        else:
            assert ratio > 1.4, (name, ratio)


@pytest.mark.parametrize("name", list(SCENES))
def test_mcocl_agrees_with_mitsuba(name: str) -> None:
    ref = load_reference(name)
    r = _render(name)
    assert r.nonfinite == 0
    z = block_z(r, ref)
    bound = z_bound(_family_size())
    assert np.all(np.isfinite(z)) and np.abs(z).max() < bound, (
        f"{name}: largest |z| {np.abs(z).max():.2f} over the bound {bound:.2f} of {_family_size()} block tests\n"
        + describe_worst(z, r, ref))


@pytest.mark.parametrize("name", list(KNOWN_DIFFERENCES))
def test_known_differences_still_differ(name: str) -> None:
    spp, why = KNOWN_DIFFERENCES[name]
    ref = load_reference(name)
    z = block_z(render_like_reference(ref, spp, SEED), ref)
    if np.abs(z).max() < z_bound(_family_size()):
        pytest.fail(f"{name} now agrees with Mitsuba: move it from KNOWN_DIFFERENCES to SCENES ({why})")
    pytest.xfail(why)


@pytest.mark.parametrize(("integrator", "name", "spp"), OTHER_INTEGRATORS)
def test_other_integrators_agree_with_mitsuba(integrator: str, name: str, spp: int) -> None:
    ref = load_reference(name)
    r = render_like_reference(ref, spp, SEED + 1, integrator=integrator)
    assert r.nonfinite == 0 and r.integrator == integrator
    z = block_z(r, ref)
    bound = z_bound(_family_size())
    assert np.all(np.isfinite(z)) and np.abs(z).max() < bound, (
        f"{name} ({integrator}): largest |z| {np.abs(z).max():.2f} over the bound {bound:.2f}\n"
        + describe_worst(z, r, ref))


@functools.cache
def _box_filtered(name: str) -> bool:
    """Whether the scene's film has a box filter (independent pixels; else Mitsuba splats into neighbours)."""
    return compile_scene(load_reference(name).xml).pixel_filter == BOX


def _pixel_family_size() -> int:
    """Pixel-and-channel tests of the box-filtered SCENES."""
    return sum(load_reference(name).mean.size for name in SCENES if _box_filtered(name))


@pytest.mark.parametrize("name", list(SCENES))
def test_pixels_agree(name: str) -> None:
    """Per pixel: few outliers in every scene; under a box filter, none beyond the Šidák bound of all their pixels."""
    ref = load_reference(name)
    r = _render(name)
    share = outlier_fraction(r, ref)
    assert share < PIXEL_OUTLIERS, f"{name}: {share:.2%} of the pixels beyond 4 standard errors"
    if _box_filtered(name):
        z = np.abs(pixel_z(r, ref))
        bound = z_bound(_pixel_family_size())
        worst = np.unravel_index(np.argmax(z), z.shape)
        assert z.max() < bound, (f"{name}: pixel {worst[:2]} channel {'RGB'[worst[2]]}: mcocl {r.mean[worst]:.5g}, "
                                 f"Mitsuba {ref.mean[worst]:.5g}, |z| {z.max():.2f} over the bound {bound:.2f}")


def test_the_gaussian_filter_is_seen() -> None:
    """smooth_gaussian has no <rfilter>: Mitsuba's default Gaussian.  Rendered with a box filter, its outline is
    too sharp, which the per-pixel check sees (about a quarter of the pixels beyond 4 standard errors)."""
    ref = load_reference("smooth_gaussian")
    cs = compile_scene(ref.xml)
    assert cs.pixel_filter == make_filter("gaussian") and cs.vertex_normals is not None
    cs.pixel_filter = BOX
    box = render(cs, spp=SCENES["smooth_gaussian"], seed=SEED + 2, integrator="mis")
    assert outlier_fraction(box, ref) > 5 * PIXEL_OUTLIERS


def test_convert_keeps_the_new_materials(tmp_path: Path) -> None:
    """`mcocl convert` writes JSON that compiles to the XML's materials table (records and roughplastic tables)."""
    xml = tmp_path / "s.xml"
    text = load_reference("new_materials").xml.read_text()
    xml.write_text(text.replace('<bsdf type="thindielectric" id="pane"/>',
                                '<bsdf type="thindielectric" id="pane"/><bsdf type="roughplastic" id="coat">'
                                '<float name="alpha" value="0.2"/></bsdf>'))
    out = tmp_path / "s.json"
    assert main(["convert", str(xml), "-o", str(out)]) == 0
    a, b = compile_scene(out).materials, compile_scene(xml).materials
    assert a.shape == (7 + 4, 20) and np.array_equal(a, b)  # 7 records, one table of 4 rows


# scene -> (block row, block column) of the power check: a lit block where 2 % is at least 6.5 standard errors
# (new_materials has noisier blocks, where 2 % is below the bound; so it was before it joined these tests)
POWER_BLOCKS = {"box_diffuse": (2, 1), "envmap_scene": (3, 1), "new_materials": (1, 1), "smooth_gaussian": (2, 1)}


@pytest.mark.parametrize("name", list(POWER_BLOCKS))
def test_a_small_change_is_caught(name: str) -> None:
    """The comparison has power: the reference with one 8 x 8 block darkened by 2 % fails it."""
    ref = load_reference(name)
    r = _render(name)
    assert np.abs(block_z(r, ref)).max() < z_bound(_family_size())
    by, bx = POWER_BLOCKS[name]
    darker = ref.mean.copy()
    darker[8 * by:8 * by + 8, 8 * bx:8 * bx + 8] *= 0.98
    z = block_z(r, dataclasses.replace(ref, mean=darker))
    assert np.abs(z[by, bx]).max() > z_bound(_family_size()), (name, np.round(z[by, bx], 2))
