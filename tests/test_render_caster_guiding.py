"""Caustic casters (mcocl/render/caster_guiding.py, kernels/render/caster_guiding.cl).

- Which shapes are casters (glass under a small light), and their bounding spheres.
- The build aims only where it may: nee and mis on scenes with a caster.
- Exactness: a glass ball in the white furnace (radiance Le / (1 - rho) everywhere, through the glass
  too) with nee and mis, independent and sobol samples, and a smooth plastic floor (a delta lobe inside
  the mixture) agreeing with the same render that never aims (share 0).
- The point of it: on a small caustic.json, mis's image mean agrees with bdpt's (an independent
  estimator), and its squared error against a bdpt reference is several times lower than with aiming
  switched off.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import mcocl.render.caster_guiding as caster_guiding
import mcocl.render.device_scene as device_scene
from mcocl.render.api import render
from mcocl.render.caster_guiding import (
    CASTER_CONE_DEG,
    MAX_CASTERS,
    RADIUS_PAD,
    SMALL_LIGHT_SR,
    caster_rows,
    light_solid_angles,
)
from mcocl.render.compiled import load_compiled
from mcocl.render.device_scene import scene_tables
from mcocl.render.job import RenderJob

SCENES = Path(__file__).resolve().parent.parent / "scenes"
RHO = np.array([0.8, 0.5, 0.2])
LE = np.array([0.2, 0.5, 0.8])
GLASS = {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0}


def scene_file(tmp_path: Path, name: str, base: str, materials: dict | None = None, shapes: list | None = None,
               **camera) -> Path:
    """A copy of scenes/``base`` with more materials and shapes and camera settings changed."""
    d = json.loads((SCENES / base).read_text())
    d.pop("comment", None)
    d["materials"].update(materials or {})
    d["shapes"] += shapes or []
    d["camera"].update(camera)
    path = tmp_path / name
    path.write_text(json.dumps(d))
    return path


def furnace_with_ball(tmp_path: Path, floor: dict | None = None) -> Path:
    """scenes/furnace.json with a glass ball in it (and, optionally, a square of ``floor`` under it)."""
    shapes = [{"name": "ball", "type": "sphere", "center": [-0.3, 0.1, -0.8], "radius": 0.35, "material": "glass"}]
    materials = {"glass": GLASS}
    if floor is not None:
        materials["floor"] = floor
        shapes.append({"name": "floor", "type": "rectangle", "material": "floor",
                       "transform": [{"scale": [0.8, 0.8, 1]}, {"rotate": {"axis": [1, 0, 0], "angle": -90}},
                                     {"translate": [-0.3, -0.5, -0.8]}]})
    return scene_file(tmp_path, "furnace_ball.json", "furnace.json", materials, shapes)


def image_mean(r) -> tuple[np.ndarray, np.ndarray]:
    """Mean over pixels and its standard error (pixels are independent)."""
    m = r.mean.reshape(-1, 3).astype(np.float64)
    v = r.variance.reshape(-1, 3).astype(np.float64)
    return m.mean(axis=0), np.sqrt(v.sum(axis=0)) / len(m)


def test_casters_are_the_dielectric_shapes_bounding_spheres(tmp_path: Path) -> None:
    c = caster_rows(load_compiled(SCENES / "caustic.json"))
    np.testing.assert_allclose(c[:, :4], [[0.0, 0.8, 0.0, 0.5 * (1 + RADIUS_PAD)]], rtol=1e-6)
    # its caustic's side: the axis from the lamp (0, 4.44, -2.1) through the ball's centre
    axis = np.array([0.0, 0.8 - 4.44, 2.1]) / np.hypot(0.8 - 4.44, 2.1)
    np.testing.assert_allclose(c[0, 4:], [*axis, np.cos(np.radians(CASTER_CONE_DEG))], rtol=1e-6, atol=1e-7)
    # and a glass cube under the same small lamp: the sphere around its box (the cube [-1, 1]^3 scaled by
    # 0.25 and moved to (1, 0.3, 1))
    cube = scene_file(tmp_path, "cube.json", "caustic.json", shapes=[
        {"name": "block", "type": "cube", "material": "glass",
         "transform": [{"scale": [0.25, 0.25, 0.25]}, {"translate": [1, 0.3, 1]}]}])
    got = caster_rows(load_compiled(cube))
    np.testing.assert_allclose(got[1, :4], [1, 0.3, 1, 0.25 * np.sqrt(3) * (1 + RADIUS_PAD)], rtol=1e-5, atol=1e-6)
    for base in ("cornell.json", "furnace.json", "many_lights.json"):  # no glass
        assert caster_rows(load_compiled(SCENES / base)).shape == (0, 8), base
    thin = json.loads((SCENES / "caustic.json").read_text())
    thin["materials"]["glass"] = {"type": "thindielectric"}
    (tmp_path / "thin.json").write_text(json.dumps(thin))
    assert caster_rows(load_compiled(tmp_path / "thin.json")).shape == (0, 8)
    balls = [{"name": f"b{i}", "type": "sphere", "center": [0.2 * i - 0.8, 0.3, 1.5], "radius": 0.05,
              "material": "glass"} for i in range(MAX_CASTERS)]
    many = scene_file(tmp_path, "many.json", "caustic.json", shapes=balls)  # the ball and 8 more
    assert caster_rows(load_compiled(many)).shape == (0, 8)  # more than the kernel aims at: none
    few = scene_file(tmp_path, "few.json", "caustic.json", shapes=balls[:-1])
    assert caster_rows(load_compiled(few)).shape == (MAX_CASTERS, 8)


def test_only_glass_under_a_small_light_casts(tmp_path: Path) -> None:
    """The Cornell box's ceiling light subtends 0.17 sr from a glass ball in the box: no caster; the
    lamp of caustic.json 4.5e-4 sr; a lamp 40x wider (radius 2) 0.7 sr: none."""
    ball = [{"name": "ball", "type": "sphere", "center": [0.3, 0.3, 0.2], "radius": 0.25, "material": "glass"}]
    box = scene_file(tmp_path, "box.json", "cornell.json", {"glass": GLASS}, ball)
    assert caster_rows(load_compiled(box)).shape == (0, 8)
    wide = json.loads((SCENES / "caustic.json").read_text())
    lamp = next(sh for sh in wide["shapes"] if sh["name"] == "lamp")
    lamp["radius"] = 2.0
    (tmp_path / "wide.json").write_text(json.dumps(wide))
    assert caster_rows(load_compiled(tmp_path / "wide.json")).shape == (0, 8)
    # the solid angle: a sphere of radius r at distance d subtends 2 pi (1 - sqrt(1 - r^2 / d^2)); 4 pi inside it
    got = light_solid_angles(np.array([[0.0, 0, 0, 1], [5.0, 0, 0, 1]]), np.array([[0.0, 3, 4, 0.05], [5.2, 0, 0, 1]]))
    want_far = 2 * np.pi * (1 - np.sqrt(1 - 0.05**2 / 25))
    np.testing.assert_allclose(got[0, 0], want_far, rtol=1e-9)
    assert got[1, 1] == pytest.approx(4 * np.pi)
    assert SMALL_LIGHT_SR > want_far


@pytest.mark.parametrize("integrator,scene,guided", [("mis", "caustic.json", True), ("nee", "caustic.json", True),
                                                     ("path", "caustic.json", False), ("mis", "cornell.json", False)])
def test_only_nee_and_mis_on_scenes_with_casters_are_built_to_aim(integrator: str, scene: str, guided: bool) -> None:
    cs = load_compiled(SCENES / scene)
    job = RenderJob(scene_tables(cs), cs.width, cs.height, integrator, 8, 5, 0, 1, 1, None)
    assert ("-DCASTER_GUIDING=1" in job.options(16)) == guided
    p = job.params(0, 1)
    assert int(p["ncasters"]) == (1 if scene == "caustic.json" else 0)


@pytest.mark.parametrize("integrator", ["nee", "mis"])
@pytest.mark.parametrize("sampler", ["independent", "sobol"])
def test_glass_ball_in_the_white_furnace(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, integrator: str,
                                        sampler: str) -> None:
    """Lossless glass in a uniform field leaves it uniform: every pixel sees Le / (1 - rho).  The furnace's
    light is the enclosure itself, so the ball is made a caster by lifting the small-light bound."""
    monkeypatch.setattr(caster_guiding, "SMALL_LIGHT_SR", 100.0)
    scene = furnace_with_ball(tmp_path)
    rows = caster_rows(load_compiled(scene))
    assert len(rows) == 1 and rows[0, 7] == -1.0  # inside the light's bounding sphere: every side
    r = render(scene, spp=64, integrator=integrator, max_depth=-1, seed=11, sampler=sampler)
    assert r.nonfinite == 0
    est, se = image_mean(r)
    want = LE / (1 - RHO)
    assert np.all(np.abs(est - want) <= 5 * se), ((est - want) / se, se)


def test_a_delta_lobe_inside_the_mixture_agrees_with_no_aiming(tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """A smooth plastic floor under the ball: its coating's delta lobe is drawn with probability
    (1 - share) times its own; the image equals the one that never aims (same build, share 0)."""
    monkeypatch.setattr(caster_guiding, "SMALL_LIGHT_SR", 100.0)
    scene = furnace_with_ball(tmp_path, {"type": "plastic", "diffuse_reflectance": 0.3, "int_ior": 1.5})
    assert len(caster_rows(load_compiled(scene))) == 1
    kw = dict(spp=64, integrator="mis", max_depth=6, seed=3, sampler="independent")
    aimed = render(scene, **kw)
    monkeypatch.setattr(device_scene, "CASTER_SHARE", 0.0)
    plain = render(scene, **kw | {"seed": 4})
    a, sa = image_mean(aimed)
    b, sb = image_mean(plain)
    assert np.all(np.abs(a - b) <= 5 * np.hypot(sa, sb)), ((a - b) / np.hypot(sa, sb))
    assert not np.array_equal(aimed.mean, plain.mean)


@pytest.fixture(scope="module")
def small_caustic(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """scenes/caustic.json at 48 x 36 pixels."""
    return scene_file(tmp_path_factory.mktemp("caustic"), "caustic_small.json", "caustic.json", width=48, height=36)


def test_caustic_mis_agrees_with_bdpt(small_caustic: Path) -> None:
    mis = render(small_caustic, spp=256, integrator="mis", seed=7, sampler="independent")
    bdpt = render(small_caustic, spp=64, integrator="bdpt", seed=8, sampler="independent")
    a, sa = image_mean(mis)
    b, sb = image_mean(bdpt)
    assert np.all(np.abs(a - b) <= 5 * np.hypot(sa, sb)), ((a - b) / np.hypot(sa, sb), a, b)


def test_aiming_lowers_the_caustic_error(small_caustic: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Squared error against a bdpt reference (2048 spp, its own variance subtracted), summed over four
    seeds: 5.6x lower with aiming (over eight seeds 5.2x, 1.9x-10.2x seed by seed)."""
    ref = render(small_caustic, spp=2048, integrator="bdpt", seed=1, sampler="independent")
    ref_var = ref.variance.astype(np.float64).mean()

    def error(share: float) -> float:
        monkeypatch.setattr(device_scene, "CASTER_SHARE", share)
        total = 0.0
        for seed in range(20, 24):
            r = render(small_caustic, spp=256, integrator="mis", seed=seed, sampler="independent")
            total += float(((r.mean.astype(np.float64) - ref.mean) ** 2).mean() - ref_var)
        return total

    aimed, plain = error(caster_guiding.CASTER_SHARE), error(0.0)
    assert plain > 2.0 * aimed, (plain, aimed)


