"""A scene of the newer materials rendered by every integrator agrees (8x8-block z-tests): roughdielectric,
thindielectric, roughplastic (its table in the materials buffer) and an anisotropic gold roughconductor
(extended records).

path (BSDF sampling only) is the reference the others must match: mis and
nee light-sample through rough refraction (the shadow ray leaves from the far
side, kernels/render/integrator.cl), lt connects to the camera with the
importance-mode BSDF (no 1/eta^2), bdpt connects in both modes
(kernels/render/bdpt.cl, vertex_eval).  A wrong mode or shadow-ray origin
shifts the glass's brightness by eta^2 or blacks out its transmitted light.
lt renders the scene without the thin pane: light tracing cannot see
through a delta surface (kernels/render/lt.cl); the others see it.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from mcocl.render.api import render
from mcocl.render.compiled import compile_scene
from mcocl.render.scene import parse_scene


def _scene(integrator: str, pane: bool = True) -> dict:
    scene = {
        "camera": {"origin": [0, 0.3, 3.4], "target": [0, -0.1, 0], "fov": 40, "width": 16, "height": 16},
        "integrator": {"type": integrator, "max_depth": 6, "rr_depth": 4},
        "materials": {
            # a texture, so that lt's, bdpt's and mis's builds (textures and rough refraction) are those of
            # tests/test_render_dielectric_tints.py: a build costs 10 to 30 s on a cold cache
            "white": {"type": "diffuse", "reflectance": {"type": "checkerboard", "color0": 0.7, "color1": 0.6}},
            "frost": {"type": "roughdielectric", "alpha": 0.3, "int_ior": 1.5},
            "frost_b": {"type": "roughdielectric", "alpha": 0.2, "int_ior": 1.33, "distribution": "beckmann"},
            "pane": {"type": "thindielectric", "int_ior": 1.5},
            "coat": {"type": "roughplastic", "alpha": 0.2, "diffuse_reflectance": [0.2, 0.5, 0.3]},
            "gold": {"type": "roughconductor", "material": "Au", "alpha_u": 0.05, "alpha_v": 0.4, "twosided": True},
        },
        "shapes": [
            {"type": "rectangle", "material": "white",
             "transform": [{"scale": 2}, {"rotate": {"axis": [1, 0, 0], "angle": -90}}, {"translate": [0, -1, 0]}]},
            {"type": "rectangle", "material": "gold", "transform": [{"scale": 2}, {"translate": [0, 0, -1.2]}]},
            {"type": "sphere", "material": "coat", "center": [-0.6, 0.5, -0.6], "radius": 0.3},
            {"type": "sphere", "material": "frost", "center": [-0.45, -0.5, 0], "radius": 0.45},
            {"type": "cube", "material": "frost_b",
             "transform": [{"scale": 0.3}, {"rotate": {"axis": [0, 1, 0], "angle": 30}}, {"translate": [0.5, -0.6, 0.1]}]},
            {"type": "rectangle", "material": "pane",
             "transform": [{"scale": 0.4}, {"rotate": {"axis": [0, 1, 0], "angle": 20}}, {"translate": [0.4, 0.2, 0.4]}]},
            {"type": "rectangle", "material": "white",
             "transform": [{"scale": 0.5}, {"rotate": {"axis": [1, 0, 0], "angle": 90}}, {"translate": [0, 1.3, 0]}],
             "emitter": {"type": "area", "radiance": [10, 10, 10]}},
        ],
    }
    if not pane:
        scene["shapes"] = [s for s in scene["shapes"] if s["material"] != "pane"]
    return scene


def _blocks(x: np.ndarray, b: int = 8) -> np.ndarray:
    h, w, c = x.shape
    return x.reshape(h // b, b, w // b, b, c).sum(axis=(1, 3))


@pytest.fixture(scope="module")
def references() -> dict:
    return {pane: render(compile_scene(parse_scene(_scene("path", pane))), spp=4096, seed=70) for pane in (True, False)}


@pytest.mark.parametrize("integrator,spp", [("mis", 1024), ("nee", 1024), ("lt", 512), ("bdpt", 256)])
def test_integrators_agree_with_path(references, integrator: str, spp: int) -> None:
    pane = integrator != "lt"
    reference = references[pane]
    cs = compile_scene(parse_scene(_scene(integrator, pane)))
    kw = {"spp_per_block": 8} if integrator in ("lt", "bdpt") else {}
    r = render(cs, spp=spp, seed=71, **kw)
    assert r.nonfinite == 0 and reference.nonfinite == 0
    m1, m2 = _blocks(reference.mean.astype(np.float64)), _blocks(r.mean.astype(np.float64))
    v = _blocks(reference.variance.astype(np.float64)) + _blocks(r.variance.astype(np.float64))
    z = np.abs(m1 - m2) / np.sqrt(v)
    level = 1 - (1 - 1e-3) ** (1 / (z.size * 4))  # Sidak over the blocks of the four comparisons
    assert 2 * stats.norm.sf(z.max()) > level, f"{integrator}: max z {z.max():.2f} over {z.size} blocks"
    assert np.all(m1 > 0)
