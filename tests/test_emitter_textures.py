"""Area emitters with a textured radiance (kernels/render/lights.cl, lights_emit.cl, bdpt.cl; render/texture_table.py).

- A checkerboard of one colour renders bit for bit as that constant radiance
  (mis: emitter hits and light samples), with the same light-choice table.
- path, lt and bdpt agree with mis per 8 x 8 block (z-tests) on a scene whose
  emitters are a checkerboard rectangle and a bitmap sphere, seen directly and
  lighting a floor; the image shows the checkerboard's colours, so a texture
  left out anywhere would fail the comparison.
- The light choice's power takes the texture's mean texel; the Mitsuba
  reader maps ``<texture name="radiance">`` inside an area emitter.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from PIL import Image
from test_render_textures import block_z

import mcocl
from mcocl.render.compiled import compile_scene
from mcocl.render.mitsuba import read_mitsuba

CHECKER = {"type": "checkerboard", "color0": [4.0, 0.8, 0.4], "color1": [0.4, 0.8, 4.0], "to_uv": [{"scale": [2, 2, 1]}]}


def emitter_scene(tmp_path: Path, name: str, radiance, sphere_radiance=None) -> Path:
    """A diffuse floor, a wall emitter facing the camera (checkerboard or constant) and, optionally, an
    emitting sphere; 32 x 32, no environment (bdpt takes none)."""
    data = {"camera": {"origin": [0, -4, 2.5], "target": [0, 0, 0.6], "fov": 45, "width": 32, "height": 32},
            "integrator": {"type": "mis", "max_depth": 3},
            "materials": {"floor": {"type": "diffuse", "reflectance": 0.6}, "lamp": {"type": "diffuse", "reflectance": 0}},
            "shapes": [{"type": "rectangle", "material": "floor", "transform": [{"scale": [2, 2, 1]}]},
                       {"type": "rectangle", "material": "lamp", "emitter": {"type": "area", "radiance": radiance},
                        "transform": [{"scale": [1.2, 0.8, 1]}, {"rotate": {"axis": [1, 0, 0], "angle": 90}},
                                      {"translate": [0, 1.2, 1.0]}]}]}
    if sphere_radiance is not None:
        data["shapes"].append({"type": "sphere", "center": [0.9, -0.4, 0.4], "radius": 0.35, "material": "lamp",
                               "emitter": {"type": "area", "radiance": sphere_radiance}})
    p = tmp_path / name
    p.write_text(json.dumps(data))
    return p


def test_constant_texture_is_bit_identical_to_the_constant(tmp_path: Path) -> None:
    c = [2.0, 1.5, 0.5]
    plain = emitter_scene(tmp_path, "plain.json", c)
    tex = emitter_scene(tmp_path, "tex.json", {"type": "checkerboard", "color0": c, "color1": c})
    a, b = compile_scene(plain), compile_scene(tex)
    assert np.array_equal(a.light_cdf, b.light_cdf) and np.array_equal(a.emitter_radiance[:, :3], b.emitter_radiance[:, :3])
    assert b.emitter_radiance[0, 3] == 1.0 and a.emitter_radiance[0, 3] == 0.0 and b.textures is not None
    # sobol (auto takes independent at 4 spp): bit-identity holds for any sample points, and the textured build
    # is then the one test_integrators_agree_on_textured_emitters makes (a mis build costs 7 to 10 s cold)
    ra, rb = mcocl.render(plain, spp=4, seed=3, sampler="sobol"), mcocl.render(tex, spp=4, seed=3, sampler="sobol")
    assert ra.mean.max() > 0.3
    assert np.array_equal(ra.mean, rb.mean) and np.array_equal(ra.stderr, rb.stderr)


def test_integrators_agree_on_textured_emitters(tmp_path: Path) -> None:
    img = (np.random.default_rng(1).random((4, 6, 3)) * 255).astype(np.uint8)
    Image.fromarray(img).save(tmp_path / "glow.png")
    p = emitter_scene(tmp_path, "glow.json", CHECKER, {"type": "bitmap", "filename": "glow.png"})
    cs = compile_scene(p)
    # power of light choice: the mean texel (the checkerboard's two colours; the sphere's decoded image)
    np.testing.assert_allclose(cs.emitter_radiance[0, :3], [2.2, 0.8, 2.2], rtol=1e-6)
    assert list(cs.emitter_radiance[:, 3]) == [1.0, 2.0]
    ref = mcocl.render(p, spp=256, seed=1, integrator="mis")
    red = ref.mean[..., 0] > 2 * ref.mean[..., 2] + 0.5
    blue = ref.mean[..., 2] > 2 * ref.mean[..., 0] + 0.5
    assert red.sum() >= 8 and blue.sum() >= 8  # the checkerboard is seen, not its mean
    for seed, integ, spp in ((2, "path", 256), (3, "lt", 64), (4, "bdpt", 64)):
        r = mcocl.render(p, spp=spp, seed=seed, integrator=integ, spp_per_block=8)
        z = block_z(r, ref)
        assert np.abs(z).max() < 4.5, (integ, np.round(z[..., 0], 1))


def test_mitsuba_area_emitter_texture(tmp_path: Path) -> None:
    (tmp_path / "s.xml").write_text("""<?xml version="1.0"?>
<scene version="3.0.0">
    <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/>
        <integer name="height" value="8"/></film></sensor>
    <texture type="checkerboard" id="chk"><rgb name="color0" value="3, 1, 1"/></texture>
    <shape type="rectangle"><emitter type="area"><ref id="chk" name="radiance"/></emitter></shape>
    <shape type="disk"><emitter type="area"><texture type="checkerboard" name="radiance"/></emitter></shape>
</scene>
""")
    d = read_mitsuba(tmp_path / "s.xml")
    assert d["shapes"][0]["emitter"]["radiance"] == {"type": "checkerboard", "color0": [3.0, 1.0, 1.0],
                                                      "color1": [0.2, 0.2, 0.2]}
    assert d["shapes"][1]["emitter"]["radiance"]["type"] == "checkerboard"
    cs = compile_scene(tmp_path / "s.xml")
    assert list(cs.emitter_radiance[:, 3]) == [1.0, 2.0]
