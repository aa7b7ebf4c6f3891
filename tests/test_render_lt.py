"""Light tracing (``integrator="lt"``) and the adjoint half of the scene it rests on.

- Emitter rays (kernels/render/lights_emit.cl), chi-square against exact
  expected counts: the emitter choice, uniform positions on a rectangle and a
  sphere, the cosine-weighted direction about the front normal, the
  environment's uniform direction and uniform point on its disk; the reported
  densities against their closed forms.
- The camera (kernels/render/camera.cl), pinhole and thin lens: the raster
  position of a primary ray is the film point it was made from, lens points
  are uniform on the aperture (chi-square), rays meet on the focal plane, and
  the importance integrates to 1 / A_lens (W_e cos = the ray density).
- The BSDFs' transport modes: only the dielectric's refraction differs.
- The white furnace's closed form; ``lt`` against ``mis`` in 8 x 8-pixel
  blocks and per pixel (Sidak-corrected z-tests) on the Cornell box, with a
  thin lens, and under a constant environment; the batch variance against
  the spread over seeds and as the noise-halting rule; bit-identical images
  across launch splits, sub-devices and a resume; black mirrors.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pyopencl as cl
import pytest
from chi2 import Chi2Family
from interrupting import interrupt_after_first_fold
from scipy import stats

from mcocl import runtime
from mcocl.accumulate import Accumulator
from mcocl.render.api import render
from mcocl.render.compiled import compile_scene
from mcocl.render.device_scene import scene_params, scene_tables
from mcocl.render.emitter_choice import ENV_SHARE, bounding_sphere
from mcocl.render.job import RenderJob
from mcocl.render.scene import parse_scene
from mcocl.render.scene_file import load_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"
N = 1 << 17
CAMERA = {"origin": [0.3, -0.2, 4.0], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 50, "width": 12, "height": 8}

# emitter choice, rectangle positions, rectangle directions, sphere positions,
# sphere directions, environment directions, environment disk
FAMILY = Chi2Family("emitter rays", 7)


def _emit_scene() -> dict:
    return {
        "camera": CAMERA,
        "integrator": {"type": "lt"},  # the environment's share of emitted paths is light tracing's
        "materials": {"m": {"type": "diffuse", "reflectance": 0.5}},
        "environment": {"type": "constant", "radiance": [0.05, 0.1, 0.2]},
        "shapes": [
            # a 1.2 x 0.8 rectangle at z = 2 facing down (front normal -z after the rotation)
            {"name": "rect", "type": "rectangle", "material": "m",
             "transform": [{"scale": [0.6, 0.4, 1]}, {"rotate": {"axis": [1, 0, 0], "angle": 180}},
                           {"translate": [0.2, 0.1, 2.0]}],
             "emitter": {"type": "area", "radiance": [4.0, 3.0, 2.0]}},
            {"name": "ball", "type": "sphere", "material": "m", "center": [-1.5, 0.5, 0.0], "radius": 0.5,
             "emitter": {"type": "area", "radiance": [3.0, 3.0, 3.0]}},
        ],
    }


class AdjointKernels:
    """The test kernels of adjoint_test.cl for one compiled scene."""

    def __init__(self, scene: dict, lanes: int = 8) -> None:
        self.cs = compile_scene(parse_scene(scene))
        self.t = scene_tables(self.cs)
        self.ctx = runtime.device_context()
        self.lanes = lanes
        src = runtime.compose(["render/adjoint_test.cl"])
        self.prg = runtime.build(self.ctx, src, [f"-DLANES={lanes}"], what="adjoint test kernels")
        mf = cl.mem_flags
        self.buf = {k: cl.Buffer(self.ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=self.t[k])
                    for k in ("emitter_radiance", "light_rec", "light_cdf", "camera")}
        centre, radius = bounding_sphere(self.cs.bounds)
        self.bsphere = np.array([*centre, radius], np.float32)

    def rays(self, n: int = N, seed: int = 3) -> dict[str, np.ndarray]:
        out = np.empty((17, n), np.float32)
        bo = cl.Buffer(self.ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
        g, lsz = self.ctx.work_size(n // self.lanes)
        runtime.kernel(self.prg, "emitter_ray_samples")(
            self.ctx.queue, g, lsz, scene_params(self.t), self.buf["emitter_radiance"], self.buf["light_rec"],
            self.buf["light_cdf"], self.bsphere, np.uint64(seed), np.uint32(n), bo)
        cl.enqueue_copy(self.ctx.queue, out, bo)
        o = out.astype(np.float64)
        return {"pos": o[0:3].T, "n": o[3:6].T, "d": o[6:9].T, "radiance": o[9:12].T, "pdf_area": o[12],
                "pdf_solid_angle": o[13], "cos": o[14], "env": out[15] != 0, "valid": out[16] != 0}

    def camera(self, dirs: np.ndarray, lens_u: tuple[float, float] = (0.5, 0.5)) -> dict[str, np.ndarray]:
        n0 = len(dirs)
        n = -(-n0 // 16) * 16
        d = np.zeros((3, n), np.float32)
        d[:, :n0] = dirs.T
        d[2, n0:] = 1.0
        mf = cl.mem_flags
        bd = cl.Buffer(self.ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=d)
        out = np.empty((7, n), np.float32)
        bo = cl.Buffer(self.ctx.context, mf.WRITE_ONLY, out.nbytes)
        g, lsz = self.ctx.work_size(n // self.lanes)
        runtime.kernel(self.prg, "camera_directions")(
            self.ctx.queue, g, lsz, self.buf["camera"], np.uint32(self.cs.width), np.uint32(self.cs.height),
            np.array([*lens_u, 0, 0], np.float32), np.uint32(n), bd, bo)
        cl.enqueue_copy(self.ctx.queue, out, bo)
        o = out[:, :n0].astype(np.float64)
        return {"raster": o[0:2].T, "pixel": out[2, :n0].astype(np.int64), "importance": o[3],
                "pdf_solid_angle": o[4], "cos": o[5], "valid": out[6, :n0] != 0}


@pytest.fixture(scope="module")
def emit() -> tuple[AdjointKernels, dict]:
    k = AdjointKernels(_emit_scene())
    return k, k.rays()


def _shape_of(k: AdjointKernels, r: dict) -> tuple[np.ndarray, np.ndarray]:
    """Masks of the samples on the rectangle (z = 2) and on the sphere."""
    on_rect = ~r["env"] & (np.abs(r["pos"][:, 2] - 2.0) < 1e-4)
    on_ball = ~r["env"] & ~on_rect
    return on_rect, on_ball


def _cos_bins(c: np.ndarray, phi: np.ndarray, n_cos: int = 10, n_phi: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Observed counts over (cos in [0, 1], phi) cells and the cosine-weighted expectation."""
    i = np.clip(np.floor(c * n_cos), 0, n_cos - 1).astype(int)
    j = np.clip(np.floor((phi + np.pi) / (2 * np.pi) * n_phi), 0, n_phi - 1).astype(int)
    obs = np.bincount(i * n_phi + j, minlength=n_cos * n_phi).astype(float)
    edges = np.linspace(0, 1, n_cos + 1)
    p_cos = np.diff(edges**2)  # P(cos in [a, b]) = b^2 - a^2 for the density cos / pi
    return obs, np.repeat(p_cos, n_phi) / n_phi * len(c)


