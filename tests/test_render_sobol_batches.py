"""The batches of the ``sobol`` render sampler (``batches``, ``--batches``; mcocl/render/sobol_film.py).

- A render of ``spp`` takes DEFAULT_BATCHES (or ``batches``) blocks of
  ceil(spp / B) samples, one scrambling each; under noise halting blocks keep
  their default size and the run waits for B of them.
- The reported variance is unbiased for the variance of the pixel mean: its
  mean over pixels agrees with the spread of pixel means over independent
  seeds (a last, shorter batch included), within 4 standard errors, and the
  test resolves a bias of 40 %.
- c4(B) is Gamma-function exact, and dividing it out makes the mean
  relative standard error of normal batch means unbiased (checked on numbers
  drawn with a fixed seed, in standard-error units).
- The image depends on the seed and the batches only: launch splits, an
  interrupted, resumed run and the build's points per scrambling give the same bits.
- The scene key ``integrator.batches`` sets them; the keyword overrides it.
- Bad values are refused with InputError naming ``batches``.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from device_doubles import small_cornell
from interrupting import interrupt_after_first_fold

from mcocl.errors import InputError
from mcocl.render import sobol_film
from mcocl.render.api import render
from mcocl.render.compiled import compile_scene
from mcocl.render.job import default_spp_per_block
from mcocl.render.scene import parse_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"



def test_spp_is_split_into_the_batches() -> None:
    cs = small_cornell(8)
    r = render(cs, spp=64, seed=1, sampler="sobol")
    assert sobol_film.DEFAULT_BATCHES == 4 and r.spp_per_block == 16 and np.all(r.count == 4)
    r = render(cs, spp=64, seed=1, sampler="sobol", batches=8)
    assert r.spp_per_block == 8 and np.all(r.count == 8) and r.spp == 64
    r = render(cs, spp=10, seed=1, sampler="sobol", batches=4)  # 3 + 3 + 3 + 1
    assert r.spp_per_block == 3 and np.all(r.count == 4) and r.spp == 10
    r = render(cs, spp=2, seed=1, sampler="sobol", batches=4)  # fewer samples than batches
    assert r.spp_per_block == 1 and np.all(r.count == 2)


def test_reported_variance_is_unbiased_for_the_pixel_mean() -> None:
    """E[reported variance] = Var(pixel mean): both averaged over pixels, from 12 independent seeds.

    Per pixel and channel d = (mean over seeds of the reported variance) - (the sample variance of the
    12 pixel means); each term is unbiased for Var(pixel mean) if the film is honest, and pixels are
    independent (their own scramblings), so any fixed weighting of d has mean 0, which is tested within
    4 standard errors over pixels.  The weights, 1 / the pixel's variance in an independent-sampler
    render of other seeds, keep the few bright, noisy pixels (the light's edge) from swamping the rest.
    14 spp in 4 batches: 4 + 4 + 4 + 2 samples, so the unequal last batch is covered too.
    """
    cs = small_cornell(16)
    runs = [render(cs, spp=14, seed=40 + k, sampler="sobol") for k in range(12)]
    assert runs[0].spp_per_block == 4 and np.all(runs[0].count == 4)
    scale = render(cs, spp=256, seed=99).variance.astype(np.float64)
    means = np.stack([r.mean.astype(np.float64) for r in runs])
    reported = np.stack([r.variance.astype(np.float64) for r in runs]).mean(axis=0)
    empirical = means.var(axis=0, ddof=1)
    ok = scale > 0
    d = (reported - empirical)[ok] / scale[ok]
    se = d.std(ddof=1) / math.sqrt(d.size)
    assert abs(d.mean()) < 4.0 * se, (d.mean(), se)
    # the bound resolves a variance 40 % off (the per-sample variance that ignores the nets' stratification
    # would be off by more): the test could fail for a wrong variance
    level = float(np.mean(empirical[ok] / scale[ok]))
    assert 4.0 * se < 0.4 * level, (se, level)


def test_stderr_bias_is_c4() -> None:
    np.testing.assert_allclose(sobol_film.stderr_bias(2), math.sqrt(2.0 / math.pi), rtol=1e-14)
    np.testing.assert_allclose(sobol_film.stderr_bias(4), math.sqrt(2.0 / 3.0) * 1.0 / (math.sqrt(math.pi) / 2),
                               rtol=1e-14)  # Gamma(2) / Gamma(3/2)
    np.testing.assert_allclose(sobol_film.stderr_bias(np.array([3.0])), [math.sqrt(math.pi) / 2], rtol=1e-14)
    assert sobol_film.stderr_bias(16) == pytest.approx(0.9835, abs=1e-4)  # tabulated c4(16)
    assert np.isnan(sobol_film.stderr_bias(1)) and np.isnan(sobol_film.stderr_bias(0))


def test_batch_relative_error_is_unbiased_for_normal_batch_means() -> None:
    """Normal batch means with known sigma: the film's mean stderr / mean reads low by c4(B), the
    batch relative error does not (mean over 20,000 pixels, 4 standard errors)."""
    rng = np.random.default_rng(2026)
    b, pixels, mu, sigma = 4, 20_000, 2.0, 0.5
    y = rng.normal(mu, sigma, (b, pixels, 1, 3))
    mean = np.full((pixels, 1, 3), mu)  # the mean's own noise left out: this checks the square root's bias
    variance = y.var(axis=0, ddof=1) / b
    count = np.full((pixels, 1), float(b))
    truth = sigma / math.sqrt(b) / mu
    per_pixel = np.sqrt(variance) / (sobol_film.stderr_bias(b) * mean)
    se = per_pixel.std(ddof=1) / math.sqrt(per_pixel.size)
    got = sobol_film.batch_relative_error(mean, variance, count)
    assert got == pytest.approx(per_pixel.mean(), rel=1e-12)
    assert abs(got - truth) < 4.0 * se
    plain = float(np.mean(np.sqrt(variance) / mean))
    assert truth - plain > 10.0 * se  # without c4 the estimate is biased low, and visibly so


def test_image_depends_on_seed_and_batches_only(tmp_path: Path) -> None:
    cs = small_cornell(12)
    whole = render(cs, spp=24, seed=7, sampler="sobol", batches=6)
    two = render(cs, spp=24, seed=7, sampler="sobol", batches=6, split=2)
    np.testing.assert_array_equal(two.mean, whole.mean)
    np.testing.assert_array_equal(two.variance, whole.variance)
    other = render(cs, spp=24, seed=7, sampler="sobol", batches=4)
    assert not np.array_equal(other.mean, whole.mean)  # the batches are part of what the image depends on
    ckpt = tmp_path / "run.ckpt"

    part = render(cs, spp=24, seed=7, sampler="sobol", batches=6, checkpoint=ckpt, progress=interrupt_after_first_fold())
    assert part.stopped_by == "interrupt" and 0 < part.spp < 24
    with pytest.raises(InputError, match="batches"):  # 4 batches would be blocks of 6, not the saved 4
        render(cs, spp=24, seed=7, sampler="sobol", batches=4, resume=ckpt)
    rest = render(cs, spp=24, seed=7, sampler="sobol", batches=6, resume=ckpt)
    np.testing.assert_array_equal(rest.mean, whole.mean)
    np.testing.assert_array_equal(rest.variance, whole.variance)
    np.testing.assert_array_equal(rest.count, whole.count)


def test_points_per_scrambling_of_the_build_do_not_change_the_image(monkeypatch: pytest.MonkeyPatch) -> None:
    """RENDER_LOG2_POINTS (2^12 points per scrambling, so that batches of up to 4096 spp share one build)
    gives the bits of the 2^8 that the builds had before: the Sobol' point and its scrambling do not depend on it."""
    cs = small_cornell(8)
    wide = render(cs, spp=32, seed=5, sampler="sobol")
    monkeypatch.setattr(sobol_film, "RENDER_LOG2_POINTS", 8)
    narrow = render(cs, spp=32, seed=5, sampler="sobol")
    np.testing.assert_array_equal(wide.mean, narrow.mean)
    np.testing.assert_array_equal(wide.variance, narrow.variance)


def test_noise_halting_keeps_default_blocks_and_waits_for_the_batches() -> None:
    r = render(SCENES / "furnace.json", target_error=0.5, seed=4, sampler="sobol", batches=3)
    assert r.stopped_by == "noise" and r.count.min() >= 3
    assert r.spp_per_block == default_spp_per_block(r.width, r.height)
    assert r.relative_error <= 0.5


def test_bad_batches_are_refused() -> None:
    cs = small_cornell(8)
    for bad in (1, 0, -2, 2.5, "four", True):
        with pytest.raises(InputError, match="batches"):
            render(cs, spp=8, sampler="sobol", batches=bad)
    with pytest.raises(InputError, match="batches"):  # the independent film's variance is per sample
        render(cs, spp=8, batches=4, sampler="independent")
    with pytest.raises(InputError, match="spp_per_block"):
        render(cs, spp=8, sampler="sobol", batches=4, spp_per_block=2)


def sphere_scene(integrator: dict) -> dict:
    """An 8 x 8 emissive sphere scene with the given integrator object."""
    return {"camera": {"origin": [0, 0, 3.9], "target": [0, 0, 0], "fov": 40, "width": 8, "height": 8},
            "integrator": integrator, "materials": {"m": {"type": "diffuse", "reflectance": 0.5}},
            "shapes": [{"type": "sphere", "material": "m", "center": [0, 0, 0], "radius": 1,
                        "emitter": {"type": "area", "radiance": 1.0}}]}


def test_scene_key_sets_the_batches() -> None:
    cs = compile_scene(parse_scene(sphere_scene({"sampler": "sobol", "batches": 8, "spp": 32})))
    r = render(cs, seed=3)
    assert cs.batches == 8 and r.spp_per_block == 4 and np.all(r.count == 8)
    np.testing.assert_array_equal(r.mean, render(cs, seed=3, batches=8).mean)
    assert render(cs, seed=3, batches=2).spp_per_block == 16  # the keyword wins
    for bad in (1, 2.5, "8"):
        with pytest.raises(InputError, match="integrator.batches"):
            parse_scene(sphere_scene({"sampler": "sobol", "batches": bad}))
    with pytest.raises(InputError, match="integrator.batches"):  # independent sampling has no batches
        parse_scene(sphere_scene({"sampler": "independent", "batches": 4}))
    # a file asking for sobol with lt contradicts itself (bdpt has a sobol back end: kernels/render/bdpt.cl)
    with pytest.raises(InputError, match="integrator.sampler"):
        parse_scene(sphere_scene({"type": "lt", "sampler": "sobol"}))
    assert parse_scene(sphere_scene({"type": "bdpt", "sampler": "sobol"})).sampler == "sobol"
    # batches choose sobol under auto for bdpt too (as the batches keyword does), never for lt
    assert parse_scene(sphere_scene({"type": "bdpt", "batches": 4})).sampler == "sobol"
    with pytest.raises(InputError, match="integrator.batches"):
        parse_scene(sphere_scene({"type": "lt", "batches": 4}))
    # ... --integrator lt on a sobol scene declines the scene's sampler, with a note, and its batches;
    # --integrator bdpt keeps sobol and the scene's batches (blocks: mcocl/render/splat_film.py)
    r = render(cs, spp=16, seed=3, integrator="lt")
    assert r.sampler == "independent" and any("draws independent samples" in n for n in r.notes)
    r = render(cs, spp=16, seed=3, integrator="bdpt")
    assert r.sampler == "sobol" and r.spp_per_block == 2 and np.all(r.count == 8)


def test_cli_batches(tmp_path: Path) -> None:
    def mcocl(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "mcocl", "render", str(SCENES / "furnace.json"), *args],
                              capture_output=True, text=True, timeout=300)

    p = mcocl("--spp", "8", "--max-depth", "2", "--sampler", "sobol", "--batches", "2", "--json",
              "--out", str(tmp_path / "f.exr"))
    assert p.returncode == 0, p.stderr
    assert '"spp_per_block": 4' in p.stdout
    p = mcocl("--spp", "8", "--sampler", "sobol", "--batches", "1", "--out", str(tmp_path / "g.exr"))
    assert p.returncode == 2 and "batches" in p.stderr and "Traceback" not in p.stderr
    p = mcocl("--spp", "8", "--batches", "0", "--out", str(tmp_path / "h.exr"))
    assert p.returncode == 2 and "--batches" in p.stderr
