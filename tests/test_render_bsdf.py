"""BSDF sampling and evaluation kernels (kernels/render/bsdf*.cl).

- chi-square goodness of fit of the sampled directions against the pdf that
  bsdf_eval reports, integrated over (cos theta, phi) bins;
- the weight of every sample equals f cos / pdf from bsdf_eval at that direction;
- bsdf_eval agrees with an independent NumPy twin of the formulas;
- the smooth dielectric chooses reflection with the Fresnel probability
  (NumPy twin) and refracts by Snell's law;
- the lane build (8 paths per vector) gives the scalar build's numbers.
"""

from __future__ import annotations

import numpy as np
import pyopencl as cl
import pytest
from chi2 import Chi2Family
from direction_bins import directions_to_bins, integrate_bins, quadrature_directions

from mcocl import runtime

N = 1 << 17


def _program(lanes: int):
    ctx = runtime.device_context()
    src = runtime.compose(["render/bsdf_sample_test.cl"])
    return ctx, runtime.build(ctx, src, [f"-DLANES={lanes}"], what="BSDF test kernels")


def _material(kind: int, color=(0.9, 0.7, 0.5), alpha=0.3, int_ior=1.5, ext_ior=1.0) -> np.ndarray:
    return np.array([kind, *color, alpha, int_ior, ext_ior, 0.0], np.float32)


def _unit(theta_deg: float, phi_deg: float = 30.0) -> np.ndarray:
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])


