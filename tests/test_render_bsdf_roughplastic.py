"""The roughplastic BSDF (kernels/render/bsdf_roughplastic.cl) and its tables (mcocl/render/roughplastic_tables.py).

- the tables against the device's own roughdielectric: t(mu) is the
  importance-mode transmitted albedo of the coat at incidence mu, R_int the
  cosine-weighted reflected albedo from inside (Monte Carlo, 5 standard errors);
- chi-square of the sampled directions against the pdf bsdf_eval reports;
  the weight of every sample equals f cos / pdf from bsdf_eval;
- bsdf_eval agrees with a NumPy twin of the formulas (Walter et al. 2007 eq. 20
  for the coat, the tabulated diffuse term);
- white furnace: the albedo is at most 1 + 5 standard errors at every
  incidence; with a white base it loses what the coat's single scattering
  loses, as Mitsuba 3's roughplastic does (its albedos, within 0.025);
- the scene key, and Mitsuba's roughplastic imported as it.
"""

from __future__ import annotations

import numpy as np
import pytest
from chi2 import Chi2Family
from direction_bins import converged_counts, directions_to_bins
from test_render_bsdf import N, evaluate, sample
from test_render_bsdf_plastic import _fresnel
from test_render_bsdf_roughdielectric import _twin as _roughdielectric_twin

from mcocl.bsdf_registry import FLAG_BITS
from mcocl.layouts import MaterialKind
from mcocl.render.compiled import compile_scene
from mcocl.render.roughplastic_tables import RES
from mcocl.render.scene import parse_scene

ROUGHDIEL = int(MaterialKind.ROUGHDIELECTRIC)


def _table(**keys) -> np.ndarray:
    """The compiled materials table of one roughplastic (record row 0, its table after it)."""
    scene = {"camera": {"origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 4, "height": 4},
             "materials": {"m": {"type": "roughplastic", **keys}}, "shapes": [{"type": "rectangle", "material": "m"}]}
    return compile_scene(parse_scene(scene, "p.json")).materials


def _unit(theta_deg: float, phi_deg: float = 30.0) -> np.ndarray:
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])


