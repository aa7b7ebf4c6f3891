"""roughconductor with distribution "beckmann" (kernels/render/bsdf_roughconductor.cl).

- chi-square of the sampled directions against the pdf bsdf_eval reports (the
  samples reflected below the horizon form one more cell);
- the weight of every sample equals f cos / pdf from bsdf_eval;
- bsdf_eval agrees with a NumPy twin written from Walter et al. 2007;
- white furnace: the albedo is at most 1 + 5 standard errors at every incidence;
- the scene file's key selects it, Mitsuba's default distribution imports as it.
"""

from __future__ import annotations

import numpy as np
import pytest
from chi2 import Chi2Family
from direction_bins import converged_counts, directions_to_bins
from test_render_bsdf import N, evaluate, sample

from mcocl.bsdf_registry import FLAG_BITS
from mcocl.layouts import MaterialKind
from mcocl.render.compiled import compile_scene
from mcocl.render.scene import parse_scene

ROUGH = int(MaterialKind.ROUGHCONDUCTOR)


def _mat(alpha: float, color=(0.9, 0.6, 0.3)) -> np.ndarray:
    return np.array([ROUGH, *color, alpha, 1.0, 1.0, FLAG_BITS["beckmann"]], np.float32)


def _unit(theta_deg: float, phi_deg: float = 30.0) -> np.ndarray:
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])


def _beckmann_twin(alpha: float, wi: np.ndarray, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """f cos / F and the pdf of sampling D(m) cos theta_m, from Walter et al. 2007 eqs. 25, 27, 14."""
    h = wi + wo
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    c = h[:, 2]
    d = np.exp(-(1 - c**2) / c**2 / alpha**2) / (np.pi * alpha**2 * c**4)

    def g1(v: np.ndarray) -> np.ndarray:
        tan = np.sqrt(np.maximum(1 - v[..., 2] ** 2, 0.0)) / np.abs(v[..., 2])
        with np.errstate(divide="ignore", invalid="ignore"):
            b = 1 / (alpha * tan)
            return np.where(b < 1.6, (3.535 * b + 2.181 * b**2) / (1 + 2.276 * b + 2.577 * b**2), 1.0)

    ok = (wo[:, 2] > 0) & (wi[2] > 0)
    fcos = d * g1(wi) * g1(wo) / (4 * wi[2])
    pdf = d * c / (4 * np.abs(np.sum(wo * h, axis=1)))
    return np.where(ok, fcos, 0.0), np.where(ok, pdf, 0.0)


CASES = [(0.5, 0.0), (0.5, 70.0), (0.2, 40.0), (0.1, 80.0), (0.9, 60.0)]
FAMILY = Chi2Family("Beckmann sampling", len(CASES))


@pytest.mark.parametrize("alpha,theta", CASES)
def test_chi2_weight_and_twin(alpha: float, theta: float) -> None:
    mat = _mat(alpha)
    wi = _unit(theta)
    s = sample(mat, wi)
    valid = s["pdf"] > 0
    n_cos, n_phi = (40 if alpha < 0.15 else 20), 40
    idx = directions_to_bins(s["wo"][valid], n_cos, n_phi, (0.0, 1.0))
    assert np.all(idx >= 0), "a sample went below the surface"
    observed, expected = converged_counts(lambda dirs: evaluate(mat, wi, dirs)[1], idx, N, n_cos, n_phi,
                                          (0.0, 1.0))
    FAMILY.check(f"beckmann a={alpha:g}, {theta:g} deg", observed, expected)
    # weight = f cos / pdf, and the twin
    f, pdf = evaluate(mat, wi, s["wo"][valid][:4096])
    np.testing.assert_allclose(pdf, s["pdf"][valid][:4096], rtol=2e-3)
    np.testing.assert_allclose(f / pdf[:, None], s["weight"][valid][:4096], rtol=2e-3)
    assert np.all(s["weight"][~valid] == 0) and np.all(s["delta"] == 0)
    rng = np.random.default_rng(2)
    v = rng.normal(size=(2000, 3))
    wo = v / np.linalg.norm(v, axis=1, keepdims=True)
    f, pdf = evaluate(mat, wi, wo)
    fc, pd = _beckmann_twin(alpha, wi, wo)
    np.testing.assert_allclose(pdf, pd, rtol=2e-4, atol=1e-6)
    np.testing.assert_allclose(f, fc[:, None] * np.array([0.9, 0.6, 0.3]), rtol=2e-4, atol=1e-6)


@pytest.mark.parametrize("alpha", [0.05, 0.3, 1.0])
def test_white_furnace(alpha: float) -> None:
    for theta in (0.0, 30.0, 60.0, 80.0, 89.0):
        w = sample(_mat(alpha, color=(1.0, 1.0, 1.0)), _unit(theta))["weight"][:, 0].astype(np.float64)
        mean, se = w.mean(), w.std() / np.sqrt(len(w))
        assert mean <= 1 + 5 * se, (alpha, theta, mean, se)
        if alpha <= 0.05 and theta <= 60.0:  # a nearly smooth surface loses almost nothing to masking
            assert mean > 0.98, (alpha, theta, mean)


def test_scene_key_selects_the_distribution() -> None:
    def record(**keys):
        scene = {"camera": {"origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 4, "height": 4},
                 "materials": {"m": {"type": "roughconductor", **keys}},
                 "shapes": [{"type": "rectangle", "material": "m"}]}
        return compile_scene(parse_scene(scene, "b.json")).materials[0]

    assert record()[7] == 0 and record(distribution="ggx")[7] == 0
    assert record(distribution="beckmann")[7] == FLAG_BITS["beckmann"]
    assert record(distribution="beckmann", twosided=True)[7] == FLAG_BITS["beckmann"] | FLAG_BITS["twosided"]
    with pytest.raises(Exception, match=r"materials\.m\.distribution: unknown value 'phong'"):
        record(distribution="phong")