def sample(mat: np.ndarray, wi: np.ndarray, n: int = N, seed: int = 1, lanes: int = 1) -> dict[str, np.ndarray]:
    """Run bsdf_sample for n draws; returns wo (n,3), pdf, weight (n,3), delta, eta."""
    ctx, prg = _program(lanes)
    mf = cl.mem_flags
    bm = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=mat)
    out = np.empty((9, n), np.float32)
    bo = cl.Buffer(ctx.context, mf.WRITE_ONLY, out.nbytes)
    g, lsz = ctx.work_size(n // lanes)
    wi4 = np.array([*wi, 0.0], np.float32)
    runtime.kernel(prg, "bsdf_sample_dirs")(ctx.queue, g, lsz, bm, wi4, np.uint64(seed), np.uint32(n), bo)
    cl.enqueue_copy(ctx.queue, out, bo)
    return {"wo": out[0:3].T.copy(), "pdf": out[3], "weight": out[4:7].T.copy(), "delta": out[7], "eta": out[8]}


def evaluate(mat: np.ndarray, wi: np.ndarray, wo: np.ndarray, lanes: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """bsdf_eval at the rows of wo: (f cos (n,3), pdf (n,))."""
    ctx, prg = _program(lanes)
    n0 = len(wo)
    n = -(-n0 // 8) * 8
    w = np.zeros((3, n), np.float32)
    w[:, :n0] = wo.T
    w[2, n0:] = 1.0
    mf = cl.mem_flags
    bm = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=mat)
    bw = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=w)
    out = np.empty((4, n), np.float32)
    bo = cl.Buffer(ctx.context, mf.WRITE_ONLY, out.nbytes)
    g, lsz = ctx.work_size(n // lanes)
    wi4 = np.array([*wi, 0.0], np.float32)
    runtime.kernel(prg, "bsdf_eval_dirs")(ctx.queue, g, lsz, bm, wi4, np.uint32(n), bw, bo)
    cl.enqueue_copy(ctx.queue, out, bo)
    return out[0:3, :n0].T.copy(), out[3, :n0].copy()


SMOOTH_CASES = [
    ("diffuse, normal incidence", _material(0), 0.0),
    ("diffuse, grazing", _material(0), 80.0),
    ("ggx a=0.5, normal", _material(2, alpha=0.5), 0.0),
    ("ggx a=0.5, 70 deg", _material(2, alpha=0.5), 70.0),
    ("ggx a=0.2, 40 deg", _material(2, alpha=0.2), 40.0),
    ("ggx a=0.1, 85 deg", _material(2, alpha=0.1), 85.0),
]


DIELECTRIC_CASES = [(0.0, 1.5), (60.0, 1.5), (85.0, 1.33), (150.0, 1.5), (130.0, 1.5), (170.0, 2.4)]
# the directions of every smooth case, and the lobe choice of every dielectric case
FAMILY = Chi2Family("BSDF sampling", len(SMOOTH_CASES) + len(DIELECTRIC_CASES))


@pytest.mark.parametrize("label,mat,theta", SMOOTH_CASES, ids=[c[0] for c in SMOOTH_CASES])
def test_chi2_smooth_bsdfs(label: str, mat: np.ndarray, theta: float) -> None:
    wi = _unit(theta)
    s = sample(mat, wi)
    valid = s["pdf"] > 0
    n_cos, n_phi = (20, 40)
    fine_cos = mat[0] == 2 and mat[4] < 0.15
    if fine_cos:
        n_cos = 40
    # the lower hemisphere is impossible for these BSDFs: bin the upper one only
    rng = (0.0, 1.0)
    idx = directions_to_bins(s["wo"][valid], n_cos, n_phi, rng)
    assert np.all(idx >= 0), "a sample went below the surface"
    obs = np.bincount(idx, minlength=n_cos * n_phi).astype(float)
    mass2 = _bin_masses(mat, wi, n_cos, n_phi, rng)
    total = mass2.sum()
    assert total <= 1.0 + 2e-3
    # the samples that failed (reflected below the horizon) form one more cell
    observed = np.append(obs, N - valid.sum())
    expected = np.append(mass2 * N, max(N * (1.0 - total), 0.0))
    FAMILY.check(label, observed, expected)


@pytest.mark.parametrize("label,mat,theta", SMOOTH_CASES, ids=[c[0] for c in SMOOTH_CASES])
def test_sample_weight_is_eval_over_pdf(label: str, mat: np.ndarray, theta: float) -> None:
    wi = _unit(theta)
    s = sample(mat, wi, n=4096)
    valid = s["pdf"] > 0
    f, pdf = evaluate(mat, wi, s["wo"][valid])
    np.testing.assert_allclose(pdf, s["pdf"][valid], rtol=2e-3)
    np.testing.assert_allclose(f / pdf[:, None], s["weight"][valid], rtol=2e-3)
    assert np.all(s["weight"][~valid] == 0)
    assert np.all(s["delta"] == 0)


def _bin_masses(mat: np.ndarray, wi: np.ndarray, n_cos: int, n_phi: int, rng: tuple[float, float]) -> np.ndarray:
    """pdf integrals over the bins, refining the quadrature until it is converged far below the counting noise."""
    prev = None
    for nq in (8, 16, 32, 64):
        dirs, wts = quadrature_directions(n_cos, n_phi, nq, rng)
        _, pdf = evaluate(mat, wi, dirs)
        mass = integrate_bins(pdf.astype(np.float64), wts, n_cos * n_phi)
        if prev is not None and np.max(np.abs(mass - prev) * N / np.sqrt(np.maximum(mass * N, 1))) < 0.2:
            return mass
        prev = mass
    raise AssertionError("the pdf quadrature did not converge")


def _ggx_twin(alpha: float, wi: np.ndarray, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """f cos / F and pdf of the GGX conductor, written from Walter et al. 2007 independently."""
    h = wi + wo
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    cos_h = h[:, 2]
    tan2_h = (1 - cos_h**2) / cos_h**2
    d = 1.0 / (np.pi * alpha**2 * cos_h**4 * (1 + tan2_h / alpha**2) ** 2)

    def g1(v: np.ndarray) -> np.ndarray:
        tan2 = (1 - v[..., 2] ** 2) / v[..., 2] ** 2
        return 2.0 / (1.0 + np.sqrt(1.0 + alpha**2 * tan2))

    cos_i = wi[2]
    fcos = d * g1(wi) * g1(wo) / (4 * cos_i)
    pdf = d * g1(wi) / (4 * cos_i)
    ok = (wo[:, 2] > 0) & (cos_i > 0)
    return np.where(ok, fcos, 0.0), np.where(ok, pdf, 0.0)


def test_eval_matches_numpy_twin() -> None:
    rng = np.random.default_rng(5)
    v = rng.normal(size=(2000, 3))
    wo = v / np.linalg.norm(v, axis=1, keepdims=True)
    for theta in (0.0, 35.0, 75.0):
        wi = _unit(theta, 110.0)
        mat = _material(0, color=(0.8, 0.5, 0.25))
        f, pdf = evaluate(mat, wi, wo)
        want = np.where(wo[:, 2] > 0, wo[:, 2] / np.pi, 0.0)
        np.testing.assert_allclose(pdf, want, rtol=1e-5, atol=1e-7)
        np.testing.assert_allclose(f, want[:, None] * np.array([0.8, 0.5, 0.25]), rtol=1e-5, atol=1e-7)
        for alpha in (0.15, 0.6):
            mat = _material(2, color=(0.9, 0.6, 0.3), alpha=alpha)
            f, pdf = evaluate(mat, wi, wo)
            fc, pd = _ggx_twin(alpha, wi, wo)
            np.testing.assert_allclose(pdf, pd, rtol=2e-4, atol=1e-6)
            np.testing.assert_allclose(f, fc[:, None] * np.array([0.9, 0.6, 0.3]), rtol=2e-4, atol=1e-6)
    # one-sided: black from behind, for both kinds
    wi = -_unit(30.0)
    for kind in (0, 2):
        f, pdf = evaluate(_material(kind), wi, wo)
        assert np.all(f == 0) and np.all(pdf == 0)
        s = sample(_material(kind), wi, n=256)
        assert np.all(s["weight"] == 0)


def test_diffuse_and_ggx_energy() -> None:
    """E[weight] over samples = integral of f cos over the sphere (quadrature of bsdf_eval)."""
    for mat, theta in ((_material(0), 20.0), (_material(2, alpha=0.4), 60.0)):
        wi = _unit(theta)
        s = sample(mat, wi)
        est = s["weight"].astype(np.float64).mean(axis=0)
        se = s["weight"].astype(np.float64).std(axis=0) / np.sqrt(N)
        dirs, wts = quadrature_directions(32, 64, 8, (0.0, 1.0))
        f, _ = evaluate(mat, wi, dirs)
        ref = (f.astype(np.float64) * wts[:, None]).sum(axis=0)
        assert np.all(np.abs(est - ref) <= 5 * se + 1e-6), (est, ref, se)
    # the Lambertian albedo is exact
    np.testing.assert_allclose(sample(_material(0), _unit(10.0))["weight"][:16], np.tile([0.9, 0.7, 0.5], (16, 1)), rtol=1e-6)


def _fresnel_twin(cos_i: float, eta: float) -> float:
    """Unpolarised Fresnel reflectance from the textbook amplitude ratios (Hecht, Optics §4.6)."""
    n1, n2 = (1.0, eta) if cos_i > 0 else (eta, 1.0)
    ci = abs(cos_i)
    s2t = (n1 / n2) ** 2 * (1 - ci * ci)
    if s2t >= 1:
        return 1.0
    ct = np.sqrt(1 - s2t)
    rs = (n1 * ci - n2 * ct) / (n1 * ci + n2 * ct)
    rp = (n2 * ci - n1 * ct) / (n2 * ci + n1 * ct)
    return 0.5 * (rs * rs + rp * rp)


@pytest.mark.parametrize("theta,eta", DIELECTRIC_CASES)
def test_dielectric_fresnel_and_snell(theta: float, eta: float) -> None:
    """theta > 90: the path arrives from inside the medium (130 deg is beyond the critical angle of 1.5)."""
    wi = _unit(theta, 45.0)
    mat = _material(3, color=(1.0, 0.9, 0.8), int_ior=eta, ext_ior=1.0)
    s = sample(mat, wi)
    r = _fresnel_twin(wi[2], eta)
    refl = np.isclose(s["wo"][:, 2], wi[2], atol=1e-5)
    assert np.all(s["delta"] == 1)
    # reflection: mirror direction, weight = tint, probability R
    np.testing.assert_allclose(s["wo"][refl], np.tile([-wi[0], -wi[1], wi[2]], (refl.sum(), 1)), atol=1e-5)
    np.testing.assert_allclose(s["weight"][refl], np.tile([1.0, 0.9, 0.8], (refl.sum(), 1)), rtol=1e-6)
    if r >= 1.0:
        assert refl.all()
        return
    # refraction: Snell's law, radiance scaled by (eta_i / eta_t)^2
    n1, n2 = (1.0, eta) if wi[2] > 0 else (eta, 1.0)
    t = s["wo"][~refl]
    sin_i = np.hypot(wi[0], wi[1])
    np.testing.assert_allclose(np.hypot(t[:, 0], t[:, 1]), n1 / n2 * sin_i, rtol=1e-4, atol=1e-6)
    assert np.all(np.sign(t[:, 2]) == -np.sign(wi[2]))
    if sin_i > 0:  # the refracted ray stays in the plane of incidence, on the other side of the normal
        np.testing.assert_allclose(t[:, :2] / np.linalg.norm(t[:, :2], axis=1, keepdims=True),
                                   np.tile(-wi[:2] / sin_i, (len(t), 1)), atol=1e-4)
    np.testing.assert_allclose(s["weight"][~refl], np.tile(np.array([1.0, 0.9, 0.8]) * (n1 / n2) ** 2, (len(t), 1)),
                               rtol=1e-5)
    np.testing.assert_allclose(s["eta"][~refl], n2 / n1, rtol=1e-6)
    # chi-square (two cells) of the lobe choice against the Fresnel reflectance
    k = refl.sum()
    FAMILY.check(f"dielectric lobe choice, {theta:g} deg, eta {eta:g}", [k, N - k], [N * r, N * (1 - r)])
    np.testing.assert_allclose(s["pdf"][refl], r, rtol=1e-4)
    np.testing.assert_allclose(s["pdf"][~refl], 1 - r, rtol=1e-4)


def test_mirror() -> None:
    wi = _unit(50.0)
    s = sample(_material(1, color=(0.95, 0.64, 0.54)), wi, n=512)
    np.testing.assert_allclose(s["wo"], np.tile([-wi[0], -wi[1], wi[2]], (512, 1)), atol=1e-6)
    np.testing.assert_allclose(s["weight"], np.tile([0.95, 0.64, 0.54], (512, 1)), rtol=1e-6)
    assert np.all(s["delta"] == 1)
    f, pdf = evaluate(_material(1), wi, s["wo"][:8])
    assert np.all(f == 0) and np.all(pdf == 0)
    assert np.all(sample(_material(1), -wi, n=64)["weight"] == 0)


def test_lane_build_matches_scalar_build() -> None:
    for mat, theta in ((_material(0), 30.0), (_material(2, alpha=0.3), 50.0), (_material(3), 40.0)):
        wi = _unit(theta)
        a = sample(mat, wi, n=4096, lanes=1)
        b = sample(mat, wi, n=4096, lanes=8)
        for key in ("wo", "pdf", "weight", "delta"):
            np.testing.assert_allclose(a[key], b[key], rtol=1e-4, atol=1e-6, err_msg=key)