@pytest.mark.parametrize("alpha,eta,beck", [(0.1, 1.49, False), (0.4, 1.49, True), (0.3, 1.8, False)])
def test_tables_match_the_device_roughdielectric(alpha: float, eta: float, beck: bool) -> None:
    mats = _table(alpha=alpha, int_ior=eta, ext_ior=1.0, distribution="beckmann" if beck else "ggx")
    start = int(mats[0, 15])
    assert start == 20  # after the one record (mcocl.layouts.MATERIAL_RECORD: 20 floats)
    t = mats.reshape(-1)[start:start + RES]
    r_int = mats.reshape(-1)[start + RES]
    glass = np.array([ROUGHDIEL, 1, 1, 1, alpha, eta, 1.0, FLAG_BITS["beckmann"] if beck else 0], np.float32)
    for k in (5, 20, 40, 63):
        mu = k / (RES - 1)
        s = sample(glass, np.array([np.sqrt(1 - mu * mu), 0.0, mu]))
        w = np.where(s["wo"][:, 2] < 0, s["weight"][:, 0] * s["eta"] ** 2, 0.0).astype(np.float64)
        assert abs(w.mean() - t[k]) <= 5 * w.std() / np.sqrt(N) + 1e-4, (mu, w.mean(), t[k])
    # R_int: from inside, relative index 1 / eta is the glass seen from below
    # Gauss-Legendre over mu, split where total internal reflection begins (a kink of the integrand)
    x, wq = np.polynomial.legendre.leggauss(10)
    crit = np.sqrt(1 - 1 / eta**2)
    est, var = 0.0, 0.0
    for a, b in ((0.0, crit), (crit, 1.0)):
        for m_, w_ in zip(a + (b - a) * 0.5 * (x + 1), (b - a) * 0.5 * wq):
            s = sample(glass, np.array([np.sqrt(1 - m_ * m_), 0.0, -m_]), n=N // 4)
            refl = np.where(s["wo"][:, 2] < 0, s["weight"][:, 0], 0.0).astype(np.float64)
            est += w_ * 2 * m_ * refl.mean()
            var += (w_ * 2 * m_) ** 2 * refl.var() / len(refl)
    assert abs(est - r_int) <= 5 * np.sqrt(var) + 1e-3, (est, r_int)


def _plastic_twin(mats: np.ndarray, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """f cos of roughplastic from the formulas (the coat's D G F as roughdielectric's reflection)."""
    rec = mats[0]
    color, alpha, eta, beck = rec[1:4].astype(np.float64), float(rec[4]), float(rec[5] / rec[6]), bool(int(rec[7]) & 2)
    flat = mats.reshape(-1).astype(np.float64)
    start = int(rec[15])
    table, r_int = flat[start:start + RES], flat[start + RES]
    grid = np.linspace(0, 1, RES)
    t_i, t_o = np.interp(wi[2], grid, table), np.interp(np.clip(wo[:, 2], 0, 1), grid, table)
    spec = _roughdielectric_twin(alpha, eta, beck, wi, wo)  # its reflection lobe is the coat's
    diff = t_i * t_o * wo[:, 2] / (np.pi * eta**2 * (1 - r_int))
    ok = wo[:, 2] > 0
    return np.where(ok[:, None], spec[:, None] + diff[:, None] * color, 0.0)


CASES = [(0.1, False, 0.0), (0.3, False, 60.0), (0.3, True, 30.0), (0.6, True, 80.0)]
FAMILY = Chi2Family("roughplastic sampling", len(CASES))


@pytest.mark.parametrize("alpha,beck,theta", CASES)
def test_chi2_weight_and_twin(alpha: float, beck: bool, theta: float) -> None:
    mats = _table(alpha=alpha, diffuse_reflectance=[0.6, 0.3, 0.2], distribution="beckmann" if beck else "ggx")
    wi = _unit(theta)
    s = sample(mats, wi)
    valid = s["pdf"] > 0
    n_cos, n_phi = (40 if alpha < 0.15 else 20), 40
    idx = directions_to_bins(s["wo"][valid], n_cos, n_phi, (0.0, 1.0))
    assert np.all(idx >= 0)
    observed, expected = converged_counts(lambda dirs: evaluate(mats, wi, dirs)[1], idx, N, n_cos, n_phi,
                                          (0.0, 1.0))
    FAMILY.check(f"roughplastic a={alpha:g} {'beckmann' if beck else 'ggx'} {theta:g} deg", observed, expected)
    f, pdf = evaluate(mats, wi, s["wo"][valid][:4096])
    np.testing.assert_allclose(pdf, s["pdf"][valid][:4096], rtol=2e-3)
    np.testing.assert_allclose(f / pdf[:, None], s["weight"][valid][:4096], rtol=2e-3)
    assert np.all(s["delta"] == 0) and np.all(s["eta"] == 1)
    rng = np.random.default_rng(9)
    v = rng.normal(size=(2000, 3))
    wo = v / np.linalg.norm(v, axis=1, keepdims=True)
    f, _ = evaluate(mats, wi, wo)
    np.testing.assert_allclose(f, _plastic_twin(mats, wi, wo), rtol=2e-3, atol=1e-6)


# White-base albedos of Mitsuba 3.9.1's roughplastic (scalar_rgb, BSDF.sample, 20,000 samples each, standard error
# about 0.003): (distribution, alpha, theta) -> albedo.  Single scattering in the coat loses much light
# (GGX alpha 1 keeps a third); mcocl's tables are exact integrals of the same model where Mitsuba averages
# R_int over 64 evenly spaced cosines, hence differences up to about 0.02.
MITSUBA_ALBEDO = {("ggx", 0.05, 0.0): 0.9569, ("ggx", 0.05, 60.0): 0.9585, ("ggx", 0.3, 0.0): 0.6948,
                  ("ggx", 0.3, 60.0): 0.6724, ("ggx", 1.0, 0.0): 0.3411, ("ggx", 1.0, 60.0): 0.2624,
                  ("beckmann", 0.05, 0.0): 0.9773, ("beckmann", 0.05, 60.0): 0.9788, ("beckmann", 0.3, 0.0): 0.8752,
                  ("beckmann", 0.3, 60.0): 0.8607, ("beckmann", 1.0, 0.0): 0.5119, ("beckmann", 1.0, 60.0): 0.4892}


@pytest.mark.parametrize("dist", ["ggx", "beckmann"])
def test_white_furnace(dist: str) -> None:
    """Never above 1; what single scattering loses is Mitsuba's loss (printed with -s)."""
    for alpha in (0.05, 0.3, 1.0):
        mats = _table(alpha=alpha, diffuse_reflectance=1.0, distribution=dist)
        for theta in (0.0, 30.0, 60.0, 85.0):
            w = sample(mats, _unit(theta))["weight"][:, 0].astype(np.float64)
            mean, se = w.mean(), w.std() / np.sqrt(len(w))
            print(f"{dist} alpha {alpha} theta {theta}: albedo {mean:.4f} +- {se:.4f}")
            assert mean <= 1 + 5 * se + 1e-6, (alpha, theta, mean, se)
            if (dist, alpha, theta) in MITSUBA_ALBEDO:
                assert abs(mean - MITSUBA_ALBEDO[dist, alpha, theta]) < 0.025, (alpha, theta, mean)


def test_scene_keys_and_tables_per_material() -> None:
    scene = {"camera": {"origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 4, "height": 4},
             "materials": {"a": {"type": "diffuse", "reflectance": 0.5},
                           "b": {"type": "roughplastic", "alpha": 0.2},
                           "c": {"type": "roughplastic", "alpha": 0.5, "distribution": "beckmann", "twosided": True}},
             "shapes": [{"type": "rectangle", "material": k} for k in "abc"]}
    mats = compile_scene(parse_scene(scene, "p.json")).materials
    assert mats.shape == (3 + 2 * 4, 20)
    assert mats[0, 15] == 0 and mats[1, 15] == 3 * 20 and mats[2, 15] == 3 * 20 + 80
    assert int(mats[2, 7]) == FLAG_BITS["beckmann"] | FLAG_BITS["twosided"]
    assert mats[1, 5] == np.float32(1.49) and mats[1, 6] == np.float32(1.000277)  # Mitsuba's defaults
    # t(1) is the coat's normal-incidence transmittance, about 1 - F(1)
    assert abs(mats.reshape(-1)[3 * 20 + RES - 1] - (1 - _fresnel(1.0, 1.49 / 1.000277))) < 0.01
