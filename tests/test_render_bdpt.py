"""Bidirectional path tracing (``integrator="bdpt"``, kernels/render/bdpt.cl).

- The white furnace's closed forms (max_depth -1, 1, 3; power and balance heuristics), also inside the
  emitting sphere at max_depth 3, where same-length weighted strategies must agree pixel by pixel
  (tests/test_bdpt_weights.py checks that one path's weights sum to 1).
- The strategies: each unweighted strategy of path length 2 alone is unbiased
  for the paths it samples (the furnace's L_e rho); the weighted strategies of
  a render sum to the full render exactly (same random numbers); so the MIS
  weights of every path length sum to 1 in expectation (the full estimate of
  each length matches its closed form).
- Agreement with ``mis`` per 8 x 8-pixel block (Sidak-corrected z-tests) on the
  Cornell box, with plastic walls, and on the caustic scene (a glass sphere: delta
  vertices that connections must pass by sampling).
- Determinism: bit-identical images across launch splits, sub-devices and a resume.
- A constant environment renders as under ``mis``.
- Bad settings: clear errors.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import stats
from test_render_lt import LE, RHO, assert_blocks_agree, assert_pixels_agree, downscaled, furnace_closed_form

from mcocl.errors import InputError
from mcocl.render.api import render
from mcocl.render.compiled import compile_scene
from mcocl.render.image_io import read_exr
from mcocl.render.scene import parse_scene
from mcocl.render.scene_file import load_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"


def _mean_and_se(r) -> tuple[np.ndarray, np.ndarray]:
    """The image's mean per channel and its standard error (batches independent, pixels summed)."""
    m = r.mean.reshape(-1, 3).astype(np.float64)
    v = r.variance.reshape(-1, 3).astype(np.float64)
    return m.mean(axis=0), np.sqrt(v.sum(axis=0)) / len(m)


@pytest.mark.parametrize("mis", ["power", "balance"])
@pytest.mark.parametrize("max_depth", [-1, 1, 3])
def test_furnace_closed_form(max_depth: int, mis: str) -> None:
    r = render(SCENES / "furnace.json", spp=32, integrator="bdpt", max_depth=max_depth, seed=11, mis=mis)
    assert r.spp == 32 and r.nonfinite == 0 and r.integrator == "bdpt"
    est, se = _mean_and_se(r)
    want = furnace_closed_form(max_depth)
    assert np.all(np.abs(est - want) <= 5 * se + 1e-6), (est, want, se)


def test_max_depth_zero_is_black() -> None:
    r = render(SCENES / "furnace.json", spp=2, integrator="bdpt", max_depth=0, seed=1)
    assert np.all(r.mean == 0)


@pytest.mark.parametrize("strategy", [(0, 3), (1, 2), (2, 1)])
def test_each_unweighted_strategy_is_unbiased(strategy: tuple[int, int]) -> None:
    """Paths of 2 segments in the furnace: every strategy alone estimates L_e rho."""
    r = render(SCENES / "furnace.json", spp=64, integrator="bdpt", max_depth=2, seed=3, strategy=strategy,
               unweighted=True)
    est, se = _mean_and_se(r)
    want = LE * RHO
    assert np.all(np.abs(est - want) <= 5 * se + 1e-6), (est, want, se)


@pytest.mark.parametrize("strategy", [(1, 2), (1, 3), (2, 2)])
def test_connections_in_a_spherical_furnace_are_exact(strategy: tuple[int, int]) -> None:
    """Inside an emitting diffuse sphere, a connection's f cos cos / d^2 over the uniform area density is
    the same for every pair of points: the unweighted connection strategies estimate L_e rho^(k-1) of
    paths of k segments with zero variance, so every pixel of every sample is exact."""
    k = sum(strategy) - 1
    # exact for any sample points, so the sampler is incidental: sobol is the build the closed-form test below
    # takes at its 256 spp (auto would take independent at 4 spp, a build of its own: 20 to 30 s cold)
    r = render(SCENES / "furnace_sphere.json", spp=4, integrator="bdpt", max_depth=k, seed=2, strategy=strategy,
               unweighted=True, sampler="sobol")
    want = np.broadcast_to(LE * RHO ** (k - 1), r.mean.shape)
    np.testing.assert_allclose(r.mean, want, rtol=2e-5)


@pytest.mark.parametrize("mis", ["power", "balance"])
def test_spherical_furnace_closed_form(mis: str) -> None:
    """max_depth 3 inside the emitting sphere: once 1e-3 low (-7 sigma at high spp) when the walks' MIS
    densities followed their offset rays instead of the vertices (see test_weights_follow_the_vertices)."""
    r = render(SCENES / "furnace_sphere.json", spp=256, integrator="bdpt", max_depth=3, seed=11, mis=mis)
    est, se = _mean_and_se(r)
    want = LE * (1 + RHO + RHO**2)
    assert np.all(np.abs(est - want) <= 5 * se + 1e-6), (est, want, se)


