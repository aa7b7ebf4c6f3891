"""roughdielectric and thindielectric (kernels/render/bsdf_roughdielectric.cl, bsdf_thindielectric.cl).

roughdielectric (GGX and Beckmann, from outside and from inside):
- chi-square of the sampled directions over the whole sphere against the pdf
  bsdf_eval reports (failed samples form one more cell);
- the weight and pdf of every sample equal f cos / pdf and pdf from bsdf_eval;
- bsdf_eval agrees with a NumPy twin written from Walter et al. 2007 (eqs. 20, 21);
- radiance-mode reciprocity f(i, o) / n_i^2 = f(o, i) / n_o^2 (Veach's thesis eq. 5.12);
- white furnace: the albedo without the radiance scaling (importance weight,
  weight * eta^2) is at most 1 + 5 standard errors, close to 1 for small
  alpha, and what it loses at larger alpha (single scattering) is reported.
thindielectric: lobe choice against R' = R + T^2 R / (1 - R^2) (chi-square),
the directions (mirror, straight through) and energy exactly 1.
"""

from __future__ import annotations

import numpy as np
import pytest
from chi2 import Chi2Family
from direction_bins import converged_counts, directions_to_bins
from test_render_bsdf import N, evaluate, sample
from test_render_bsdf_plastic import _fresnel

from mcocl.bsdf_registry import FLAG_BITS
from mcocl.layouts import MaterialKind
from mcocl.render.compiled import compile_scene
from mcocl.render.scene import parse_scene

ROUGH = int(MaterialKind.ROUGHDIELECTRIC)
THIN = int(MaterialKind.THINDIELECTRIC)
BECKMANN = float(FLAG_BITS["beckmann"])


def _mat(alpha: float, eta: float, beckmann: bool = False, kind: int = ROUGH) -> np.ndarray:
    return np.array([kind, 1.0, 1.0, 1.0, alpha, eta, 1.0, BECKMANN if beckmann else 0.0], np.float32)


def _unit(theta_deg: float, phi_deg: float = 30.0) -> np.ndarray:
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])


