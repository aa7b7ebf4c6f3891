"""Point, spot and directional lights (mcocl/render/delta_lights.py, kernels/render/delta_lights.cl).

- Closed form: a diffuse plane under a point, a spot and a directional
  light; every pixel's radiance is (rho / pi) times the irradiance
  I cos / d^2 (times the spot's falloff) plus E cos, averaged over the pixel's
  footprint by quadrature.  nee, mis and lt must match it per pixel and per
  8 x 8 block (Sidak-corrected z-tests); path sees nothing.
- Agreement: nee, mis, lt and bdpt on a Cornell box lit by its area light
  plus a point and a spot light, in 8 x 8 blocks; bdpt against the closed
  form.
- Emitter rays of the delta lights: the spot's directions are uniform in its
  cone (chi-square), the point light's uniform on the sphere; densities,
  positions and radiance against their closed forms; the choice probability
  follows the powers.
- The scene file and Mitsuba XML: validation errors, the XML twin compiles
  to the same light records; the light BVH takes point and spot lights
  (closed form) and refuses directional ones.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest
from chi2 import Chi2Family
from scipy import stats
from test_render_lt import AdjointKernels

from mcocl.errors import InputError
from mcocl.render.api import render
from mcocl.render.compiled import compile_scene
from mcocl.render.device_scene import scene_tables
from mcocl.render.emitter_choice import LUMINANCE, bounding_sphere
from mcocl.render.scene import parse_scene
from mcocl.render.scene_file import load_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"
FAMILY = Chi2Family("delta light rays", 3)

RHO = 0.5
POINT = {"type": "point", "position": [0.3, -0.2, 1.0], "intensity": [1.0, 0.8, 0.6]}
SPOT = {"type": "spot", "position": [-0.4, 0.3, 1.5], "target": [-0.6, 0.1, 0.0], "intensity": [3.0, 4.0, 5.0],
        "cutoff_angle": 35.0, "beam_width": 15.0}
DIRECTIONAL = {"type": "directional", "direction": [0.3, -0.2, -1.0], "irradiance": [0.2, 0.3, 0.1]}


def plane_scene(size: int = 16, lights: list | None = None) -> dict:
    """A 4 x 4 diffuse plane at z = 0 (front +z) seen from straight above; it fills the whole image."""
    return {
        "camera": {"origin": [0, 0, 3], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 60,
                   "width": size, "height": size},
        "integrator": {"type": "mis", "max_depth": -1},
        "materials": {"white": {"type": "diffuse", "reflectance": RHO}},
        "shapes": [{"type": "rectangle", "material": "white", "transform": [{"scale": [2, 2, 1]}]}],
        "lights": copy.deepcopy(lights if lights is not None else [POINT, SPOT, DIRECTIONAL]),
    }


def spot_falloff(cos_t: np.ndarray, cutoff_deg: float, beam_deg: float) -> np.ndarray:
    """Mitsuba 3's spot falloff: 1 within the beam, linear in the angle to 0 at the cutoff."""
    ang = np.arccos(np.clip(cos_t, -1, 1))
    cut, beam = math.radians(cutoff_deg), math.radians(beam_deg)
    ramp = np.clip((cut - ang) / (cut - beam), 0, 1)
    return np.where(ang <= beam, 1.0, np.where(ang < cut, ramp, 0.0))


def irradiance(x: np.ndarray, lights: list[dict]) -> np.ndarray:
    """RGB irradiance (n, 3) at points x (n, 3) of the plane z = 0 (normal +z)."""
    e = np.zeros((len(x), 3))
    for li in lights:
        if li["type"] == "directional":
            d = np.asarray(li["direction"], float)
            d /= np.linalg.norm(d)
            e += np.asarray(li["irradiance"]) * max(-d[2], 0.0)
            continue
        v = np.asarray(li["position"], float) - x
        dist = np.linalg.norm(v, axis=1)
        cos_s = v[:, 2] / dist
        f = np.ones(len(x))
        if li["type"] == "spot":
            axis = np.asarray(li["target"], float) - li["position"]
            axis /= np.linalg.norm(axis)
            f = spot_falloff(-(v @ axis) / dist, li["cutoff_angle"], li["beam_width"])
        e += np.asarray(li["intensity"])[None] * (f * np.maximum(cos_s, 0) / dist**2)[:, None]
    return e


