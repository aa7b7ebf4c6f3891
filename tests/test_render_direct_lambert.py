"""Direct light on a diffuse floor against Lambert's polygon formula, an exact and independent reference.

A square light faces down over a grey Lambertian floor; the camera looks straight down at the floor
beside it, so with ``max_depth=2`` every pixel is ``rho/pi E(x)`` averaged over the pixel's footprint
(box filter), where ``E`` is the irradiance from a uniform polygon (Lambert 1760; Arvo 1995, eq. 3):

    E(x) = Le/2 * sum_k angle(u_k, u_k+1) * n . normalize(u_k x u_k+1),   u_k = (v_k - x) / |v_k - x|.

The image mean is that integral over the film square, by Gauss-Legendre quadrature in numpy.

The scene sits 50 units from the world's origin, where offset_origin's eps is 4.6e-3: next-event
estimation that measured the light from the lifted shadow-ray origin rather than from the surface point
estimated the irradiance eps above the floor, 0.3 % too dark here (12 standard errors), and 1e-4 too
bright in the Cornell box, where bdpt's connections (measured from the point) were the darker side
(kernels/render/integrator.cl, p_up).  test_the_reference_can_tell_the_lift proves the bound can see it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mcocl.render.api import render
from mcocl.render.compiled import compile_scene
from mcocl.render.scene import parse_scene

RHO, LE = 0.5, 1.0
HALF = 0.05  # the light's half side
HEIGHT = 0.5  # the light above the floor
SHIFT = 50.0  # the whole scene along x
CAMERA = (0.6, 0.3, 0.0)  # above the floor, beside the light, looking straight down
FOV = 40.0
RAY_EPSILON = 8.940697e-05  # kernels/render/prims.cl


def scene() -> dict:
    """The light, the floor and the camera, ``SHIFT`` units along x (32 x 32 pixels)."""
    cx, cy, cz = CAMERA
    return {
        "camera": {"origin": [cx + SHIFT, cy, cz], "target": [cx + SHIFT, 0, cz], "up": [0, 0, -1],
                   "fov": FOV, "width": 32, "height": 32},
        "materials": {"grey": {"type": "diffuse", "reflectance": [RHO] * 3}},
        "shapes": [
            {"name": "light", "type": "rectangle", "material": "grey",
             "transform": [{"scale": [HALF, HALF, 1]}, {"rotate": {"axis": [1, 0, 0], "angle": 90}},
                           {"translate": [SHIFT, HEIGHT, 0]}],
             "emitter": {"type": "area", "radiance": [LE] * 3}},
            {"name": "floor", "type": "rectangle", "material": "grey",
             "transform": [{"scale": [10, 10, 1]}, {"rotate": {"axis": [1, 0, 0], "angle": -90}},
                           {"translate": [SHIFT, 0, 0]}]},
        ],
    }


def irradiance(x: np.ndarray) -> np.ndarray:
    """Lambert's formula at the points ``x`` (N, 3) of a surface with normal +y (unshifted frame)."""
    h = HALF
    corners = np.array([[-h, HEIGHT, -h], [h, HEIGHT, -h], [h, HEIGHT, h], [-h, HEIGHT, h]])
    u = corners[None] - x[:, None]
    u /= np.linalg.norm(u, axis=-1, keepdims=True)
    total = np.zeros(len(x))
    for k in range(4):
        a, b = u[:, k], u[:, (k + 1) % 4]
        c = np.cross(a, b)
        total += np.arccos(np.clip((a * b).sum(-1), -1.0, 1.0)) * c[:, 1] / np.linalg.norm(c, axis=-1)
    return LE / 2 * np.abs(total)


def image_mean(lift: float = 0.0, nodes: int = 128) -> float:
    """The exact image mean: rho/pi E over the floor square the film sees, the floor raised by ``lift``."""
    half = math.tan(math.radians(FOV) / 2) * CAMERA[1]
    g, w = np.polynomial.legendre.leggauss(nodes)
    xs, zs = np.meshgrid(CAMERA[0] + half * g, CAMERA[2] + half * g)
    pts = np.stack([xs.ravel(), np.full(xs.size, lift), zs.ravel()], -1)
    return float((irradiance(pts) * np.outer(w, w).ravel()).sum() / 4 * RHO / math.pi)


def render_mean(integrator: str, **kw) -> tuple[float, float]:
    """The rendered image's mean (red channel) and its standard error."""
    r = render(compile_scene(parse_scene(scene())), spp=256, integrator=integrator, sampler="independent",
               max_depth=2, seed=11, **kw)
    red = r.mean[..., 0]
    return float(red.mean()), float(math.sqrt(r.variance[..., 0].sum()) / red.size)


def test_the_quadrature_has_converged() -> None:
    assert image_mean(nodes=64) == pytest.approx(image_mean(nodes=128), rel=1e-9)


CASES = [("mis", {}), ("nee", {}), ("bdpt", {}), ("bdpt", {"strategy": (1, 2), "unweighted": True})]


@pytest.mark.parametrize(("integrator", "kw"), CASES, ids=["mis", "nee", "bdpt", "bdpt-1-2"])
def test_direct_light_matches_lamberts_formula(integrator: str, kw: dict) -> None:
    exact = image_mean()
    mean, se = render_mean(integrator, **kw)
    assert se < 4e-4 * exact  # the bound below is tight enough to see the lift (next test)
    assert abs(mean - exact) < 4 * se, (integrator, mean, exact, (mean - exact) / se)


def test_the_reference_can_tell_the_lift() -> None:
    """The floor raised by offset_origin's eps there changes the reference by more than 5 bounds."""
    eps = (1 + SHIFT + CAMERA[0] + 0.2) * RAY_EPSILON
    exact, lifted = image_mean(), image_mean(lift=eps)
    assert abs(lifted / exact - 1) > 5 * 4e-4, (exact, lifted)
