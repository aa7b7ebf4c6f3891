"""The two tints of a dielectric: specular_reflectance and specular_transmittance (Mitsuba 3's names).

- The smooth, thin and rough dielectric kernels tint each lobe by its own
  colour: their sampled weights (per lobe) and evaluations equal values
  measured on Mitsuba 3.9 (scalar_rgb) with distinct tints.
- Textured tints: light tracing and bdpt agree with mis (block z-tests) on a
  scene with a rough glass sphere, a glass cube and a thin pane, each with a
  textured tint; a checkerboard of one colour renders bit for bit as that
  constant; scenes whose two tints are one constant keep the record's old
  flags (no transmittance read), and the Mitsuba importer carries the tints.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from test_render_bsdf import evaluate, sample
from test_render_textures import assert_splatting_agrees_with_mis

import mcocl
from mcocl.bsdf_registry import FLAG_BITS
from mcocl.layouts import MaterialKind
from mcocl.render.scene_file import load_scene

R, T = [0.2, 0.5, 0.9], [0.9, 0.6, 0.3]


def _record(kind: int, alpha: float = 0.0) -> np.ndarray:
    """A material record (mcocl.layouts.MATERIAL_RECORD) with tints R and T, int_ior 1.5, ext_ior 1."""
    return np.array([kind, *R, alpha, 1.5, 1.0, FLAG_BITS["transmittance"], 0.0, 0, 0, 0, 0, 0, 0, 0, *T, 0.0],
                    np.float32)


WI = np.array([np.sin(np.radians(40)) * np.cos(np.radians(30)), np.sin(np.radians(40)) * np.sin(np.radians(30)),
               np.cos(np.radians(40))])
# Mitsuba 3.9 scalar_rgb, BSDF.sample with wi = WI (side +1) or its mirror below (side -1), int_ior 1.5:
# per lobe the weight (both lobes are deltas: one value each) and the lobe's probability.
MITSUBA_DELTA = {
    (MaterialKind.DIELECTRIC, 1): ((R, 0.04573364), ([0.4, 0.26666671, 0.13333336], 0.95426637)),
    (MaterialKind.DIELECTRIC, -1): ((R, 0.24529120), ([2.02499986, 1.35, 0.67500001], 0.75470877)),
    (MaterialKind.THINDIELECTRIC, 1): ((R, 0.08746709), (T, 0.91253293)),
    (MaterialKind.THINDIELECTRIC, -1): ((R, 0.08746709), (T, 0.91253293)),
}
# roughdielectric, GGX alpha 0.3: BSDF.eval and BSDF.pdf at (side, wo before normalising)
MITSUBA_ROUGH = [
    (1, [0.3, -0.2, 0.93], [0.000955218740, 0.002388046822, 0.004298483953], 0.0047921911),
    (1, [-0.4, 0.1, -0.91], [0.090196542442, 0.060131032020, 0.030065516010], 0.2265281230),
    (-1, [0.3, -0.2, 0.93], [0.0, 0.0, 0.0], 0.0),
    (-1, [-0.4, 0.1, -0.91], [0.004376604687, 0.010941511020, 0.019694719464], 0.0219836421),
]


def test_delta_dielectrics_tint_each_lobe_as_mitsuba() -> None:
    for (kind, side), lobes in MITSUBA_DELTA.items():
        wi = WI * np.array([1.0, 1.0, side])
        s = sample(_record(kind), wi, n=4096, seed=3)
        reflected = s["wo"][:, 2] * wi[2] > 0
        assert 0 < reflected.sum() < len(reflected)
        for pick, (weight, prob) in zip((reflected, ~reflected), lobes):
            np.testing.assert_allclose(s["weight"][pick], np.broadcast_to(weight, (pick.sum(), 3)), rtol=2e-6,
                                       err_msg=f"{kind.name} side {side}")
            np.testing.assert_allclose(s["pdf"][pick], prob, rtol=2e-6)


def test_rough_dielectric_tints_each_lobe_as_mitsuba() -> None:
    for side, wo, f, pdf in MITSUBA_ROUGH:
        wo = np.array(wo) / np.linalg.norm(wo)
        ours, our_pdf = evaluate(_record(MaterialKind.ROUGHDIELECTRIC, alpha=0.3), WI * np.array([1, 1, side]),
                                 wo[None, :])
        np.testing.assert_allclose(ours[0], f, rtol=2e-4, atol=1e-9)
        np.testing.assert_allclose(our_pdf[0], pdf, rtol=2e-4, atol=1e-9)


def _checker(c0, c1) -> dict:
    return {"type": "checkerboard", "color0": c0, "color1": c1, "to_uv": [{"scale": [3, 3, 1]}]}


def glass_scene(tmp_path: Path, name: str, sphere_t, cube_t, pane_r, size: int = 32) -> Path:
    """A checkerboard floor, a rough glass sphere on it, and between the floor and the lamp (out of view) a
    glass cube and a thin pane: tints may be textures (the sphere's and cube's transmittance, the pane's
    reflectance, lit from the lamp's side)."""
    data = {"camera": {"origin": [0, -4, 2.5], "target": [0, 0, 0.3], "fov": 40, "width": size, "height": size},
            "integrator": {"type": "mis", "max_depth": 6},
            "materials": {"floor": {"type": "diffuse", "reflectance": _checker([0.8, 0.8, 0.8], 0.3)},
                          "rough": {"type": "roughdielectric", "alpha": 0.3, "specular_reflectance": [0.9, 0.4, 0.2],
                                    "specular_transmittance": sphere_t},
                          "glass": {"type": "dielectric", "specular_transmittance": cube_t},
                          "pane": {"type": "thindielectric", "specular_reflectance": pane_r,
                                   "specular_transmittance": [0.3, 0.9, 0.5]},
                          "lamp": {"type": "diffuse", "reflectance": 0}},
            "shapes": [{"type": "rectangle", "material": "floor", "transform": [{"scale": [2, 2, 1]}]},
                       {"type": "sphere", "center": [0.4, 0.2, 0.5], "radius": 0.5, "material": "rough"},
                       {"type": "cube", "material": "glass",
                        "transform": [{"scale": [0.5, 0.5, 0.1]}, {"translate": [-0.6, 0, 2]}]},
                       {"type": "rectangle", "material": "pane",
                        "transform": [{"scale": [0.6, 0.6, 1]}, {"translate": [0.6, 0, 2.2]}]},
                       {"type": "rectangle", "material": "lamp", "transform": [{"translate": [0, 0, 3]}],
                        "flip_normals": True, "emitter": {"type": "area", "radiance": 4}}]}
    p = tmp_path / name
    p.write_text(json.dumps(data))
    return p


def test_light_tracing_and_bdpt_agree_with_mis_on_textured_glass(tmp_path: Path) -> None:
    p = glass_scene(tmp_path, "g.json", _checker([0.9, 0.2, 0.2], [0.2, 0.9, 0.9]),
                    _checker([0.2, 0.3, 0.9], [0.9, 0.9, 0.2]), _checker(0.9, 0.1))
    assert_splatting_agrees_with_mis(p)


def test_one_colour_checkerboards_render_as_the_constants(tmp_path: Path) -> None:
    a, b, c = [0.9, 0.2, 0.2], [0.2, 0.3, 0.9], [0.6, 0.5, 0.1]
    plain = glass_scene(tmp_path, "p.json", a, b, c, size=16)
    tex = glass_scene(tmp_path, "t.json", _checker(a, a), _checker(b, b), _checker(c, c), size=16)
    for integ in ("mis", "lt"):
        want = mcocl.render(plain, spp=4, seed=5, integrator=integ)
        got = mcocl.render(tex, spp=4, seed=5, integrator=integ)
        assert np.array_equal(want.mean, got.mean) and np.array_equal(want.stderr, got.stderr), integ


def test_flags_and_the_mitsuba_importer(tmp_path: Path) -> None:
    (tmp_path / "s.xml").write_text(
        '<scene version="3.0.0"><sensor type="perspective"/><shape type="sphere"><bsdf type="dielectric">'
        '<rgb name="specular_reflectance" value="0.2, 0.5, 0.9"/>'
        '<texture type="checkerboard" name="specular_transmittance"/></bsdf></shape>'
        '<shape type="sphere"><bsdf type="roughdielectric"><rgb name="specular_transmittance" value="0.5"/></bsdf>'
        '</shape><shape type="sphere"><bsdf type="thindielectric"/></shape></scene>')
    mats = {m.kind: m for m in load_scene(tmp_path / "s.xml").materials}
    smooth, rough, thin = mats["dielectric"], mats["roughdielectric"], mats["thindielectric"]
    np.testing.assert_allclose(smooth.rgb, [0.2, 0.5, 0.9])
    assert "transmittance_rgb" in smooth.textures and smooth.flags & FLAG_BITS["transmittance"]
    np.testing.assert_allclose(rough.transmittance_rgb, 0.5)
    assert rough.flags & FLAG_BITS["transmittance"]
    # equal tints (the defaults): no transmittance bit, the record renders as the one-tint dielectric did
    assert not thin.flags & FLAG_BITS["transmittance"]
