"""mcocl against Mitsuba 3 reference images (tests/data/mitsuba/, made as tests/data/README.md says).

- Every scene of tests/data/mitsuba/ is one Mitsuba XML file that both renderers read: Mitsuba 3
  (scalar_rgb, many independent batches) made the stored mean and standard errors; mcocl renders the
  same file here (``mis``, a fixed seed) and every 8 x 8 block and channel must agree within the
  Šidák-corrected z bound of the whole family (tests/mitsuba_reference.py).
- Light tracing and BDPT agree with the same reference of an all-diffuse, area-lit scene.
- A known difference (KNOWN_DIFFERENCES) is an expected failure that fails loudly once it is fixed.
- Every XML file has its reference, made from the file as it is now, with the manifest saying how.
- The comparison can fail: one 8 x 8 block of the reference darkened by 2 % is caught (z about 6.6 against a bound of 4.6).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest
from mitsuba_reference import (
    block_means,
    block_z,
    describe_worst,
    load_reference,
    reference_names,
    render_like_reference,
    z_bound,
)

# scene name (tests/data/mitsuba/<name>.xml) -> mcocl's samples per pixel (a second or two each on PoCL)
SCENES = {
    "box_diffuse": 2048,
    "camera_dialect": 2048,
    "conductors": 4096,
    "emitters_direct": 4096,
    "glass": 4096,
    "plastic_twosided": 4096,
    "shapes": 2048,
    "spectra": 1024,
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
        # blocks of independent pixels (box filter): the block stderr from the batch spread matches the pixels'
        pixel_based = np.sqrt(block_means(ref.stderr**2) / 64)
        noisy = pixel_based > 0
        ratio = ref.block_stderr[noisy] / pixel_based[noisy]
        assert 0.6 < np.median(ratio) < 1.4, (name, np.median(ratio))


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


def test_a_small_change_is_caught() -> None:
    """The comparison has power: the reference with one 8 x 8 block darkened by 2 % fails it."""
    ref = load_reference("box_diffuse")
    r = _render("box_diffuse")
    assert np.abs(block_z(r, ref)).max() < z_bound(_family_size())
    darker = ref.mean.copy()
    darker[16:24, 8:16] *= 0.98
    z = block_z(r, dataclasses.replace(ref, mean=darker))
    assert np.abs(z[2, 1]).max() > z_bound(_family_size())