def test_emitter_choice_follows_power(emit) -> None:
    k, r = emit
    assert np.all(r["valid"])
    on_rect, on_ball = _shape_of(k, r)
    env_pmf = float(k.t["env_choice"][1])
    pmf = k.t["prim_pmf"].astype(np.float64)
    lights = k.cs.light_prims
    is_ball = lights >= k.cs.num_triangles
    p_rect = (1 - env_pmf) * pmf[lights[~is_ball]].sum()
    p_ball = (1 - env_pmf) * pmf[lights[is_ball]].sum()
    FAMILY.check("emitter choice", [on_rect.sum(), on_ball.sum(), r["env"].sum()],
                 np.array([p_rect, p_ball, env_pmf]) * N)
    # the environment takes ENV_SHARE of the light paths (emitter_choice: independent of the scene's
    # size), the area lights the rest in proportion to their power luminance * area * pi
    assert env_pmf == pytest.approx(ENV_SHARE, abs=2**-23)
    lum = np.array([0.2126, 0.7152, 0.0722])
    powers = np.array([lum @ [4, 3, 2] * 1.2 * 0.8, lum @ [3, 3, 3] * 4 * math.pi * 0.25]) * math.pi
    np.testing.assert_allclose([p_rect, p_ball], (1 - env_pmf) * powers / powers.sum(), rtol=1e-4)


