"""Conductor Fresnel terms (eta + i k) and anisotropic roughness (kernels/render/fresnel_conductor.cl,
microfacet_aniso.cl, bsdf_conductor.cl, bsdf_roughconductor.cl, bsdf_roughdielectric.cl).

- the conductor Fresnel term against a NumPy twin written with complex
  amplitudes (Hecht, Optics §4.6), through conductor's sample weight and
  roughconductor's eval (the ratio to the same material without eta/k is F(i.h));
- eta 0, k 1 (Mitsuba's material="none") reflects everything at every angle;
- anisotropic GGX and Beckmann, reflection (roughconductor) and refraction
  (roughdielectric): chi-square of the sampled directions against the pdf eval
  reports, weight = f cos / pdf; alpha_u = alpha_v through the anisotropic code
  gives the isotropic values; white furnace at most 1;
- scene keys: named presets, eta/k, both refused, alpha_u/alpha_v (equal ones
  are the isotropic record, bit for bit), one alone refused.
"""

from __future__ import annotations

import numpy as np
import pytest
from chi2 import Chi2Family
from direction_bins import converged_counts, directions_to_bins
from test_render_bsdf import N, evaluate, sample

from mcocl.bsdf_registry import FLAG_BITS
from mcocl.conductor_iors import CONDUCTOR_IORS
from mcocl.layouts import MaterialKind
from mcocl.render.compiled import compile_scene
from mcocl.render.scene import parse_scene

CONDUCTOR, ROUGH, ROUGHDIEL = (int(MaterialKind[k]) for k in ("CONDUCTOR", "ROUGHCONDUCTOR", "ROUGHDIELECTRIC"))
ANISO, CPLX, BECK = (float(FLAG_BITS[k]) for k in ("anisotropic", "complex_ior", "beckmann"))


def _mat(kind: int, color=(0.9, 0.8, 0.7), alpha=0.3, alpha_v=0.0, eta=(0.0, 0.0, 0.0), k=(0.0, 0.0, 0.0),
         int_ior=1.0, flags=0.0) -> np.ndarray:
    return np.array([kind, *color, alpha, int_ior, 1.0, flags, alpha_v, *eta, *k, 0.0], np.float32)


def _unit(theta_deg: float, phi_deg: float = 30.0) -> np.ndarray:
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])


def _fresnel_conductor(c: np.ndarray, eta: float, k: float) -> np.ndarray:
    """Unpolarised reflectance of a conductor eta + i k from its complex s and p amplitudes."""
    n = eta + 1j * k
    c = np.asarray(c, np.float64)
    ct = np.sqrt(1 - (1 - c * c) / n**2 + 0j)
    rs = (c - n * ct) / (c + n * ct)
    rp = (n * c - ct) / (n * c + ct)
    return 0.5 * (np.abs(rs) ** 2 + np.abs(rp) ** 2)


GOLD = CONDUCTOR_IORS["Au"]


@pytest.mark.parametrize("theta", [0.0, 40.0, 75.0, 88.0])
def test_conductor_fresnel_weight(theta: float) -> None:
    eta, k = GOLD
    wi = _unit(theta)
    s = sample(_mat(CONDUCTOR, eta=eta, k=k, flags=CPLX), wi, n=64)
    want = np.array([_fresnel_conductor(wi[2], e, kk) for e, kk in zip(eta, k)]) * [0.9, 0.8, 0.7]
    np.testing.assert_allclose(s["weight"][0], want, rtol=2e-5)
    np.testing.assert_allclose(s["wo"][0], [-wi[0], -wi[1], wi[2]], atol=1e-6)
    # Mitsuba's material="none": eta 0, k 1 reflects everything
    s = sample(_mat(CONDUCTOR, color=(1, 1, 1), eta=(0, 0, 0), k=(1, 1, 1), flags=CPLX), wi, n=64)
    np.testing.assert_allclose(s["weight"][0], 1.0, rtol=1e-6)