def closed_form_image(cs, lights: list[dict], sub: int = 24) -> np.ndarray:
    """(H, W, 3): each pixel's mean radiance (rho / pi) E over its footprint (midpoint rule, sub^2 points)."""
    o, right, up, fwd = (cs.camera[i, :3].astype(np.float64) for i in range(4))
    w, h = cs.width, cs.height
    s = (np.arange(sub) + 0.5) / sub
    px, py = np.meshgrid(np.arange(w), np.arange(h))
    jx, jy = np.meshgrid(s, s)
    sx = px[..., None] + jx.ravel()[None, None]
    sy = py[..., None] + jy.ravel()[None, None]
    ndc_x, ndc_y = 2 * sx / w - 1, 1 - 2 * sy / h
    d = fwd + ndc_x[..., None] * right + ndc_y[..., None] * up
    t = -o[2] / d[..., 2]
    x = o + t[..., None] * d
    e = irradiance(x.reshape(-1, 3), lights).reshape(h, w, -1, 3)
    return RHO / math.pi * e.mean(axis=2)


def assert_matches(r, want: np.ndarray, what: str) -> None:
    """Per-pixel and 8 x 8-block z-tests of a render against an exact image (Sidak, family-wise 1e-3 each)."""
    m, v = r.mean.astype(np.float64), r.variance.astype(np.float64)
    assert np.all(v > 0), what
    z = (m - want) / np.sqrt(v)
    assert 2 * stats.norm.sf(np.abs(z).max()) > 1 - (1 - 1e-3) ** (1 / z.size), (what, np.abs(z).max())
    h, w = m.shape[:2]
    bm = (m - want).reshape(h // 8, 8, w // 8, 8, 3).mean(axis=(1, 3))
    bv = v.reshape(h // 8, 8, w // 8, 8, 3).sum(axis=(1, 3)) / 64**2
    zb = bm / np.sqrt(bv)
    assert 2 * stats.norm.sf(np.abs(zb).max()) > 1 - (1 - 1e-3) ** (1 / zb.size), (what, np.abs(zb).max())


@pytest.fixture(scope="module")
def plane():
    cs = compile_scene(parse_scene(plane_scene()))
    return cs, closed_form_image(cs, [POINT, SPOT, DIRECTIONAL])


@pytest.mark.parametrize("integrator", ["nee", "mis"])
def test_plane_closed_form_nee_mis(plane, integrator: str) -> None:
    cs, want = plane
    r = render(cs, spp=256, integrator=integrator, seed=5, sampler="independent")  # per-pixel normal z-tests
    assert r.nonfinite == 0
    assert_matches(r, want, integrator)


def test_plane_closed_form_lt(plane) -> None:
    cs, want = plane
    r = render(cs, spp=1024, integrator="lt", seed=6, spp_per_block=16)
    assert r.nonfinite == 0
    assert_matches(r, want, "lt")


def test_plane_closed_form_bdpt(plane) -> None:
    """bdpt: y_0 at the point and spot lights, at infinity for the directional one; no (0, t) or (1, 1)."""
    cs, want = plane
    r = render(cs, spp=256, integrator="bdpt", seed=7, spp_per_block=4)
    assert r.nonfinite == 0
    assert_matches(r, want, "bdpt")


def test_path_cannot_see_delta_lights(plane) -> None:
    cs, _ = plane
    r = render(cs, spp=8, integrator="path", seed=1)
    assert np.all(r.mean == 0)


def test_mis_equals_nee_with_only_delta_lights(plane) -> None:
    """MIS weight 1: with no area light the two estimators are the same numbers."""
    cs, _ = plane
    a = render(cs, spp=16, integrator="nee", seed=9)
    b = render(cs, spp=16, integrator="mis", seed=9)
    np.testing.assert_array_equal(a.mean, b.mean)


def test_nee_mis_lt_agree_on_cornell_with_point_and_spot() -> None:
    sc = load_scene(SCENES / "cornell.json")
    sc.camera.width = sc.camera.height = 32
    data = {"lights": [{"type": "point", "position": [0.3, 0.5, 0.2], "intensity": 0.8},
                       {"type": "spot", "position": [-0.5, 0.8, 0.5], "target": [-0.2, -1.0, -0.3],
                        "intensity": 3.0, "cutoff_angle": 40, "beam_width": 25}]}
    sc.lights = parse_scene({**plane_scene(), **data}).lights
    cs = compile_scene(sc)
    a = render(cs, spp=256, integrator="mis", seed=1, max_depth=4)
    b = render(cs, spp=256, integrator="nee", seed=2, max_depth=4)
    c = render(cs, spp=512, integrator="lt", seed=3, max_depth=4, spp_per_block=8)
    d = render(cs, spp=128, integrator="bdpt", seed=4, max_depth=4, spp_per_block=4)
    for x, y, what in ((a, b, "mis-nee"), (a, c, "mis-lt"), (a, d, "mis-bdpt")):
        z = (x.mean - y.mean).astype(np.float64).reshape(4, 8, 4, 8, 3).mean(axis=(1, 3))
        v = (x.variance + y.variance).astype(np.float64).reshape(4, 8, 4, 8, 3).sum(axis=(1, 3)) / 64**2
        zz = np.abs(z / np.sqrt(v))
        assert 2 * stats.norm.sf(zz.max()) > 1 - (1 - 1e-3) ** (1 / zz.size), (what, zz.max())


# ---- emitter rays -------------------------------------------------------------

def _ray_scene(light: dict) -> dict:
    s = plane_scene(8, [light])
    s["integrator"] = {"type": "lt"}
    return s


def test_point_light_rays() -> None:
    k = AdjointKernels(_ray_scene(POINT))
    r = k.rays()
    assert np.all(r["valid"]) and not np.any(r["env"])
    np.testing.assert_allclose(r["pos"], np.tile(POINT["position"], (len(r["pos"]), 1)), atol=1e-6)
    d = r["d"]
    n_cos, n_phi = 10, 12
    i = np.clip(np.floor((d[:, 2] + 1) / 2 * n_cos), 0, n_cos - 1).astype(int)
    j = np.clip(np.floor((np.arctan2(d[:, 1], d[:, 0]) + np.pi) / (2 * np.pi) * n_phi), 0, n_phi - 1).astype(int)
    FAMILY.check("point directions", np.bincount(i * n_phi + j, minlength=n_cos * n_phi),
                 np.full(n_cos * n_phi, len(d) / (n_cos * n_phi)))
    np.testing.assert_allclose(r["pdf_solid_angle"], 1 / (4 * math.pi), rtol=1e-6)
    np.testing.assert_allclose(r["pdf_area"], 1.0)  # the only light: chosen with probability 1
    np.testing.assert_allclose(r["radiance"], np.tile(POINT["intensity"], (len(d), 1)), rtol=1e-6)
    np.testing.assert_allclose(r["cos"], 1.0)


def test_spot_light_rays() -> None:
    k = AdjointKernels(_ray_scene(SPOT))
    r = k.rays()
    axis = np.asarray(SPOT["target"], float) - SPOT["position"]
    axis /= np.linalg.norm(axis)
    c = r["d"] @ axis
    cmax = math.cos(math.radians(SPOT["cutoff_angle"]))
    assert np.all(c >= cmax - 1e-5)
    # uniform in the cone: cos uniform on [cos cutoff, 1]
    edges = np.linspace(cmax, 1, 11)
    FAMILY.check("spot directions", np.histogram(np.clip(c, cmax, 1), edges)[0], np.full(10, len(c) / 10))
    np.testing.assert_allclose(r["pdf_solid_angle"], 1 / (2 * math.pi * (1 - cmax)), rtol=1e-5)
    f = spot_falloff(c, SPOT["cutoff_angle"], SPOT["beam_width"])
    ok = r["valid"]
    np.testing.assert_allclose(r["radiance"][ok], np.outer(f, SPOT["intensity"])[ok], rtol=2e-4, atol=2e-5)
    assert np.all(f[~ok] < 1e-3)  # only rays at the very edge of the cone carry no light


def test_directional_light_rays() -> None:
    k = AdjointKernels(_ray_scene(DIRECTIONAL))
    r = k.rays()
    d = np.asarray(DIRECTIONAL["direction"], float)
    d /= np.linalg.norm(d)
    np.testing.assert_allclose(r["d"], np.tile(d, (len(r["d"]), 1)), atol=1e-6)
    centre, radius = bounding_sphere(k.cs.bounds)
    rel = r["pos"] - centre
    along = rel @ d
    np.testing.assert_allclose(along, -radius * 1.001, rtol=1e-4)
    rho2 = (np.sum(rel * rel, axis=1) - along**2) / radius**2
    edges = np.linspace(0, 1, 11)
    FAMILY.check("directional disk", np.histogram(rho2, edges)[0], np.full(10, len(rho2) / 10))
    np.testing.assert_allclose(r["pdf_area"], 1 / (math.pi * radius**2), rtol=1e-5)
    np.testing.assert_allclose(r["pdf_solid_angle"], 1.0)


def test_choice_follows_power() -> None:
    cs = compile_scene(parse_scene(plane_scene()))
    _, radius = bounding_sphere(cs.bounds)
    lum = [LUMINANCE @ POINT["intensity"], LUMINANCE @ SPOT["intensity"], LUMINANCE @ DIRECTIONAL["irradiance"]]
    power = np.array([4 * math.pi * lum[0], 2 * math.pi * (1 - math.cos(math.radians(35))) * lum[1],
                      math.pi * radius**2 * lum[2]])
    np.testing.assert_allclose(cs.light_pmf, power / power.sum(), rtol=1e-5)
    assert cs.light_pmf.sum() == pytest.approx(1.0, abs=1e-6)
    t = scene_tables(cs)
    assert tuple(t["light_scalars"]) == (3, 2)
    assert t["light_rec"].shape == (12, 4)


# ---- scene files ----------------------------------------------------------------

@pytest.mark.parametrize("light, message", [
    ({"type": "point", "position": [0, 0, 1]}, "lights[0].intensity: missing required key"),
    ({"type": "bulb", "position": [0, 0, 1]}, "lights[0].type: unknown value 'bulb'"),
    ({"type": "spot", "position": [0, 0, 1], "intensity": 1}, "exactly one of 'direction' and 'target'"),
    ({"type": "spot", "position": [0, 0, 1], "intensity": 1, "direction": [0, 0, -1], "cutoff_angle": 10,
      "beam_width": 20}, "lights[0].beam_width: must be <= 10"),
    ({"type": "directional", "direction": [0, 0, 0], "irradiance": 1}, "zero vector"),
    ({"type": "point", "position": [0, 0, 1], "intensity": -1}, "RGB values must be >= 0"),
])
def test_bad_lights_are_rejected(light: dict, message: str) -> None:
    with pytest.raises(InputError, match=message.replace("[", r"\[").replace("]", r"\]")):
        parse_scene(plane_scene(8, [light]))


def test_light_bvh_refuses_directional_lights() -> None:
    s = plane_scene(8)
    s["integrator"]["light_sampler"] = "bvh"
    with pytest.raises(InputError, match=r"directional light \(lights\[2\]\); the light BVH holds lights at finite"):
        compile_scene(parse_scene(s))


@pytest.mark.parametrize("integrator", ["nee", "mis"])
def test_light_bvh_with_point_and_spot_lights(integrator: str) -> None:
    """Point and spot lights are leaves of the light BVH (a point box; a spot's cone is its cutoff)."""
    lights = [POINT, SPOT, dict(POINT, position=[-1.0, 1.0, 0.5], intensity=0.3)]
    s = plane_scene(16, lights)
    s["integrator"]["light_sampler"] = "bvh"
    cs = compile_scene(parse_scene(s))
    r = render(cs, spp=256, integrator=integrator, seed=8, sampler="independent")  # per-pixel normal z-tests
    assert r.nonfinite == 0
    assert_matches(r, closed_form_image(cs, lights), f"bvh {integrator}")


XML = """<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="60"/>
    <transform name="to_world"><lookat origin="0, 0, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
  </sensor>
  <shape type="rectangle"><transform name="to_world"><scale x="2" y="2" z="1"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>
  <emitter type="point"><point name="position" x="0.3" y="-0.2" z="1"/>
    <rgb name="intensity" value="1, 0.8, 0.6"/></emitter>
  <emitter type="spot"><rgb name="intensity" value="3, 4, 5"/>
    <float name="cutoff_angle" value="35"/><float name="beam_width" value="15"/>
    <transform name="to_world"><lookat origin="-0.4, 0.3, 1.5" target="-0.6, 0.1, 0" up="0, 1, 0"/></transform>
  </emitter>
  <emitter type="directional"><vector name="direction" x="0.3" y="-0.2" z="-1"/>
    <rgb name="irradiance" value="0.2, 0.3, 0.1"/></emitter>
</scene>
"""


def test_mitsuba_xml_twin_has_the_same_light_records(tmp_path: Path, plane) -> None:
    cs, _ = plane
    p = tmp_path / "lights.xml"
    p.write_text(XML)
    twin = compile_scene(load_scene(p))
    a, b = scene_tables(cs)["light_rec"], scene_tables(twin)["light_rec"]
    np.testing.assert_allclose(b, a, rtol=1e-6, atol=1e-6)


def test_mitsuba_xml_spot_beam_beyond_cutoff_is_an_error(tmp_path: Path) -> None:
    p = tmp_path / "bad.xml"
    p.write_text(XML.replace('value="15"', 'value="50"'))
    with pytest.raises(InputError, match="beam_width must lie in"):
        load_scene(p)