@pytest.mark.parametrize("strategies", [[(0, 3), (1, 2)], [(0, 4), (1, 3), (2, 2)]])
def test_weights_follow_the_vertices(strategies: list[tuple[int, int]]) -> None:
    """Inside the emitting diffuse sphere every area density but the camera's is 1 / area, so the weight of
    a strategy (s, t >= 2) depends on z_1 alone, and the same seed gives the same camera subpath: the
    weighted images of one path length must agree pixel by pixel (their unweighted values are exact).
    A walk whose densities follow its sampled ray (leaving an offset origin) rather than the geometric
    direction between its vertices broke this by up to 10% in a pixel."""
    k = sum(strategies[0]) - 1
    imgs = [render(SCENES / "furnace_sphere.json", spp=2, integrator="bdpt", max_depth=k, seed=5,
                   strategy=st, sampler="sobol").mean.astype(np.float64) for st in strategies]
    for img in imgs[1:]:
        np.testing.assert_allclose(img, imgs[0], rtol=2e-4)


def test_weighted_strategies_sum_to_the_full_render() -> None:
    """One seed: the weighted strategies' images add up to the render of all strategies (float rounding
    apart), and the part of path length 2 matches its closed form: its MIS weights sum to 1.  The full
    render without its connection roulette, which a single strategy never plays."""
    kw = {"spp": 32, "integrator": "bdpt", "max_depth": 2, "seed": 5}
    full = render(SCENES / "furnace.json", roulette=False, **kw).mean.astype(np.float64)
    parts = {st: render(SCENES / "furnace.json", strategy=st, **kw).mean.astype(np.float64)
             for st in [(0, 2), (1, 1), (0, 3), (1, 2), (2, 1)]}
    np.testing.assert_allclose(sum(parts.values()), full, rtol=1e-5, atol=1e-6)
    length2 = sum(parts[st] for st in [(0, 3), (1, 2), (2, 1)]).reshape(-1, 3).mean(axis=0)
    np.testing.assert_allclose(length2, LE * RHO, rtol=2e-2)


def test_bdpt_agrees_with_mis_on_cornell() -> None:
    cs = downscaled("cornell.json", 32)
    # per-pixel z-tests: the reference's variance from independent samples, not 4 sobol batches
    a = render(cs, spp=1024, integrator="mis", seed=1, sampler="independent")
    b = render(cs, spp=128, integrator="bdpt", seed=2, spp_per_block=2)
    assert b.nonfinite == 0
    assert_blocks_agree(a, b)
    assert_pixels_agree(a, b)


def test_bdpt_agrees_with_mis_through_glass() -> None:
    """The caustic scene: a glass sphere (delta vertices) and a small spherical lamp.  Blocks only: mis's
    own per-pixel variance estimate is unreliable in the caustic (rare, large samples)."""
    cs = downscaled("caustic.json", 32)
    a = render(cs, spp=1024, integrator="mis", seed=1)
    b = render(cs, spp=128, integrator="bdpt", seed=2, spp_per_block=2)
    assert b.nonfinite == 0
    assert_blocks_agree(a, b)


def test_bdpt_agrees_with_mis_on_plastic() -> None:
    """Cornell with plastic walls: a connection joins a path at a vertex the walk left by the delta coat;
    the weight once kept that delta flag and left strategies out (bdpt 22% too bright)."""
    data = json.loads((SCENES / "cornell.json").read_text())
    data["camera"]["width"] = data["camera"]["height"] = 32
    data["materials"] = {k: {"type": "plastic", "diffuse_reflectance": m["reflectance"]} if m["type"] == "diffuse"
                         else m for k, m in data["materials"].items()}
    cs = compile_scene(parse_scene(data, SCENES / "cornell.json"))
    a = render(cs, spp=1024, integrator="mis", seed=1)
    b = render(cs, spp=128, integrator="bdpt", seed=2, spp_per_block=2)
    assert b.nonfinite == 0
    assert_blocks_agree(a, b)


def thin_lens_cornell():
    """The Cornell box at 32 x 32 pixels through a thin lens (aperture radius 0.15, focused at 2.5)."""
    sc = load_scene(SCENES / "cornell.json")
    sc.camera.width = sc.camera.height = 32
    sc.camera.aperture_radius, sc.camera.focus_distance = 0.15, 2.5
    return compile_scene(sc)