@pytest.mark.parametrize("beck", [False, True])
def test_roughconductor_fresnel_is_a_factor(beck: bool) -> None:
    eta, k = CONDUCTOR_IORS["Cu"]
    flags = BECK if beck else 0.0
    wi = _unit(50.0)
    rng = np.random.default_rng(6)
    v = rng.normal(size=(2000, 3))
    wo = v / np.linalg.norm(v, axis=1, keepdims=True)
    plain, p0 = evaluate(_mat(ROUGH, flags=flags), wi, wo)
    metal, p1 = evaluate(_mat(ROUGH, eta=eta, k=k, flags=flags + CPLX), wi, wo)
    np.testing.assert_array_equal(p0, p1)
    h = wi + wo
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    f = np.stack([_fresnel_conductor(h @ wi, e, kk) for e, kk in zip(eta, k)], axis=1)
    ok = plain[:, 0] > 1e-6
    np.testing.assert_allclose(metal[ok], plain[ok] * f[ok], rtol=1e-4)
    # sampling agrees with eval
    s = sample(_mat(ROUGH, eta=eta, k=k, flags=flags + CPLX), wi, n=4096)
    valid = s["pdf"] > 0
    fe, pe = evaluate(_mat(ROUGH, eta=eta, k=k, flags=flags + CPLX), wi, s["wo"][valid])
    np.testing.assert_allclose(pe, s["pdf"][valid], rtol=2e-3)
    np.testing.assert_allclose(fe / pe[:, None], s["weight"][valid], rtol=2e-3)


ANISO_CASES = [(ROUGH, 0.1, 0.4, False, 40.0), (ROUGH, 0.5, 0.15, False, 70.0), (ROUGH, 0.1, 0.4, True, 40.0),
               (ROUGH, 0.5, 0.15, True, 70.0), (ROUGHDIEL, 0.1, 0.4, False, 40.0), (ROUGHDIEL, 0.4, 0.2, True, 140.0)]
ANISO_IDS = [f"{'dielectric' if c[0] == ROUGHDIEL else 'conductor'}-{'beckmann' if c[3] else 'ggx'}-{c[1]}x{c[2]}-{c[4]:g}"
             for c in ANISO_CASES]
FAMILY = Chi2Family("anisotropic sampling", len(ANISO_CASES))


@pytest.mark.parametrize("kind,au,av,beck,theta", ANISO_CASES, ids=ANISO_IDS)
def test_anisotropic_chi2_and_weight(kind: int, au: float, av: float, beck: bool, theta: float) -> None:
    mat = _mat(kind, color=(1, 1, 1), alpha=au, alpha_v=av, int_ior=1.5, flags=ANISO + (BECK if beck else 0.0))
    wi = _unit(theta, 20.0)
    s = sample(mat, wi)
    valid = s["pdf"] > 0
    rng_c = (-1.0, 1.0) if kind == ROUGHDIEL else (0.0, 1.0)
    n_cos, n_phi = (40 if kind == ROUGHDIEL else 20), 40
    idx = directions_to_bins(s["wo"][valid], n_cos, n_phi, rng_c)
    assert np.all(idx >= 0)
    observed, expected = converged_counts(lambda dirs: evaluate(mat, wi, dirs)[1], idx, N, n_cos, n_phi,
                                          rng_c)
    FAMILY.check(ANISO_IDS[ANISO_CASES.index((kind, au, av, beck, theta))], observed, expected)
    f, pdf = evaluate(mat, wi, s["wo"][valid][:4096])
    np.testing.assert_allclose(pdf, s["pdf"][valid][:4096], rtol=2e-3)
    np.testing.assert_allclose(f / pdf[:, None], s["weight"][valid][:4096], rtol=2e-3)
    # white furnace (importance-mode albedo for the dielectric): at most 1
    w = (s["weight"][:, 0] * s["eta"] ** 2).astype(np.float64)
    assert w.mean() <= 1 + 5 * w.std() / np.sqrt(N) + 1e-6