def _twin(alpha: float, eta: float, beckmann: bool, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """f cos theta_o in radiance mode, from Walter et al. 2007 eqs. 13, 16, 20, 21, 23 and 33/34 or 25/27."""
    ci, co = wi[2], wo[:, 2]
    refl = ci * co > 0
    eta_p = eta if ci > 0 else 1 / eta
    k = np.where(refl, 1.0, eta_p)
    h = wi[None, :] + wo * k[:, None]
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    h *= np.sign(h[:, 2:3])
    c = h[:, 2]
    t2 = (1 - c**2) / c**2
    if beckmann:
        d = np.exp(-t2 / alpha**2) / (np.pi * alpha**2 * c**4)
    else:
        d = 1 / (np.pi * alpha**2 * c**4 * (1 + t2 / alpha**2) ** 2)

    def g1(v: np.ndarray, vh: np.ndarray) -> np.ndarray:
        tan2 = np.maximum(1 - v[..., 2] ** 2, 0.0) / v[..., 2] ** 2
        if beckmann:
            with np.errstate(divide="ignore"):
                b = 1 / (alpha * np.sqrt(tan2))
            g = np.where(b < 1.6, (3.535 * b + 2.181 * b**2) / (1 + 2.276 * b + 2.577 * b**2), 1.0)
        else:
            g = 2 / (1 + np.sqrt(1 + alpha**2 * tan2))
        return np.where(vh * v[..., 2] > 0, g, 0.0)

    dih, doh = h @ wi, np.sum(wo * h, axis=1)
    g = g1(np.broadcast_to(wi, wo.shape), dih) * g1(wo, doh)
    # Fresnel at the microfacet, seen from the side wi is on
    f = np.where(dih > 0, _fresnel(np.abs(dih), eta), _fresnel(np.abs(dih), 1 / eta))
    fr = f * d * g / (4 * abs(ci))
    ft = (1 - f) * d * g * np.abs(dih * doh) / (abs(ci) * (dih + eta_p * doh) ** 2)  # eta_p^2 times 1 / eta_p^2
    return np.where(refl, fr, ft)


CASES = [(0.3, 1.5, False, 30.0), (0.3, 1.5, False, 150.0), (0.1, 1.33, False, 80.0), (0.6, 1.5, False, 120.0),
         (0.3, 1.5, True, 30.0), (0.3, 1.5, True, 150.0), (0.1, 1.33, True, 80.0), (0.6, 1.5, True, 120.0),
         (0.3, 0.7, False, 45.0)]
IDS = [f"{'beckmann' if b else 'ggx'}-a{a}-eta{e}-{t:g}deg" for a, e, b, t in CASES]
FAMILY = Chi2Family("roughdielectric sampling", len(CASES) + 3)


@pytest.mark.parametrize("alpha,eta,beck,theta", CASES, ids=IDS)
def test_chi2_weight_and_twin(alpha: float, eta: float, beck: bool, theta: float) -> None:
    mat = _mat(alpha, eta, beck)
    wi = _unit(theta)
    s = sample(mat, wi)
    valid = s["pdf"] > 0
    n_cos, n_phi = (60 if alpha < 0.15 else 30), 40
    idx = directions_to_bins(s["wo"][valid], n_cos, n_phi, (-1.0, 1.0))
    observed, expected = converged_counts(lambda dirs: evaluate(mat, wi, dirs)[1], idx, N, n_cos, n_phi,
                                          (-1.0, 1.0))
    FAMILY.check(IDS[CASES.index((alpha, eta, beck, theta))], observed, expected)
    # weight = f cos / pdf and pdf from eval, at the samples
    f, pdf = evaluate(mat, wi, s["wo"][valid][:4096])
    np.testing.assert_allclose(pdf, s["pdf"][valid][:4096], rtol=2e-3)
    np.testing.assert_allclose(f / pdf[:, None], s["weight"][valid][:4096], rtol=2e-3)
    assert np.all(s["weight"][~valid] == 0) and np.all(s["delta"] == 0)
    # the path's eta: eta_t / eta_i on refraction, 1 on reflection
    refr = valid & (s["wo"][:, 2] * wi[2] < 0)
    np.testing.assert_allclose(s["eta"][refr], eta if wi[2] > 0 else 1 / eta, rtol=1e-6)
    np.testing.assert_array_equal(s["eta"][valid & ~refr], 1.0)
    # the twin at random directions of both hemispheres
    rng = np.random.default_rng(4)
    v = rng.normal(size=(3000, 3))
    wo = v / np.linalg.norm(v, axis=1, keepdims=True)
    f, _ = evaluate(mat, wi, wo)
    # float32 half vectors of refraction near the critical angle: a few 1e-3 relative
    np.testing.assert_allclose(f[:, 0], _twin(alpha, eta, beck, wi, wo), rtol=5e-3, atol=1e-6)


@pytest.mark.parametrize("beck", [False, True])
def test_radiance_reciprocity(beck: bool) -> None:
    """f(i, o) / n_i^2 = f(o, i) / n_o^2 with f = (f cos o) / |cos o| and n the index on each direction's side."""
    eta, mat = 1.5, _mat(0.4, 1.5, beck)
    rng = np.random.default_rng(5)
    v = rng.normal(size=(400, 3))
    dirs = v / np.linalg.norm(v, axis=1, keepdims=True)
    for wi in (_unit(35.0), _unit(140.0)):
        fo, _ = evaluate(mat, wi, dirs)
        back = np.array([evaluate(mat, d, wi[None, :])[0][0, 0] for d in dirs[:60]])
        n = lambda w: np.where(w[..., 2] > 0, 1.0, eta)  # noqa: E731
        lhs = fo[:60, 0] / np.abs(dirs[:60, 2]) / n(wi) ** 2
        rhs = back / abs(wi[2]) / n(dirs[:60]) ** 2
        np.testing.assert_allclose(lhs, rhs, rtol=1e-3, atol=1e-6)
        assert np.any(lhs > 0)


@pytest.mark.parametrize("beck", [False, True])
def test_white_furnace(beck: bool) -> None:
    """The importance-mode albedo (weight * eta^2: refraction's radiance scaling undone) never exceeds 1.

    Single scattering loses the light a second microfacet would have sent on:
    with alpha 0.05 under 60 degrees the loss is below 1.5 %; at alpha 1 and
    grazing incidence it reaches tens of percent (printed with -s)."""
    for alpha in (0.05, 0.3, 1.0):
        for theta in (0.0, 30.0, 60.0, 85.0, 120.0, 175.0):
            s = sample(_mat(alpha, 1.5, beck), _unit(theta))
            w = (s["weight"][:, 0] * s["eta"] ** 2).astype(np.float64)
            mean, se = w.mean(), w.std() / np.sqrt(len(w))
            print(f"{'beckmann' if beck else 'ggx'} alpha {alpha} theta {theta}: albedo {mean:.4f} +- {se:.4f}")
            assert mean <= 1 + 5 * se + 1e-6, (alpha, theta, mean, se)  # 1e-6: float32 rounding of a weight of 1
            if alpha <= 0.05 and (theta <= 60.0 or theta >= 150.0):
                assert mean > 0.985, (alpha, theta, mean)


@pytest.mark.parametrize("theta,eta", [(0.0, 1.5), (60.0, 1.5), (130.0, 1.33)])
def test_thindielectric(theta: float, eta: float) -> None:
    mat = _mat(0.0, eta, kind=THIN)
    wi = _unit(theta)
    s = sample(mat, wi)
    r = float(_fresnel(abs(wi[2]), eta))
    r2 = r + (1 - r) ** 2 * r / (1 - r * r)
    refl = s["wo"][:, 2] * wi[2] > 0
    FAMILY.check(f"thindielectric lobe choice, {theta:g} deg", [refl.sum(), N - refl.sum()], [N * r2, N * (1 - r2)])
    np.testing.assert_allclose(s["wo"][refl], np.tile([-wi[0], -wi[1], wi[2]], (refl.sum(), 1)), atol=1e-6)
    np.testing.assert_allclose(s["wo"][~refl], np.tile(-wi, ((~refl).sum(), 1)), atol=1e-6)
    np.testing.assert_allclose(s["pdf"][refl], r2, rtol=1e-4)
    np.testing.assert_allclose(s["pdf"][~refl], 1 - r2, rtol=1e-4)
    assert np.all(s["weight"] == 1.0) and np.all(s["delta"] == 1) and np.all(s["eta"] == 1.0)  # energy exactly 1
    f, pdf = evaluate(mat, wi, s["wo"][:64])
    assert np.all(f == 0) and np.all(pdf == 0)  # a delta BSDF: nothing to evaluate


def test_scene_keys() -> None:
    def record(kind: str, **keys):
        scene = {"camera": {"origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 4, "height": 4},
                 "materials": {"m": {"type": kind, **keys}},
                 "shapes": [{"type": "rectangle", "material": "m"}]}
        return compile_scene(parse_scene(scene, "b.json")).materials[0]

    r = record("roughdielectric", alpha=0.2, distribution="beckmann", int_ior=1.33)
    assert r[0] == ROUGH and r[4] == np.float32(0.2) and r[5] == np.float32(1.33) and r[7] == BECKMANN
    assert record("roughdielectric")[7] == 0
    assert record("thindielectric")[0] == THIN
    for kind in ("roughdielectric", "thindielectric"):
        with pytest.raises(Exception, match="invisible"):
            record(kind, int_ior=1.2, ext_ior=1.2)