def test_thin_lens_bdpt_agrees_with_mis() -> None:
    """Depth of field: camera subpaths start at lens points, t = 1 connections reach uniform lens points."""
    cs = thin_lens_cornell()
    a = render(cs, spp=1024, integrator="mis", seed=3)
    # the independent sampler, as this test was written for (its per-pixel z-scores are seed-sensitive:
    # against 4096 independent mis spp, max |z| 5.2-5.7 over seeds 4-6 for either bdpt sampler);
    # tests/test_render_bdpt_sobol.py has the sobol sampler's thin lens
    b = render(cs, spp=128, integrator="bdpt", seed=4, spp_per_block=2, sampler="independent")
    assert_blocks_agree(a, b)
    assert_pixels_agree(a, b)


# A scene with every emitter kind: an area light, a constant environment, point, spot and directional
# lights, over a plane with a rough metal sphere and a glass one.
EVERY_EMITTER = {
    "camera": {"origin": [0, 1.5, 3], "target": [0, 0.3, 0], "up": [0, 1, 0], "fov": 60, "width": 24, "height": 16},
    "materials": {"white": {"type": "diffuse", "reflectance": 0.6}, "metal": {"type": "roughconductor", "alpha": 0.3},
                  "glass": {"type": "dielectric"}},
    "shapes": [
        {"type": "rectangle", "material": "white",
         "transform": [{"scale": 2}, {"rotate": {"axis": [1, 0, 0], "angle": -90}}]},
        {"type": "sphere", "material": "metal", "center": [0, 0.5, 0], "radius": 0.5},
        {"type": "sphere", "material": "glass", "center": [0.8, 0.3, 0.5], "radius": 0.3},
        {"type": "sphere", "material": "white", "center": [-0.9, 0.2, 0.6], "radius": 0.2,
         "emitter": {"type": "area", "radiance": [3.0, 2.0, 1.0]}},
    ],
    "environment": {"type": "constant", "radiance": [0.3, 0.4, 0.5]},
    "lights": [{"type": "point", "position": [0.3, 1.0, 1.0], "intensity": [1.0, 0.8, 0.6]},
               {"type": "spot", "position": [-0.4, 1.3, 1.5], "target": [-0.6, 0.1, 0.0],
                "intensity": [3.0, 4.0, 5.0], "cutoff_angle": 35.0, "beam_width": 15.0},
               {"type": "directional", "direction": [0.3, -1.0, -0.5], "irradiance": [0.5, 0.6, 0.4]}],
}


@pytest.mark.parametrize("scene", ["cornell.json", "caustic.json", "every_emitter"])
def test_lane_builds_agree_with_the_scalar_build(scene: str) -> None:
    """Every sample draws the same numbers in every lane width (kernels/render/bdpt.cl, "Lanes"), so a
    packet build differs from the scalar one only in the order of its float additions: a lane that
    leaked into another's strategies, or a masked lane that splatted, would differ by far more.
    every_emitter: lanes of one packet start at different kinds of light and end at infinity or not."""
    if scene == "every_emitter":
        cs = compile_scene(parse_scene(EVERY_EMITTER))
    else:
        sc = load_scene(SCENES / scene)
        sc.camera.width, sc.camera.height = 24, 16
        # every_emitter's point lights take the power light sampler: the other scenes take it too, so that the
        # three share the two narrow builds (a build per light sampler and width cost 20 to 40 s on a cold cache)
        sc.light_sampler = "power"
        cs = compile_scene(sc)
    scalar = render(cs, spp=16, integrator="bdpt", seed=5, lanes=1).mean.astype(np.float64)
    assert scalar.max() > 0
    for lanes in (4, 16):
        packed = render(cs, spp=16, integrator="bdpt", seed=5, lanes=lanes).mean.astype(np.float64)
        assert np.abs(packed - scalar).max() <= 1e-5 * scalar.max(), lanes


# Launch splits, sub-devices and resume: tests/test_render_lt.py runs them for bdpt too (SPLATTING).


@pytest.mark.parametrize(("kw", "match"), [
    ({"mis": "cubic"}, "heuristic"),
    ({"strategy": (0, 0)}, "t >= 1"),
    ({"strategy": (3, 3)}, "max_depth"),
    ({"strategy": "ab"}, "whole numbers"),
    ({"unweighted": True}, "only with a strategy"),
    ({"roulette": 0}, "True or False"),
])
def test_bad_settings(kw: dict, match: str) -> None:
    with pytest.raises(InputError, match=match):
        render(SCENES / "furnace.json", spp=1, integrator="bdpt", max_depth=3, **kw)


