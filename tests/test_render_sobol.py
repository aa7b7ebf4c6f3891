"""The render sampler ``sobol`` (integrator.sampler; mcocl/render/sobol_film.py).

- Renders with ``sobol`` agree with independent ones per 8 x 8 block of
  pixels (z-tests with a Šidák correction) on scenes/furnace.json and a small
  Cornell box, and with the furnace's exact radiance (1, 1, 1), also when
  paths outgrow the Sobol' table (padded dimensions).
- The variance is the spread of block means: a pixel's count is its number of
  batches, block_batches computes the batch statistics exactly, and on the
  Cornell box the reported variance at equal spp is below the independent one.
- The image does not depend on launch splits or an interrupted and resumed
  run; the default sampler's image is unchanged by the option.
- Bad values are refused with their key.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from device_doubles import small_cornell
from interrupting import interrupt_after_first_fold
from scipy import stats

from mcocl.accumulate import Accumulator
from mcocl.errors import InputError
from mcocl.layouts import FilmStat
from mcocl.render import sobol_film
from mcocl.render.api import render
from mcocl.render.compiled import compile_scene
from mcocl.render.scene import parse_scene
from mcocl.render.scene_file import load_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"
FAMILY_ALPHA = 1e-3



def block_z(a, b_mean, b_var, block: int = 8) -> np.ndarray:
    """z-scores of the differences of 8 x 8 block means of render ``a`` and a mean/variance pair (per channel)."""
    h, w, _ = a.mean.shape

    def blocks(x):
        return np.asarray(x, np.float64).reshape(h // block, block, w // block, block, 3).sum(axis=(1, 3)) / block**2

    d = blocks(a.mean) - blocks(b_mean)
    v = (blocks(a.variance) + blocks(b_var)) / block**2
    return d / np.sqrt(v)


def sidak_bound(tests: int) -> float:
    """Two-sided z bound of one test in a family of ``tests`` at FAMILY_ALPHA."""
    return float(stats.norm.isf((1.0 - (1.0 - FAMILY_ALPHA) ** (1.0 / tests)) / 2.0))


def test_furnace_agrees_with_independent_and_exact() -> None:
    a = render(SCENES / "furnace.json", spp=64, seed=11, sampler="sobol", batches=16)
    b = render(SCENES / "furnace.json", spp=64, seed=12, sampler="independent")
    assert a.nonfinite == 0 and np.all(a.count == 16)  # 16 batches of 4 spp
    z = block_z(a, b.mean, b.variance)
    assert np.abs(z).max() < sidak_bound(z.size), z
    zx = block_z(a, np.ones_like(a.mean), np.zeros_like(a.variance))
    assert np.abs(zx).max() < sidak_bound(zx.size), zx


def test_padded_dimensions_past_the_table_stay_unbiased(monkeypatch: pytest.MonkeyPatch) -> None:
    """With a 64-dimension table, vertices from depth 7 on draw padded coordinates; the furnace stays exact."""
    monkeypatch.setattr(sobol_film, "RENDER_TABLE_DIMS", 64)
    sc = load_scene(SCENES / "furnace.json")
    cs = compile_scene(sc, rr_depth=20)  # long paths: most reach the padded dimensions
    a = render(cs, spp=64, seed=3, sampler="sobol")
    zx = block_z(a, np.ones_like(a.mean), np.zeros_like(a.variance))
    assert np.abs(zx).max() < sidak_bound(zx.size), zx


def test_cornell_agrees_with_independent_and_has_less_variance() -> None:
    cs = small_cornell(32)
    a = render(cs, spp=128, seed=5, sampler="sobol")
    b = render(cs, spp=128, seed=6, sampler="independent")
    z = block_z(a, b.mean, b.variance)
    assert np.abs(z).max() < sidak_bound(z.size), z
    assert a.spp == b.spp == 128 and a.spp_per_block == 32 and np.all(a.count == sobol_film.DEFAULT_BATCHES)
    # RQMC within a pixel: the honest (between-replicate) variance is well below independent sampling's
    assert np.nanmean(a.variance) < 0.7 * np.nanmean(b.variance)


def test_block_batches_are_block_means() -> None:
    rng = np.random.default_rng(1)
    s = rng.uniform(0.0, 5.0, (3, 2, 2, len(FilmStat)))
    s[..., FilmStat.SAMPLES] = [[[4, 2], [0, 1]]] * 3
    out = sobol_film.block_batches(s)
    n = s[..., FilmStat.SAMPLES]
    for c in range(3):
        y = np.where(n > 0, s[..., c] / np.maximum(n, 1), 0.0)
        np.testing.assert_allclose(out[..., c], y, rtol=1e-15)
        np.testing.assert_allclose(out[..., 3 + c], y * y, rtol=1e-15)
    np.testing.assert_array_equal(out[..., FilmStat.SAMPLES], (n > 0).astype(float))
    np.testing.assert_array_equal(out[..., FilmStat.NONFINITE], s[..., FilmStat.NONFINITE])


def test_sobol_image_does_not_depend_on_split_or_resume(tmp_path: Path) -> None:
    cs = small_cornell(12)
    whole = render(cs, spp=12, seed=7, spp_per_block=2, sampler="sobol")
    two = render(cs, spp=12, seed=7, spp_per_block=2, sampler="sobol", split=2)
    np.testing.assert_array_equal(two.mean, whole.mean)
    np.testing.assert_array_equal(two.variance, whole.variance)
    ckpt = tmp_path / "run.ckpt"

    part = render(cs, spp=12, seed=7, spp_per_block=2, sampler="sobol", checkpoint=ckpt,
                  progress=interrupt_after_first_fold())
    assert part.stopped_by == "interrupt" and 0 < part.spp < 12
    assert Accumulator.load(ckpt).blocks_done * 2 == part.spp
    with pytest.raises(InputError):  # the checkpoint of a sobol render is not an independent one
        render(cs, spp=12, seed=7, sampler="independent", resume=ckpt)
    rest = render(cs, spp=12, seed=7, sampler="sobol", resume=ckpt)
    np.testing.assert_array_equal(rest.mean, whole.mean)
    np.testing.assert_array_equal(rest.variance, whole.variance)
    np.testing.assert_array_equal(rest.count, whole.count)


def test_scene_key_selects_the_sampler_and_the_default_is_unchanged() -> None:
    data = {"camera": {"origin": [0, 0, 3.9], "target": [0, 0, 0], "fov": 40, "width": 8, "height": 8},
            "integrator": {"sampler": "sobol", "spp": 32},
            "materials": {"m": {"type": "diffuse", "reflectance": 0.5}},
            "shapes": [{"type": "sphere", "material": "m", "center": [0, 0, 0], "radius": 1,
                        "emitter": {"type": "area", "radiance": 1.0}}]}
    cs = compile_scene(parse_scene(data))
    assert cs.sampler == "sobol"
    from_scene = render(cs, seed=2)
    np.testing.assert_array_equal(from_scene.mean, render(cs, seed=2, sampler="sobol").mean)
    assert any("sobol" in n for n in from_scene.notes)
    data["integrator"]["sampler"] = "independent"
    plain = compile_scene(parse_scene(data))
    np.testing.assert_array_equal(render(plain, seed=2).mean, render(cs, seed=2, sampler="independent").mean)


def test_bad_sampler_is_refused() -> None:
    data = {"camera": {"origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 4, "height": 4},
            "integrator": {"sampler": "halton"}}
    with pytest.raises(InputError, match="integrator.sampler"):
        parse_scene(data)
    cs = small_cornell(8)
    with pytest.raises(InputError, match="sampler"):
        render(cs, spp=4, sampler="halton")
    with pytest.raises(InputError, match="lt"):
        render(cs, spp=4, sampler="sobol", integrator="lt")


def test_noise_halting_waits_for_enough_batches() -> None:
    """target_error stops a sobol render only once DEFAULT_BATCHES replicates estimate the variance."""
    r = render(SCENES / "furnace.json", target_error=0.5, seed=4, sampler="sobol")
    assert r.stopped_by == "noise" and r.count.min() >= sobol_film.DEFAULT_BATCHES
    assert r.spp_per_block == 64  # the default block (2^20 paths, at most 64 spp) for an unbounded run