def test_rows_pair_each_caster_with_each_small_light(tmp_path: Path) -> None:
    """A second small lamp beside caustic.json's: two rows for the one ball, each with its own axis (a ball
    inside a light's bounding sphere, which aims from every side, is in the white-furnace test above)."""
    second = {"name": "lamp2", "type": "sphere", "material": "lampshell", "center": [3.0, 0.8, 0.0], "radius": 0.05,
              "emitter": {"type": "area", "radiance": [100, 100, 100]}}
    rows = caster_rows(load_compiled(scene_file(tmp_path, "two.json", "caustic.json", shapes=[second])))
    assert rows.shape == (2, 8)
    axes = sorted(tuple(np.round(r[4:7], 5)) for r in rows)
    assert axes[0] == pytest.approx((-1.0, 0.0, 0.0))  # from (3, 0.8, 0) through (0, 0.8, 0)
    want = np.array([0.0, 0.8 - 4.44, 2.1]) / np.hypot(0.8 - 4.44, 2.1)
    assert axes[1] == pytest.approx(tuple(want), abs=1e-5)


def test_aiming_only_on_the_caustics_side_costs_nothing_in_a_closed_box(tmp_path: Path,
                                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """The Cornell box lit by a small lamp (0.1 x 0.1, the same power), a glass ball on its floor:
    indirect light dominates, and aiming from every floor point (cosine -1) makes the squared error
    against a bdpt reference 4.5x that of no aiming; aiming only within CASTER_CONE_DEG of the
    lamp-ball axis and CASTER_REACH radii of the ball keeps it at 1.02x (bound 1.3x: four seeds of
    32 x 32 pixels)."""
    d = json.loads((SCENES / "cornell.json").read_text())
    light = d["shapes"][0]
    scale = (0.23 * 0.19) / (0.05 * 0.05)
    light["transform"][0]["scale"] = [0.05, 0.05, 0.05]
    light["emitter"]["radiance"] = [x * scale for x in light["emitter"]["radiance"]]
    d["materials"]["glass"] = GLASS
    d["shapes"].append({"name": "ball", "type": "sphere", "center": [0.5, -0.8, 0.5], "radius": 0.2,
                        "material": "glass"})
    d["camera"].update(width=32, height=32)
    path = tmp_path / "small_lamp_box.json"
    path.write_text(json.dumps(d))
    assert len(caster_rows(load_compiled(path))) == 1
    ref = render(path, spp=2048, integrator="bdpt", seed=1, sampler="independent")
    keep = ref.mean.reshape(-1, 3).max(axis=1) < 3.0  # not the lamp seen directly (its edge noise is no one's)
    ref_var = ref.variance.reshape(-1, 3)[keep].astype(np.float64).mean()

    def error(share: float) -> float:
        monkeypatch.setattr(device_scene, "CASTER_SHARE", share)
        total = 0.0
        for seed in range(30, 34):
            r = render(path, spp=64, integrator="mis", seed=seed, sampler="independent")
            diff = r.mean.reshape(-1, 3)[keep].astype(np.float64) - ref.mean.reshape(-1, 3)[keep]
            total += float((diff ** 2).mean() - ref_var)
        return total

    aimed, plain = error(caster_guiding.CASTER_SHARE), error(0.0)
    assert aimed < 1.3 * plain, (aimed, plain)
    # every side, at any distance: the harm the rules prevent
    monkeypatch.setattr(caster_guiding, "CASTER_CONE_DEG", 180.0)
    monkeypatch.setattr(device_scene, "CASTER_REACH", 1e9)
    everywhere = error(caster_guiding.CASTER_SHARE)
    assert everywhere > 2.0 * plain, (everywhere, plain)


@pytest.mark.parametrize("target,aims", [
    ((0.0, 0.0, -1.5), False),  # behind the ball, on the lamp's side: 92 degrees off the lamp-ball axis
    ((0.0, 0.0, 3.0), False),   # in front, 45 degrees off the axis but 6 radii from the centre: out of reach
    ((0.0, 0.0, 0.6), True),    # the caustic's side, within reach
])
def test_points_off_the_caustics_side_or_out_of_reach_do_not_aim(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                                 target: tuple, aims: bool) -> None:
    """caustic.json's floor seen from straight above through a narrow lens: where no visible point aims,
    the render is bit-identical to the same seed's with share 0 (the kernel is the same; a lane that does
    not aim draws and weighs exactly as without aiming); where they aim, it is not."""
    x, y, z = target
    scene = scene_file(tmp_path, "view.json", "caustic.json", origin=[x, 3.0, z], target=[x, y, z], up=[0, 0, -1],
                       fov=8, width=12, height=12)
    kw = dict(spp=16, integrator="mis", max_depth=6, seed=5, sampler="independent")
    aimed = render(scene, **kw)
    monkeypatch.setattr(device_scene, "CASTER_SHARE", 0.0)
    plain = render(scene, **kw)
    assert np.array_equal(aimed.mean, plain.mean) != aims