@pytest.mark.parametrize("kind,beck", [(ROUGH, False), (ROUGH, True), (ROUGHDIEL, False), (ROUGHDIEL, True)])
def test_equal_roughnesses_give_the_isotropic_bsdf(kind: int, beck: bool) -> None:
    """The anisotropic formulas with alpha_u = alpha_v are the isotropic ones (to float rounding)."""
    flags = BECK if beck else 0.0
    iso = _mat(kind, alpha=0.35, int_ior=1.5, flags=flags)
    ani = _mat(kind, alpha=0.35, alpha_v=0.35, int_ior=1.5, flags=flags + ANISO)
    wi = _unit(35.0)
    rng = np.random.default_rng(7)
    v = rng.normal(size=(2000, 3))
    wo = v / np.linalg.norm(v, axis=1, keepdims=True)
    f0, p0 = evaluate(iso, wi, wo)
    f1, p1 = evaluate(ani, wi, wo)
    np.testing.assert_allclose(f1, f0, rtol=2e-3, atol=1e-6)
    np.testing.assert_allclose(p1, p0, rtol=2e-3, atol=1e-6)
    if not beck:  # same visible-normal sampler: the same directions
        a, b = sample(iso, wi, n=4096), sample(ani, wi, n=4096)
        np.testing.assert_allclose(b["wo"], a["wo"], atol=1e-5)


def _record(kind: str, **keys) -> np.ndarray:
    scene = {"camera": {"origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 4, "height": 4},
             "materials": {"m": {"type": kind, **keys}}, "shapes": [{"type": "rectangle", "material": "m"}]}
    return compile_scene(parse_scene(scene, "c.json")).materials[0]


def test_scene_keys() -> None:
    for kind in ("conductor", "roughconductor"):
        plain = _record(kind)
        assert plain[7] == 0 and np.all(plain[8:] == 0)
        r = _record(kind, material="Au")
        assert r[7] == CPLX
        np.testing.assert_array_equal(r[9:12], np.float32(GOLD[0]))
        np.testing.assert_array_equal(r[12:15], np.float32(GOLD[1]))
        r = _record(kind, eta=[0.2, 0.4, 1.4])
        np.testing.assert_array_equal(r[12:15], 1.0)  # Mitsuba's default k
        with pytest.raises(Exception, match=r"materials\.m\.material: give either material or eta/k"):
            _record(kind, material="Cu", k=2.0)
        with pytest.raises(Exception, match="unknown value 'Unobtainium'"):
            _record(kind, material="Unobtainium")
    for kind in ("roughconductor", "roughdielectric"):
        np.testing.assert_array_equal(_record(kind, alpha_u=0.2, alpha_v=0.2), _record(kind, alpha=0.2))
        r = _record(kind, alpha_u=0.1, alpha_v=0.3)
        assert r[4] == np.float32(0.1) and r[8] == np.float32(0.3) and int(r[7]) & int(ANISO)
        with pytest.raises(Exception, match="give both alpha_u and alpha_v"):
            _record(kind, alpha_u=0.1)


def test_lane_build_matches_scalar_build() -> None:
    """8 paths per vector give the scalar build's numbers for the new branches (mixed lanes included)."""
    eta, k = CONDUCTOR_IORS["Cu"]
    mats = (_mat(ROUGH, alpha=0.2, alpha_v=0.5, eta=eta, k=k, flags=ANISO + CPLX),
            _mat(ROUGH, alpha=0.2, alpha_v=0.5, flags=ANISO + BECK), _mat(CONDUCTOR, eta=eta, k=k, flags=CPLX),
            _mat(ROUGHDIEL, alpha=0.3, int_ior=1.5), _mat(ROUGHDIEL, alpha=0.1, alpha_v=0.4, int_ior=1.5, flags=ANISO + BECK),
            _mat(int(MaterialKind.THINDIELECTRIC), int_ior=1.5))
    for mat in mats:
        for wi in (_unit(50.0), _unit(130.0)):
            a = sample(mat, wi, n=4096, lanes=1)
            b = sample(mat, wi, n=4096, lanes=8)
            for key in ("wo", "pdf", "weight", "delta", "eta"):
                np.testing.assert_allclose(a[key], b[key], rtol=1e-4, atol=1e-6, err_msg=key)
            fa, pa = evaluate(mat, wi, a["wo"][:512], lanes=1)
            fb, pb = evaluate(mat, wi, a["wo"][:512], lanes=8)
            np.testing.assert_allclose(fa, fb, rtol=1e-4, atol=1e-6)
            np.testing.assert_allclose(pa, pb, rtol=1e-4, atol=1e-6)