@pytest.mark.parametrize("strategy", [(1.5, 2), "12", (1,), (1, 2, 3), (float("nan"), 2), (True, 2)])
def test_a_strategy_is_a_pair_of_whole_numbers(strategy) -> None:
    """int() took (1.5, 2) and the string "12" for strategy (1, 2) (issue 10: bench/hostile_suite.py)."""
    with pytest.raises(InputError, match="two whole numbers"):
        render(SCENES / "furnace.json", spp=1, integrator="bdpt", max_depth=3, strategy=strategy)


def test_a_strategy_past_the_kernels_subpaths_is_refused() -> None:
    """With max_depth -1 nothing bounded a strategy: (30, 1) rendered black (no subpath has 30 vertices)
    and (10**30, 1) overflowed the launch parameters with a traceback."""
    from mcocl.render.bdpt_settings import BDPT_MAX_VERTICES

    kernel = (Path(__file__).resolve().parent.parent / "kernels" / "render" / "bdpt.cl").read_text()
    assert f"#define BDPT_MAX_VERTICES {BDPT_MAX_VERTICES}\n" in kernel
    for strategy in ((BDPT_MAX_VERTICES + 1, 1), (1, BDPT_MAX_VERTICES + 1), (10**30, 1)):
        with pytest.raises(InputError, match="bdpt's limit"):
            render(SCENES / "furnace.json", spp=1, integrator="bdpt", max_depth=-1, strategy=strategy)


def test_bdpt_settings_are_bdpts_only() -> None:
    with pytest.raises(InputError, match="bdpt's settings"):
        render(SCENES / "furnace.json", spp=1, integrator="mis", mis="balance")
    with pytest.raises(InputError, match="bdpt's settings"):
        render(SCENES / "furnace.json", spp=1, integrator="lt", roulette=False)


def test_connection_roulette_is_on_by_default_and_unbiased() -> None:
    """The roulette on connection shadow rays (kernels/render/bdpt.cl, connection_roulette) changes the
    image of a seed (so it plays) but not its expectation: inside the emitting sphere at max_depth 3 the
    estimate with it matches the closed form L_e (1 + rho + rho^2), within 5 standard errors, as without."""
    kw = {"spp": 64, "integrator": "bdpt", "max_depth": 3, "seed": 7}
    on = render(SCENES / "furnace_sphere.json", **kw)
    off = render(SCENES / "furnace_sphere.json", roulette=False, **kw)
    assert not np.array_equal(on.mean, off.mean)
    want = LE * (1 + RHO + RHO**2)
    for r in (on, off):
        est, se = _mean_and_se(r)
        assert np.all(np.abs(est - want) <= 5 * se + 1e-6), (est, want, se)


def test_environment_renders_like_mis() -> None:
    """A constant environment (once refused): escaped camera rays end at infinity (kernels/render/bdpt.cl);
    per pixel against mis (Sidak-corrected z-tests; tests/test_render_envmap.py checks maps and blocks)."""
    scene = {
        "camera": {"origin": [0, 0, 3], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 40, "width": 4, "height": 4},
        "materials": {"m": {"type": "diffuse", "reflectance": 0.5}},
        "environment": {"type": "constant", "radiance": 1.0},
        "shapes": [{"name": "s", "type": "sphere", "material": "m"}],
    }
    a = render(parse_scene(scene), spp=4096, integrator="mis", seed=1)
    b = render(parse_scene(scene), spp=4096, integrator="bdpt", seed=2, spp_per_block=64)
    assert b.nonfinite == 0
    z = (a.mean - b.mean) / np.sqrt(a.variance + b.variance + 1e-30)
    assert 2 * stats.norm.sf(np.abs(z).max()) > 1 - (1 - 1e-3) ** (1 / z.size), np.abs(z).max()


def test_cli_no_roulette(tmp_path: Path) -> None:
    """``mcocl render --no-roulette`` renders what ``roulette=False`` does, and is refused for another integrator."""
    out = tmp_path / "b.exr"
    # 16 lanes on both sides: the 16-lane build of this scene's variant is the one the launch-split, sub-device
    # and dask tests build (the lane width is incidental here: the CLI and the API take the same build)
    args = [sys.executable, "-m", "mcocl", "render", str(SCENES / "furnace.json"), "--spp", "8", "--max-depth", "3",
            "--seed", "5", "--lanes", "16"]
    p = subprocess.run([*args, "--integrator", "bdpt", "--no-roulette", "--out", str(out)], capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    want = render(SCENES / "furnace.json", spp=8, integrator="bdpt", max_depth=3, seed=5, roulette=False,
                  lanes=16).mean
    np.testing.assert_allclose(read_exr(out).mean, want, rtol=1e-6)
    p = subprocess.run([*args, "--integrator", "mis", "--no-roulette", "--out", str(tmp_path / "m.exr")],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode != 0 and "bdpt's settings" in p.stderr
