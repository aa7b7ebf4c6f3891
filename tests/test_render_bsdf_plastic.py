"""The plastic BSDF (kernels/render/bsdf_plastic.cl) and the twosided flag (kernels/render/bsdf.cl).

- chi-square of plastic's sampled directions against the pdf bsdf_eval reports,
  with the specular (delta) samples as one more cell;
- the lobe choice: the delta samples' pdf is the specular probability of an
  independent NumPy twin (Fresnel reflectance, Mitsuba's sampling weight);
- the weight of every diffuse sample equals f cos / pdf from bsdf_eval;
- bsdf_eval agrees with a NumPy twin whose internal diffuse reflectance is a
  quadrature of the Fresnel formula (this checks the polynomial fit);
- white furnace: the albedo (mean weight) is at most 1 + 5 standard errors at
  every incidence, and close to 1 for a white base (the exact model conserves);
- twosided: a back-side query gives the front side's values mirrored, for
  every opaque BSDF; the flag leaves front-side results bit-identical;
- path and mis (and light tracing, without plastic) render the same image of a scene with plastic, twosided
  materials seen from behind and a Beckmann metal (8x8-block z-tests, Sidak correction);
- the lane build gives the scalar build's numbers.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from chi2 import Chi2Family
from direction_bins import directions_to_bins, integrate_bins, quadrature_directions
from scipy import stats
from test_render_bsdf import N, evaluate, sample

from mcocl.layouts import MaterialKind
from mcocl.render.api import render
from mcocl.render.compiled import compile_scene
from mcocl.render.scene import parse_scene

PLASTIC = int(MaterialKind.PLASTIC)
TWOSIDED = 1.0  # material_record.flags bit (mcocl.bsdf_registry.FLAG_BITS)


def _mat(kind: int, color=(0.6, 0.4, 0.2), alpha=0.3, int_ior=1.49, ext_ior=1.000277, flags=0.0) -> np.ndarray:
    return np.array([kind, *color, alpha, int_ior, ext_ior, flags], np.float32)


def _unit(theta_deg: float, phi_deg: float = 30.0) -> np.ndarray:
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])


def _fresnel(c: np.ndarray, eta: float) -> np.ndarray:
    """Unpolarised Fresnel reflectance entering a medium of relative index eta (Hecht, Optics §4.6)."""
    c = np.asarray(c, np.float64)
    s2t = (1 - c * c) / eta**2
    ct = np.sqrt(np.maximum(1 - s2t, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):  # grazing (c = 0) is total reflection: R = 1
        rs = (c - eta * ct) / (c + eta * ct)
        rp = (eta * c - ct) / (eta * c + ct)
    return np.where((s2t >= 1) | (c <= 0), 1.0, 0.5 * (rs * rs + rp * rp))


def _fdr_internal(eta: float) -> float:
    """2 int_0^1 F(c) c dc for light leaving a medium of relative index eta (Gauss-Legendre, TIR split off)."""
    crit = np.sqrt(1 - 1 / eta**2) if eta > 1 else 0.0  # cos of the critical angle, seen from inside
    x, w = np.polynomial.legendre.leggauss(400)
    c = crit + (1 - crit) * 0.5 * (x + 1)
    inside = np.sum(w * 0.5 * (1 - crit) * 2 * c * _fresnel(c, 1 / eta))
    return float(inside + crit**2)  # below the critical cosine: total internal reflection


def _plastic_twin(color, eta, wi, wo):
    """f cos of the diffuse lobe and the specular probability, written from the formulas of bsdf_plastic.cl."""
    f_i = _fresnel(wi[2], eta)
    f_o = _fresnel(np.maximum(wo[:, 2], 0.0), eta)
    k = (1 - f_i) * (1 - f_o) / ((1 - _fdr_internal(eta)) * eta**2) * np.maximum(wo[:, 2], 0.0) / np.pi
    s = 1 / (1 + np.mean(color))
    p_spec = f_i * s / (f_i * s + (1 - f_i) * (1 - s))
    return k[:, None] * np.asarray(color), float(p_spec)


CASES = [(0.0, 1.49), (45.0, 1.49), (80.0, 1.49), (60.0, 1.8), (30.0, 1.2), (40.0, 0.8)]  # eta < 1: a thin coat
FAMILY = Chi2Family("plastic sampling", len(CASES))


@pytest.mark.parametrize("theta,eta", CASES)
def test_chi2_and_lobe_choice(theta: float, eta: float) -> None:
    mat = _mat(PLASTIC, int_ior=eta, ext_ior=1.0)
    wi = _unit(theta)
    s = sample(mat, wi)
    spec = s["delta"] == 1
    n_cos, n_phi = 20, 40
    idx = directions_to_bins(s["wo"][~spec], n_cos, n_phi, (0.0, 1.0))
    assert np.all(idx >= 0), "a diffuse sample went below the surface"
    dirs, wts = quadrature_directions(n_cos, n_phi, 16, (0.0, 1.0))
    _, pdf = evaluate(mat, wi, dirs)
    mass = integrate_bins(pdf.astype(np.float64), wts, n_cos * n_phi)
    _, p_spec = _plastic_twin(mat[1:4].astype(np.float64), eta, wi, dirs[:1])
    assert abs(mass.sum() - (1 - p_spec)) < 1e-3
    observed = np.append(np.bincount(idx, minlength=n_cos * n_phi), spec.sum())
    expected = np.append(mass * N, N * p_spec)
    FAMILY.check(f"plastic {theta:g} deg, eta {eta:g}", observed, expected)
    # the specular lobe: mirror direction, pdf = its probability, weight F / P
    np.testing.assert_allclose(s["wo"][spec], np.tile([-wi[0], -wi[1], wi[2]], (spec.sum(), 1)), atol=1e-6)
    np.testing.assert_allclose(s["pdf"][spec], p_spec, rtol=1e-4)
    np.testing.assert_allclose(s["weight"][spec][:, 0], _fresnel(wi[2], eta) / p_spec, rtol=1e-4)


@pytest.mark.parametrize("theta,eta", CASES)
def test_eval_twin_and_sample_weight(theta: float, eta: float) -> None:
    color = (0.6, 0.4, 0.2)
    mat = _mat(PLASTIC, color=color, int_ior=eta, ext_ior=1.0)
    wi = _unit(theta, 70.0)
    rng = np.random.default_rng(3)
    v = rng.normal(size=(2000, 3))
    wo = v / np.linalg.norm(v, axis=1, keepdims=True)
    f, pdf = evaluate(mat, wi, wo)
    want, p_spec = _plastic_twin(np.array(color), eta, wi, wo)
    # the polynomial fit of the internal diffuse reflectance is good to ~1e-3 relative
    np.testing.assert_allclose(f, want, rtol=3e-3, atol=1e-7)
    np.testing.assert_allclose(pdf, (1 - p_spec) * np.maximum(wo[:, 2], 0) / np.pi, rtol=1e-4, atol=1e-7)
    s = sample(mat, wi, n=4096)
    diff = s["delta"] == 0
    f, pdf = evaluate(mat, wi, s["wo"][diff])
    np.testing.assert_allclose(pdf, s["pdf"][diff], rtol=2e-3)
    np.testing.assert_allclose(f / pdf[:, None], s["weight"][diff], rtol=2e-3)


@pytest.mark.parametrize("eta", [1.49, 1.8])
def test_white_furnace(eta: float) -> None:
    """Mean weight = albedo <= 1 + 5 se at every incidence; a white base conserves (the model's identity)."""
    for color, exact in (((1.0, 1.0, 1.0), True), ((0.5, 0.5, 0.5), False)):
        for theta in (0.0, 30.0, 60.0, 80.0, 89.0):
            w = sample(_mat(PLASTIC, color=color, int_ior=eta, ext_ior=1.0), _unit(theta))["weight"][:, 0]
            w = w.astype(np.float64)
            mean, se = w.mean(), w.std() / np.sqrt(len(w))
            assert mean <= 1 + 5 * se, (color, theta, mean, se)
            if exact:
                assert abs(mean - 1) <= 5 * se + 2e-3, (theta, mean, se)


def _mirrored(v: np.ndarray) -> np.ndarray:
    out = np.array(v, copy=True)
    out[..., 2] *= -1
    return out


@pytest.mark.parametrize("kind", ["DIFFUSE", "CONDUCTOR", "ROUGHCONDUCTOR", "PLASTIC"])
def test_twosided_back_is_the_mirrored_front(kind: str) -> None:
    code = int(MaterialKind[kind])
    one, two = _mat(code), _mat(code, flags=TWOSIDED)
    wi = _unit(40.0)
    front = sample(one, wi, n=4096)
    # the flag changes nothing on the front side
    for key, val in sample(two, wi, n=4096).items():
        np.testing.assert_array_equal(val, front[key], err_msg=key)
    # from behind: the front's samples mirrored, same weights and pdfs
    back = sample(two, _mirrored(wi), n=4096)
    np.testing.assert_array_equal(back["wo"], _mirrored(front["wo"]))
    for key in ("weight", "pdf", "delta"):
        np.testing.assert_array_equal(back[key], front[key], err_msg=key)
    assert np.any(back["weight"] > 0)
    # a one-sided material stays black from behind
    assert np.all(sample(one, _mirrored(wi), n=256)["weight"] == 0)
    rng = np.random.default_rng(8)
    v = rng.normal(size=(512, 3))
    wo = v / np.linalg.norm(v, axis=1, keepdims=True)
    f1, p1 = evaluate(one, wi, wo)
    f2, p2 = evaluate(two, _mirrored(wi), _mirrored(wo))
    np.testing.assert_array_equal(f2, f1)
    np.testing.assert_array_equal(p2, p1)


def _plastic_scene() -> dict:
    wall = {"type": "rectangle", "material": "white"}
    return {
        "camera": {"origin": [0, 0, 3.6], "target": [0, 0, 0], "fov": 42, "width": 16, "height": 16},
        "integrator": {"type": "mis", "max_depth": 8, "rr_depth": 4},
        "materials": {
            "white": {"type": "diffuse", "reflectance": 0.7},
            "plastic": {"type": "plastic", "diffuse_reflectance": [0.2, 0.4, 0.7], "int_ior": 1.5},
            "panel": {"type": "diffuse", "reflectance": [0.8, 0.6, 0.3], "twosided": True},
            "shiny": {"type": "plastic", "diffuse_reflectance": 0.3, "twosided": True},
            "metal": {"type": "roughconductor", "alpha": 0.3, "specular_reflectance": [0.9, 0.8, 0.6], "distribution": "beckmann",
                      "twosided": True},
        },
        "shapes": [
            {**wall, "material": "plastic",
             "transform": [{"rotate": {"axis": [1, 0, 0], "angle": -90}}, {"translate": [0, -1, 0]}]},
            {**wall, "transform": [{"translate": [0, 0, -1]}]},
            # panels facing away from the camera: it sees their back sides
            {"type": "rectangle", "material": "panel",
             "transform": [{"scale": 0.35}, {"rotate": {"axis": [0, 1, 0], "angle": 160}}, {"translate": [-0.5, 0.1, 0]}]},
            {"type": "rectangle", "material": "shiny",
             "transform": [{"scale": 0.35}, {"rotate": {"axis": [0, 1, 0], "angle": 200}}, {"translate": [0.5, 0.1, 0]}]},
            {"type": "rectangle", "material": "metal",
             "transform": [{"scale": 0.3}, {"rotate": {"axis": [1, 0, 0], "angle": 120}}, {"translate": [0, -0.5, 0.3]}]},
            {"type": "sphere", "material": "plastic", "center": [0, 0.45, -0.4], "radius": 0.3},
            {"type": "rectangle", "material": "white",
             "transform": [{"scale": 0.5}, {"rotate": {"axis": [1, 0, 0], "angle": 90}}, {"translate": [0, 1.2, 0]}],
             "emitter": {"type": "area", "radiance": [8, 8, 8]}},
        ],
        "environment": {"type": "constant", "radiance": [0.3, 0.3, 0.4]},
    }


def _blocks(x: np.ndarray, b: int = 8) -> np.ndarray:
    """Sums over b x b pixel blocks of an (H, W, C) image."""
    h, w, c = x.shape
    return x.reshape(h // b, b, w // b, b, c).sum(axis=(1, 3))


def test_path_and_mis_agree_on_plastic_and_twosided() -> None:
    cs = compile_scene(parse_scene(_plastic_scene()))
    # path on the independent sampler (auto would take sobol at 2048 spp): the comparison holds for either, and
    # path's independent build with this scene's bvh light sampler is the one the Cornell-box integrator tests
    # make, where a sobol one would be built for this test alone (7 to 10 s on a cold PoCL cache)
    samplers = {"path": "independent", "mis": "auto"}
    r = {k: render(cs, spp=spp, integrator=k, seed=40 + i, sampler=samplers[k])
         for i, (k, spp) in enumerate((("path", 2048), ("mis", 512)))}
    for a, b in itertools.combinations(r, 2):
        ra, rb = r[a], r[b]
        assert ra.nonfinite == 0 and rb.nonfinite == 0
        m1 = _blocks(ra.mean.astype(np.float64))
        m2 = _blocks(rb.mean.astype(np.float64))
        v = _blocks(ra.variance.astype(np.float64)) + _blocks(rb.variance.astype(np.float64))
        z = np.abs(m1 - m2) / np.sqrt(v)
        p = 2 * stats.norm.sf(z)
        level = 1 - (1 - 1e-3) ** (1 / z.size)
        assert p.min() > level, f"{a} vs {b}: max z {z.max():.2f} over {z.size} blocks"
        assert np.all(m1 > 0)


def test_light_tracing_agrees_with_mis_on_twosided_backs() -> None:
    """Light tracing (importance transport, connections to the camera) sees the same twosided backs as mis.

    Plastic stays out: light tracing cannot show a delta lobe seen directly (kernels/render/lt.cl)."""
    scene = _plastic_scene()
    scene["materials"]["plastic"] = {"type": "diffuse", "reflectance": [0.2, 0.4, 0.7]}
    scene["materials"]["shiny"] = {"type": "roughconductor", "alpha": 0.4, "twosided": True}
    cs = compile_scene(parse_scene(scene))
    a = render(cs, spp=512, integrator="mis", seed=50)
    b = render(cs, spp=256, integrator="lt", seed=51, spp_per_block=8)
    assert a.nonfinite == 0 and b.nonfinite == 0
    m1, m2 = _blocks(a.mean.astype(np.float64)), _blocks(b.mean.astype(np.float64))
    v = _blocks(a.variance.astype(np.float64)) + _blocks(b.variance.astype(np.float64))
    z = np.abs(m1 - m2) / np.sqrt(v)
    assert 2 * stats.norm.sf(z.max()) > 1 - (1 - 1e-3) ** (1 / z.size), f"max z {z.max():.2f}"


def test_lane_build_matches_scalar_build() -> None:
    """8 paths per vector give the scalar build's numbers for the new material paths, both sides."""
    rough = int(MaterialKind.ROUGHCONDUCTOR)
    for mat in (_mat(PLASTIC), _mat(PLASTIC, flags=TWOSIDED), _mat(rough, flags=TWOSIDED),
                _mat(rough, flags=TWOSIDED + 2.0), _mat(int(MaterialKind.DIFFUSE), flags=TWOSIDED)):
        for wi in (_unit(50.0), _mirrored(_unit(35.0))):
            a = sample(mat, wi, n=4096, lanes=1)
            b = sample(mat, wi, n=4096, lanes=8)
            for key in ("wo", "pdf", "weight", "delta"):
                np.testing.assert_allclose(a[key], b[key], rtol=1e-4, atol=1e-6, err_msg=key)
            fa, pa = evaluate(mat, wi, a["wo"][:512], lanes=1)
            fb, pb = evaluate(mat, wi, a["wo"][:512], lanes=8)
            np.testing.assert_allclose(fa, fb, rtol=1e-4, atol=1e-6)
            np.testing.assert_allclose(pa, pb, rtol=1e-4, atol=1e-6)