def test_area_light_rays(emit) -> None:
    k, r = emit
    on_rect, on_ball = _shape_of(k, r)
    env_pmf = float(k.t["env_choice"][1])
    pmf = k.t["prim_pmf"].astype(np.float64)
    # rectangle: positions uniform over [-0.4, 0.8] x [-0.3, 0.5], directions cosine-weighted about -z
    p = r["pos"][on_rect]
    kk = 8
    i = np.clip(np.floor((p[:, 0] + 0.4) / 1.2 * kk), 0, kk - 1).astype(int)
    j = np.clip(np.floor((p[:, 1] + 0.3) / 0.8 * kk), 0, kk - 1).astype(int)
    FAMILY.check("rectangle positions", np.bincount(i * kk + j, minlength=kk * kk),
                 np.full(kk * kk, on_rect.sum() / kk**2))
    d = r["d"][on_rect]
    local = np.stack([d[:, 0], -d[:, 1], -d[:, 2]], axis=1)  # the frame of the front normal -z
    obs, exp = _cos_bins(local[:, 2], np.arctan2(local[:, 1], local[:, 0]))
    FAMILY.check("rectangle directions", obs, exp)
    np.testing.assert_allclose(r["n"][on_rect], np.tile([0, 0, -1.0], (on_rect.sum(), 1)), atol=1e-6)
    np.testing.assert_allclose(r["cos"][on_rect], local[:, 2], atol=1e-5)
    np.testing.assert_allclose(r["pdf_solid_angle"][on_rect], local[:, 2] / math.pi, rtol=1e-4, atol=1e-7)
    tri = k.cs.light_prims[k.cs.light_prims < k.cs.num_triangles]
    # each triangle of the rectangle is chosen with its pmf and has half the area: pmf / area is the same
    np.testing.assert_allclose(r["pdf_area"][on_rect], (1 - env_pmf) * pmf[tri[0]] / 0.48, rtol=1e-5)
    np.testing.assert_allclose(r["radiance"][on_rect], np.tile([4.0, 3.0, 2.0], (on_rect.sum(), 1)))
    # sphere: uniform over its area, directions cosine-weighted about the outward normal
    c = np.array([-1.5, 0.5, 0.0])
    q = r["pos"][on_ball] - c
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 0.5, atol=1e-5)
    nrm = q / 0.5
    obs, exp = _cos_bins((nrm[:, 2] + 1) / 2, np.arctan2(nrm[:, 1], nrm[:, 0]))
    FAMILY.check("sphere positions", obs, np.full(len(obs), on_ball.sum() / len(obs)))
    cos_d = np.sum(r["d"][on_ball] * nrm, axis=1)
    edges = np.linspace(0, 1, 11)
    FAMILY.check("sphere directions", np.histogram(cos_d, edges)[0], np.diff(edges**2) * on_ball.sum())
    ball = k.cs.light_prims[k.cs.light_prims >= k.cs.num_triangles][0]
    np.testing.assert_allclose(r["pdf_area"][on_ball], (1 - env_pmf) * pmf[ball] / (math.pi * 1.0), rtol=1e-5)


def test_environment_rays(emit) -> None:
    k, r = emit
    sel = r["env"]
    d = r["d"][sel]
    n_cos, n_phi = 10, 12
    i = np.clip(np.floor((d[:, 2] + 1) / 2 * n_cos), 0, n_cos - 1).astype(int)
    j = np.clip(np.floor((np.arctan2(d[:, 1], d[:, 0]) + np.pi) / (2 * np.pi) * n_phi), 0, n_phi - 1).astype(int)
    FAMILY.check("environment directions", np.bincount(i * n_phi + j, minlength=n_cos * n_phi),
                 np.full(n_cos * n_phi, sel.sum() / (n_cos * n_phi)))
    centre, radius = bounding_sphere(k.cs.bounds)
    rel = r["pos"][sel] - centre
    along = np.sum(rel * d, axis=1)
    np.testing.assert_allclose(along, -radius * 1.001, rtol=1e-4)  # the disk lies outside the bounding sphere
    rho2 = (np.sum(rel * rel, axis=1) - along**2) / radius**2  # uniform on the disk: rho^2 uniform in [0, 1]
    edges = np.linspace(0, 1, 11)
    FAMILY.check("environment disk", np.histogram(rho2, edges)[0], np.full(10, sel.sum() / 10))
    env_pmf = float(k.t["env_choice"][1])
    np.testing.assert_allclose(r["pdf_area"][sel], env_pmf / (math.pi * radius**2), rtol=1e-5)
    np.testing.assert_allclose(r["pdf_solid_angle"][sel], 1 / (4 * math.pi), rtol=1e-6)


def test_camera_importance_and_raster_positions(emit) -> None:
    k, _ = emit
    cs = k.cs
    o, right, up, fwd = (cs.camera[i, :3].astype(np.float64) for i in range(4))
    rng = np.random.default_rng(5)
    # film points -> primary directions (the contract of mcocl/render/compiled.py) -> back to the film
    s = rng.uniform([0, 0], [cs.width, cs.height], size=(4096, 2))
    ndc_x, ndc_y = 2 * s[:, 0] / cs.width - 1, 1 - 2 * s[:, 1] / cs.height
    d = fwd + ndc_x[:, None] * right + ndc_y[:, None] * up
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    c = k.camera(d)
    assert np.all(c["valid"])
    np.testing.assert_allclose(c["raster"], s, atol=2e-3)
    inner = np.all(np.abs(s - np.round(s)) > 3e-3, axis=1)
    want = np.floor(s[:, 1]).astype(int) * cs.width + np.floor(s[:, 0]).astype(int)
    assert np.array_equal(c["pixel"][inner], want[inner])
    np.testing.assert_allclose(c["pdf_solid_angle"], c["importance"] * c["cos"], rtol=1e-5)
    # the importance integrates to one: E[W_e cos] over uniform directions times 4 pi
    u = rng.normal(size=(1 << 18, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    c = k.camera(u)
    x = 4 * math.pi * c["importance"] * np.maximum(c["cos"], 0)
    assert np.all(c["importance"][~c["valid"]] == 0)
    assert abs(x.mean() - 1) <= 5 * x.std() / math.sqrt(len(x)), (x.mean(), x.std() / math.sqrt(len(x)))


@pytest.mark.parametrize("kind", [0, 1, 2, 3, 4])
def test_transport_modes_differ_only_by_the_dielectrics_refraction_scale(emit, kind: int) -> None:
    """Same uniforms, both modes: the same directions; the same weights except refraction, where radiance
    carries (eta_i / eta_t)^2 and importance does not (Veach's thesis §5.2)."""
    k, _ = emit
    eta = 1.5
    mat = np.array([kind, 0.9, 0.7, 0.5, 0.3, eta, 1.0, 0.0], np.float32)
    wi = np.array([0.3, 0.2, math.sqrt(1 - 0.13)], np.float32)
    n = 4096
    mf = cl.mem_flags
    bm = cl.Buffer(k.ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=mat)
    out = np.empty((12, n), np.float32)
    bo = cl.Buffer(k.ctx.context, mf.WRITE_ONLY, out.nbytes)
    g, lsz = k.ctx.work_size(n // k.lanes)
    runtime.kernel(k.prg, "bsdf_sample_modes")(k.ctx.queue, g, lsz, bm, np.array([*wi, 0], np.float32),
                                               np.uint64(9), np.uint32(n), bo)
    cl.enqueue_copy(k.ctx.queue, out, bo)
    wo_r, w_r, wo_i, w_i = out[0:3].T, out[3:6].T, out[6:9].T, out[9:12].T
    np.testing.assert_array_equal(wo_r, wo_i)
    refract = wo_r[:, 2] < 0
    if kind == 3:  # MaterialKind.DIELECTRIC, entering the glass from outside
        assert 0 < refract.sum() < n
        np.testing.assert_allclose(w_r[refract], w_i[refract] / eta**2, rtol=1e-6)
        np.testing.assert_array_equal(w_r[~refract], w_i[~refract])
    else:  # symmetric BSDFs (a rough conductor's samples below the horizon have weight 0 in both modes)
        np.testing.assert_array_equal(w_r, w_i)


THIN_LENS = {**CAMERA, "aperture_radius": 0.25, "focus_distance": 3.0}


@pytest.fixture(scope="module")
def lens() -> AdjointKernels:
    return AdjointKernels({**_emit_scene(), "camera": THIN_LENS})


def test_thin_lens_rays(lens) -> None:
    """Lens points uniform on the aperture disk (chi-square), rays through a film point meet on the focal
    plane, and the film position of a ray is the film point it was made from."""
    k = lens
    cs = k.cs
    n = 1 << 16
    out = np.empty((8, n), np.float32)
    bo = cl.Buffer(k.ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    g, lsz = k.ctx.work_size(n // k.lanes)
    runtime.kernel(k.prg, "camera_rays")(k.ctx.queue, g, lsz, k.buf["camera"], np.uint32(cs.width),
                                         np.uint32(cs.height), np.uint64(4), np.uint32(n), bo)
    cl.enqueue_copy(k.ctx.queue, out, bo)
    o64 = out.astype(np.float64)
    film, org, d = o64[0:2].T, o64[2:5].T, o64[5:8].T
    origin, right, up, fwd = (cs.camera[i, :3].astype(np.float64) for i in range(4))
    assert cs.camera[0, 3] == np.float32(0.25) and cs.camera[1, 3] == np.float32(3.0)
    rel = org - origin
    x, y = rel @ (right / np.linalg.norm(right)), rel @ (up / np.linalg.norm(up))
    np.testing.assert_allclose(rel @ fwd, 0, atol=1e-6)
    rho2, phi = (x * x + y * y) / 0.25**2, np.arctan2(y, x)
    i = np.clip(np.floor(rho2 * 8), 0, 7).astype(int)
    j = np.clip(np.floor((phi + np.pi) / (2 * np.pi) * 8), 0, 7).astype(int)
    FAMILY_LENS.check("lens points", np.bincount(i * 8 + j, minlength=64), np.full(64, n / 64))
    # every ray passes the focal-plane point of its pinhole ray
    ndc_x, ndc_y = 2 * film[:, 0] / cs.width - 1, 1 - 2 * film[:, 1] / cs.height
    focal = origin + 3.0 * (fwd + ndc_x[:, None] * right + ndc_y[:, None] * up)
    t = 3.0 / (d @ fwd)
    np.testing.assert_allclose(org + t[:, None] * d, focal, atol=2e-4)
    # and camera_importance maps (lens point, direction) back to the film point
    for lens_u in ((0.3, 0.7), (0.9, 0.1)):
        rr, ph = 0.25 * math.sqrt(lens_u[0]), 2 * math.pi * lens_u[1]
        xl = origin + rr * math.cos(ph) * right / np.linalg.norm(right) + rr * math.sin(ph) * up / np.linalg.norm(up)
        dd = focal[:2048] - xl
        dd /= np.linalg.norm(dd, axis=1, keepdims=True)
        c = k.camera(dd, lens_u)
        assert np.all(c["valid"])
        np.testing.assert_allclose(c["raster"], film[:2048], atol=3e-3)
    # the importance integrates to 1 / A_lens over the directions from one lens point
    rng = np.random.default_rng(6)
    u = rng.normal(size=(1 << 18, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    c = k.camera(u, (0.6, 0.2))
    xw = 4 * math.pi * c["importance"] * np.maximum(c["cos"], 0) * math.pi * 0.25**2
    assert abs(xw.mean() - 1) <= 5 * xw.std() / math.sqrt(len(xw)), xw.mean()


FAMILY_LENS = Chi2Family("thin lens", 1)


# ---- the renders -----------------------------------------------------------

RHO = np.array([0.8, 0.5, 0.2])
LE = np.array([0.2, 0.5, 0.8])


def furnace_closed_form(max_depth: int) -> np.ndarray:
    """L = Le (1 - rho^D) / (1 - rho), Le / (1 - rho) unbounded (scenes/furnace.json)."""
    return LE / (1 - RHO) if max_depth < 0 else LE * (1 - RHO**max_depth) / (1 - RHO)


def downscaled(name: str, size: int):
    sc = load_scene(SCENES / name)
    sc.camera.width = sc.camera.height = size
    return compile_scene(sc)


def block_means(x: np.ndarray) -> np.ndarray:
    """Means of the 8 x 8-pixel blocks of a 32 x 32 image, per channel."""
    return x.astype(np.float64).reshape(4, 8, 4, 8, 3).mean(axis=(1, 3))


def block_variances(var: np.ndarray) -> np.ndarray:
    """Variances of those block means from the pixels' reported variances (pixels taken as independent)."""
    return var.astype(np.float64).reshape(4, 8, 4, 8, 3).sum(axis=(1, 3)) / 64**2


def assert_blocks_agree(a, b) -> None:
    """No 8 x 8-block z-score of two renders beyond the Sidak-corrected level (family-wise 1e-3)."""
    z = (block_means(a.mean) - block_means(b.mean)) / np.sqrt(block_variances(a.variance) + block_variances(b.variance))
    level = 1 - (1 - 1e-3) ** (1 / z.size)
    assert 2 * stats.norm.sf(np.abs(z).max()) > level, f"largest |z| {np.abs(z).max():.2f} (level {level:.2e})"


def assert_pixels_agree(a, b) -> None:
    """No per-pixel z-score beyond the Sidak-corrected level (family-wise 1e-3)."""
    z = (a.mean - b.mean) / np.sqrt(a.variance + b.variance)
    assert np.all(np.isfinite(z))
    assert 2 * stats.norm.sf(np.abs(z).max()) > 1 - (1 - 1e-3) ** (1 / z.size), np.abs(z).max()


@pytest.mark.parametrize("scene", ["furnace.json", "furnace_sphere.json"])
@pytest.mark.parametrize("max_depth", [-1, 0, 1, 3])
def test_furnace_closed_form(scene: str, max_depth: int) -> None:
    r = render(SCENES / scene, spp=32, integrator="lt", max_depth=max_depth, seed=11)
    assert r.spp == 32 and r.nonfinite == 0 and r.integrator == "lt"
    assert np.all(r.count == 16)  # sixteen batches of 2 light paths per pixel
    m = r.mean.reshape(-1, 3).astype(np.float64)
    v = r.variance.reshape(-1, 3).astype(np.float64)
    est, se = m.mean(axis=0), np.sqrt(v.sum(axis=0)) / len(m)
    want = furnace_closed_form(max_depth)
    assert np.all(np.abs(est - want) <= 5 * se + 1e-7), (est, want, se)


def test_reported_stderr_matches_the_spread_over_seeds() -> None:
    """The batch variance is honest: per pixel, the spread of 12 seeds' means against the reported variance."""
    runs = [render(SCENES / "furnace.json", spp=16, integrator="lt", max_depth=3, seed=s) for s in range(300, 312)]
    assert_variance_is_honest(runs)


def assert_variance_is_honest(runs: list) -> None:
    """The spread of the runs' (different seeds') means, summed over pixels, against their mean reported
    variance: a chi-square ratio with (runs - 1) x pixels degrees of freedom.  The reported variances are
    themselves estimates from a few batches: 15 % beyond the chi-square range is allowed."""
    means = np.stack([r.mean for r in runs]).astype(np.float64)
    reported = np.stack([r.variance for r in runs]).astype(np.float64).mean(axis=0)
    ratio = means.var(axis=0, ddof=1).sum() / reported.sum()
    dof = (len(runs) - 1) * means[0].size
    assert 0.85 * stats.chi2.ppf(1e-4, dof) / dof < ratio < 1.15 * stats.chi2.ppf(1 - 1e-4, dof) / dof, ratio


def test_lt_agrees_with_mis_on_cornell() -> None:
    """8 x 8-pixel blocks of a 32 x 32 Cornell box: z-tests of every block and channel, Sidak-corrected.

    A block's variance is the sum of its pixels' reported variances over 64^2: exact for mis (pixels are
    independent), and for lt up to the covariance of pixels that one light path splats into (a few splats
    per path among 1024 pixels)."""
    cs = downscaled("cornell.json", 32)
    a = render(cs, spp=1024, integrator="mis", seed=1)
    # 64 batches: a variance estimate good enough for per-pixel z-scores too
    b = render(cs, spp=512, integrator="lt", seed=2, spp_per_block=8)
    assert b.nonfinite == 0
    assert_blocks_agree(a, b)
    # and per pixel the lt image has no wild outliers either
    assert_pixels_agree(a, b)


# The splat film's promises, for every integrator that splats (lt, bdpt).
SPLATTING = ("lt", "bdpt")


@pytest.mark.parametrize(("integrator", "sampler", "spp_per_block", "spp_limit"),
                         [*((i, "independent", 2, 15) for i in SPLATTING), ("bdpt", "sobol", 4, 30)])
def test_image_does_not_depend_on_how_blocks_are_launched(integrator: str, sampler: str, spp_per_block: int,
                                                          spp_limit: int) -> None:
    cs = downscaled("cornell.json", 16)
    job = RenderJob(scene_tables(cs), cs.width, cs.height, integrator, cs.max_depth, cs.rr_depth, seed=42,
                    spp_per_block=spp_per_block, spp_limit=spp_limit, bounding_sphere=(0.0, 0.0, 0.0, 1.0),
                    sampler=sampler)
    runner = job.runner(runtime.device_context())
    runner.per_launch = 3  # several launches share the scratch images inside one chunk too
    films = []
    for chunks in ([1] * 8, [3, 5], [8], [2, 1, 4, 1]):
        acc = Accumulator(job.stat_shape)
        first = 0
        for n in chunks:
            acc.add(first, runner.collect(runner.enqueue(first, n)))
            first += n
        films.append(acc.totals)
    for f in films[1:]:
        np.testing.assert_array_equal(f, films[0])
    assert films[0][..., 6].min() == 8  # eight batches, the last one partial
    assert films[0][..., 0].max() > 0


@pytest.mark.parametrize("integrator", SPLATTING)
def test_sub_devices_give_the_same_image(integrator: str) -> None:
    cs = downscaled("cornell.json", 12)
    one = render(cs, spp=8, seed=4, integrator=integrator, spp_per_block=2)
    two = render(cs, spp=8, seed=4, integrator=integrator, spp_per_block=2, split=2)
    np.testing.assert_array_equal(one.mean, two.mean)
    np.testing.assert_array_equal(one.variance, two.variance)


@pytest.mark.parametrize("integrator", SPLATTING)
def test_resumed_render_is_identical(tmp_path: Path, integrator: str) -> None:
    cs = downscaled("cornell.json", 16)
    whole = render(cs, spp=12, seed=7, integrator=integrator, spp_per_block=2)
    ckpt = tmp_path / "run.ckpt"

    part = render(cs, spp=12, seed=7, integrator=integrator, spp_per_block=2, checkpoint=ckpt,
                  progress=interrupt_after_first_fold())
    assert part.stopped_by == "interrupt" and 0 < part.spp < 12
    rest = render(cs, spp=12, seed=7, integrator=integrator, resume=ckpt)
    assert rest.spp == 12 and rest.spp_this_run == 12 - part.spp
    np.testing.assert_array_equal(rest.mean, whole.mean)
    np.testing.assert_array_equal(rest.variance, whole.variance)


def test_noise_halting_uses_the_batch_variance() -> None:
    r = render(SCENES / "furnace.json", target_error=0.05, integrator="lt", max_depth=3, seed=3, spp_per_block=1)
    assert r.stopped_by == "noise" and r.relative_error <= 0.05
    assert r.count.min() >= 2


def test_specular_surfaces_seen_directly_are_black() -> None:
    """What light tracing cannot see: a mirror in front of the pinhole (documented in kernels/render/lt.cl)."""
    scene = {
        "camera": {"origin": [0, 0, 3], "target": [0, 0, 0], "fov": 20, "width": 8, "height": 8},
        "materials": {"mirror": {"type": "conductor"}, "white": {"type": "diffuse", "reflectance": 0.8}},
        "shapes": [
            {"name": "mirror", "type": "rectangle", "material": "mirror", "transform": [{"scale": [3, 3, 1]}]},
            {"name": "lamp", "type": "sphere", "material": "white", "center": [0, 0, 3.5], "radius": 0.3,
             "emitter": {"type": "area", "radiance": [1, 1, 1]}},
        ],
    }
    cs = compile_scene(parse_scene(scene))
    path = render(cs, spp=64, integrator="path", seed=1)
    lt = render(cs, spp=64, integrator="lt", seed=1)
    assert path.mean.max() > 0.1  # path tracing sees the lamp in the mirror
    assert lt.mean.max() == 0.0


def test_thin_lens_lt_agrees_with_mis_and_blurs() -> None:
    """Depth of field: lt (connections to lens points) and mis (rays from lens points) agree per 8 x 8
    block, and the thin lens's image differs from the pinhole's where the box is out of focus."""
    sc = load_scene(SCENES / "cornell.json")
    sc.camera.width = sc.camera.height = 32
    pin = compile_scene(sc)
    sc.camera.aperture_radius, sc.camera.focus_distance = 0.15, 2.5
    cs = compile_scene(sc)
    # per-pixel z-tests: variances from independent samples, not 4 sobol batches
    a = render(cs, spp=1024, integrator="mis", seed=3, sampler="independent")
    b = render(cs, spp=512, integrator="lt", seed=4, spp_per_block=8)
    p = render(pin, spp=1024, integrator="mis", seed=3, sampler="independent")
    assert_blocks_agree(a, b)
    assert_pixels_agree(a, b)
    zp = (a.mean - p.mean) / np.sqrt(a.variance + p.variance)
    assert np.abs(zp).max() > 10  # edges blurred by the lens


@pytest.mark.parametrize("camera,match", [
    ({"aperture_radius": -0.1}, "camera.aperture_radius: must be >= 0"),
    ({"aperture_radius": 0.1, "focus_distance": 0}, "camera.focus_distance: must be > 0"),
    ({"aperture_radius": "wide"}, "camera.aperture_radius: expected a number"),
])
def test_bad_thin_lens_settings(camera: dict, match: str) -> None:
    from mcocl.errors import InputError

    with pytest.raises(InputError, match=match):
        parse_scene({**_emit_scene(), "camera": {**CAMERA, **camera}})


def test_thin_lens_focus_defaults_to_the_target() -> None:
    cs = compile_scene(parse_scene({**_emit_scene(), "camera": {**CAMERA, "aperture_radius": 0.1}}))
    dist = float(np.linalg.norm(np.array(CAMERA["origin"]) - np.array(CAMERA["target"])))
    assert cs.camera[1, 3] == np.float32(dist) and cs.camera[0, 3] == np.float32(0.1)
    pin = compile_scene(parse_scene(_emit_scene()))
    assert pin.camera[0, 3] == 0 and pin.camera[1, 3] == 0  # a pinhole's record is what it always was


def test_lt_agrees_with_mis_under_the_environment() -> None:
    """Emitter rays of every kind in a render: a constant environment (seen directly and through its disk),
    a spherical and a rectangular light over a diffuse floor, with a lens; 8 x 8 blocks as above."""
    scene = {
        "camera": {"origin": [0.0, 1.5, 4.0], "target": [0, 0, 0], "fov": 60, "width": 32, "height": 32,
                   "aperture_radius": 0.05},
        "materials": {"white": {"type": "diffuse", "reflectance": [0.7, 0.6, 0.5]},
                      "grey": {"type": "diffuse", "reflectance": 0.3}},
        "environment": {"type": "constant", "radiance": [0.3, 0.4, 0.5]},
        "shapes": [
            {"name": "floor", "type": "rectangle", "material": "white",
             "transform": [{"scale": [2, 2, 1]}, {"rotate": {"axis": [1, 0, 0], "angle": -90}}]},
            {"name": "ball", "type": "sphere", "material": "grey", "center": [0.6, 0.5, 0.0], "radius": 0.5},
            {"name": "lamp", "type": "sphere", "material": "grey", "center": [-0.8, 0.4, 0.5], "radius": 0.2,
             "emitter": {"type": "area", "radiance": [4, 4, 4]}},
        ],
    }
    cs = compile_scene(parse_scene(scene))
    a = render(cs, spp=1024, integrator="mis", max_depth=4, seed=5)
    b = render(cs, spp=512, integrator="lt", max_depth=4, seed=6, spp_per_block=8)
    assert_blocks_agree(a, b)
    assert np.isclose(a.mean.mean(), b.mean.mean(), rtol=0.02)


def test_mitsuba_thinlens(tmp_path: Path) -> None:
    from mcocl.errors import InputError

    def sensor(extra: str) -> Path:
        p = tmp_path / "s.xml"
        p.write_text('<scene version="3.0.0"><sensor type="thinlens"><float name="fov" value="40"/>' + extra
                     + '<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>'
                     '</film></sensor><shape type="cube"/></scene>')
        return p

    cs = compile_scene(sensor('<float name="aperture_radius" value="0.2"/><float name="focus_distance" value="3"/>'))
    assert cs.camera[0, 3] == np.float32(0.2) and cs.camera[1, 3] == np.float32(3.0)
    cs = compile_scene(sensor('<float name="aperture_radius" value="0.2"/>'))
    assert cs.camera[1, 3] == np.float32(1e4)  # Mitsuba's far_clip
    with pytest.raises(InputError, match="aperture_radius"):
        compile_scene(sensor(""))


def test_mitsuba_ptracer_is_lt(tmp_path: Path) -> None:
    p = tmp_path / "s.xml"
    p.write_text('<scene version="3.0.0"><integrator type="ptracer"><integer name="max_depth" value="4"/>'
                 '<integer name="samples_per_pass" value="1024"/></integrator>'
                 '<sensor type="perspective"><float name="fov" value="40"/></sensor><shape type="cube"/></scene>')
    cs = compile_scene(p)
    assert (cs.integrator, cs.max_depth, cs.rr_depth) == ("lt", 4, 5)
