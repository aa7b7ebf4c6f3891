"""Emitter sampling for next-event estimation (kernels/render/lights.cl).

From a fixed point, light samples are drawn and checked against independent
NumPy references:

- the emitter choice (chi-square over the primitives and the environment)
  against power = luminance * area * pi, computed here from the geometry;
- each technique's distribution (chi-square against exact expected counts):
  uniform area on triangles (barycentric cells), uniform solid angle in the
  cone a sphere subtends, uniform area on a sphere seen from inside, uniform
  directions for the environment;
- the reported pdf against the closed forms (d^2 / (A cos) / cone);
- the MIS consistency: the pdf light_pdf_hit gives for the direction of a
  sample (what a BSDF-sampled ray hitting that point is weighted with) equals
  the pdf of the sample.
"""

from __future__ import annotations

import math

import numpy as np
import pyopencl as cl
import pytest
from chi2 import Chi2Family

from mcocl import runtime
from mcocl.render.compiled import LUMINANCE, compile_scene
from mcocl.render.device_scene import LIGHT_BVH_ABSENT, scene_buffers, scene_params, scene_tables
from mcocl.render.scene import parse_scene

N = 1 << 17
P = np.array([0.1, -0.2, 0.05])


def _camera() -> dict:
    return {"origin": [0, 0, 5], "target": [0, 0, 0], "fov": 40, "width": 8, "height": 8}


def _outside_scene() -> dict:
    """Lights around P that do not overlap as seen from P, plus the environment."""
    return {
        "camera": _camera(),
        "materials": {"m": {"type": "diffuse", "reflectance": 0.5}},
        "environment": {"type": "constant", "radiance": [0.05, 0.1, 0.2]},
        "shapes": [
            # a rectangle 2 above P facing down (-z front after the rotation): seen from the front
            {"name": "rect", "type": "rectangle", "material": "m",
             "transform": [{"scale": [0.6, 0.4, 1]}, {"rotate": {"axis": [1, 0, 0], "angle": 180}},
                           {"translate": [0.2, 0.1, 2.0]}],
             "emitter": {"type": "area", "radiance": [4.0, 3.0, 2.0]}},
            {"name": "small-sphere", "type": "sphere", "material": "m", "center": [3.0, 0.5, 0.0], "radius": 0.4,
             "emitter": {"type": "area", "radiance": [10.0, 10.0, 10.0]}},
            {"name": "big-sphere", "type": "sphere", "material": "m", "center": [-2.5, -1.0, 0.3], "radius": 1.2,
             "emitter": {"type": "area", "radiance": [0.5, 0.8, 1.0]}},
            # a triangle below P whose front faces away from P: its samples must come back invalid
            {"name": "away", "type": "mesh", "material": "m",
             "vertices": [[-0.5, -0.5, -2.0], [0.5, -0.5, -2.0], [0.0, 0.6, -2.0]], "faces": [[0, 1, 2]],
             "emitter": {"type": "area", "radiance": [1.0, 1.0, 1.0]}},
        ],
    }


# the emitter choice, the three triangles (the rectangle's two and "away") and the
# two spheres of the outside scene, the environment, and the sphere seen from inside
FAMILY = Chi2Family("light sampling", 1 + 3 + 2 + 1 + 1)


def _inside_scene() -> dict:
    """P inside a spherical emitter whose normals point inwards."""
    return {
        "camera": _camera(),
        "materials": {"m": {"type": "diffuse", "reflectance": 0.5}},
        "shapes": [{"name": "shell", "type": "sphere", "material": "m", "center": [0.3, 0.0, -0.2], "radius": 1.5,
                    "flip_normals": True, "emitter": {"type": "area", "radiance": [1.0, 2.0, 3.0]}}],
    }


class LightKernels:
    """The test kernels of light_sample_test.cl bound to one compiled scene."""

    def __init__(self, scene: dict, lanes: int = 8) -> None:
        # nee: the integrator whose light sampling takes a share for the environment (emitter_choice.py)
        self.cs = compile_scene(parse_scene(scene), integrator="nee")
        self.t = scene_tables(self.cs)
        self.ctx = runtime.device_context()
        self.lanes = lanes
        src = runtime.compose(["render/light_sample_test.cl"])
        self.prg = runtime.build(self.ctx, src, [f"-DLANES={lanes}"], what="light test kernels")
        self.names = ("bvh_nodes", "tri_rows", "spheres", "sphere_flip", "prim_rec",
                      "emitter_radiance", "light_rec", "light_cdf", "light_bvh", "light_trail")
        mf = cl.mem_flags
        self.buf = {**{k: cl.Buffer(self.ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a)
                       for k, a in LIGHT_BVH_ABSENT.items()}, **scene_buffers(self.cs, self.ctx)}

    def _args(self) -> list:
        return [scene_params(self.t), *(self.buf[k] for k in self.names)]

    def sample(self, p: np.ndarray, n: int = N, seed: int = 7) -> dict[str, np.ndarray]:
        out = np.empty((13, n), np.float32)
        bo = cl.Buffer(self.ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
        g, lsz = self.ctx.work_size(n // self.lanes)
        p4 = np.array([*p, 0.0], np.float32)
        runtime.kernel(self.prg, "light_sample_dirs")(self.ctx.queue, g, lsz, *self._args(), p4, np.uint64(seed),
                                                      np.uint32(n), bo)
        cl.enqueue_copy(self.ctx.queue, out, bo)
        return {"wo": out[0:3].T.copy(), "pdf": out[3].astype(np.float64), "radiance": out[4:7].T.copy(),
                "valid": out[7] != 0, "env": out[8] != 0, "prim": out[9].astype(np.int64), "pos": out[10:13].T.copy()}

    def pdf(self, p: np.ndarray, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n0 = len(wo)
        n = -(-n0 // 16) * 16
        w = np.zeros((3, n), np.float32)
        w[:, :n0] = wo.T
        w[2, n0:] = 1.0
        mf = cl.mem_flags
        bw = cl.Buffer(self.ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=w)
        out = np.empty((3, n), np.float32)
        bo = cl.Buffer(self.ctx.context, mf.WRITE_ONLY, out.nbytes)
        g, lsz = self.ctx.work_size(n // self.lanes)
        p4 = np.array([*p, 0.0], np.float32)
        runtime.kernel(self.prg, "light_pdf_dirs")(self.ctx.queue, g, lsz, *self._args(), p4, np.uint32(n), bw, bo)
        cl.enqueue_copy(self.ctx.queue, out, bo)
        return out[0, :n0].astype(np.float64), out[1, :n0].astype(np.int64), out[2, :n0] != 0


@pytest.fixture(scope="module")
def outside() -> tuple[LightKernels, dict]:
    k = LightKernels(_outside_scene())
    return k, k.sample(P)


def _prim_powers(cs) -> tuple[np.ndarray, np.ndarray]:
    """Light primitives and their power (luminance * area * pi), from the geometry (float64)."""
    prims, power = [], []
    tris = cs.tri_vertices[:, :, :3].astype(np.float64)
    for prim in range(cs.num_triangles + cs.num_spheres):
        e = cs.shape_emitter[cs.prim_shape[prim]]
        if e < 0:
            continue
        lum = float(cs.emitter_radiance[e, :3].astype(np.float64) @ LUMINANCE)
        if prim < cs.num_triangles:
            v = tris[prim]
            area = 0.5 * np.linalg.norm(np.cross(v[1] - v[0], v[2] - v[0]))
        else:
            area = 4 * math.pi * float(cs.spheres[prim - cs.num_triangles, 3]) ** 2
        prims.append(prim)
        power.append(lum * area * math.pi)
    return np.array(prims), np.array(power)


def test_emitter_choice_is_proportional_to_power(outside) -> None:
    k, s = outside
    prims, power = _prim_powers(k.cs)
    env_pmf = float(k.t["env_choice"][1])
    assert 0 < env_pmf < 1
    probs = (1 - env_pmf) * power / power.sum()
    observed = [int(np.sum(~s["env"] & (s["prim"] == p))) for p in prims] + [int(s["env"].sum())]
    expected = list(N * probs) + [N * env_pmf]
    assert sum(observed) == N
    FAMILY.check("emitter choice", observed, expected)
    # the exact grid probabilities the kernel divides by agree with the powers
    pmf = k.t["prim_pmf"][prims].astype(np.float64)
    np.testing.assert_allclose(pmf, power / power.sum(), rtol=1e-5, atol=2.5e-7)


def _tri_vertices(cs, prim: int) -> np.ndarray:
    return cs.tri_vertices[prim, :, :3].astype(np.float64)


def test_triangle_area_sampling_is_uniform(outside) -> None:
    k, s = outside
    for prim in range(k.cs.num_triangles):
        sel = ~s["env"] & (s["prim"] == prim)
        v = _tri_vertices(k.cs, prim)
        y = s["pos"][sel].astype(np.float64)
        # barycentrics of v1, v2 by least squares on the triangle's plane
        e = np.stack([v[1] - v[0], v[2] - v[0]], axis=1)
        b = np.linalg.lstsq(e, (y - v[0]).T, rcond=None)[0].T
        assert np.all(b > -1e-4) and np.all(b.sum(axis=1) < 1 + 1e-4)
        kk = 8  # cells of [0,1]^2: inside the triangle (area 1), on the diagonal (1/2), outside (0)
        i = np.clip(np.floor(b[:, 0] * kk), 0, kk - 1).astype(int)
        j = np.clip(np.floor(b[:, 1] * kk), 0, kk - 1).astype(int)
        obs = np.bincount(i * kk + j, minlength=kk * kk).astype(float)
        ii, jj = np.meshgrid(np.arange(kk), np.arange(kk), indexing="ij")
        w = np.where(ii + jj < kk - 1, 1.0, np.where(ii + jj == kk - 1, 0.5, 0.0)).ravel()
        FAMILY.check(f"triangle {prim}", obs, w / w.sum() * sel.sum())


def test_sphere_cone_sampling_is_uniform_in_solid_angle(outside) -> None:
    k, s = outside
    cs = k.cs
    for sph in range(cs.num_spheres):
        prim = cs.num_triangles + sph
        sel = ~s["env"] & (s["prim"] == prim)
        c = cs.spheres[sph, :3].astype(np.float64)
        r = float(cs.spheres[sph, 3])
        w = (c - P) / np.linalg.norm(c - P)
        sin2 = r * r / np.dot(c - P, c - P)
        omc = 1 - math.sqrt(1 - sin2)
        wo = s["wo"][sel].astype(np.float64)
        cos_t = wo @ w
        u = (1 - cos_t) / omc  # uniform in [0, 1] for a uniform solid angle in the cone
        a = np.cross(w, [0.0, 0.0, 1.0])
        a /= np.linalg.norm(a)
        b = np.cross(w, a)
        phi = np.arctan2(wo @ b, wo @ a)
        assert np.all(u > -1e-3) and np.all(u < 1 + 1e-3)
        nu, nphi = 10, 12
        iu = np.clip(np.floor(u * nu), 0, nu - 1).astype(int)
        ip = np.clip(np.floor((phi + np.pi) / (2 * np.pi) * nphi), 0, nphi - 1).astype(int)
        obs = np.bincount(iu * nphi + ip, minlength=nu * nphi).astype(float)
        FAMILY.check(f"sphere {sph}", obs, np.full(nu * nphi, sel.sum() / (nu * nphi)))
        # the pdf is the cone's, times the choice probability
        pmf = float(k.t["prim_pmf"][prim]) * (1 - float(k.t["env_choice"][1]))
        np.testing.assert_allclose(s["pdf"][sel], pmf / (2 * math.pi * omc), rtol=2e-3)
        assert np.all(s["valid"][sel])


def test_environment_sampling_is_uniform(outside) -> None:
    k, s = outside
    sel = s["env"]
    wo = s["wo"][sel].astype(np.float64)
    n_cos, n_phi = 10, 16
    i = np.clip(np.floor((wo[:, 2] + 1) / 2 * n_cos), 0, n_cos - 1).astype(int)
    j = np.clip(np.floor((np.arctan2(wo[:, 1], wo[:, 0]) + np.pi) / (2 * np.pi) * n_phi), 0, n_phi - 1).astype(int)
    obs = np.bincount(i * n_phi + j, minlength=n_cos * n_phi).astype(float)
    FAMILY.check("environment", obs, np.full(n_cos * n_phi, sel.sum() / (n_cos * n_phi)))
    np.testing.assert_allclose(s["pdf"][sel], float(k.t["env_choice"][1]) / (4 * math.pi), rtol=1e-6)
    np.testing.assert_allclose(s["radiance"][sel], np.tile([0.05, 0.1, 0.2], (sel.sum(), 1)), rtol=1e-6)


def test_triangle_pdf_closed_form_and_one_sidedness(outside) -> None:
    k, s = outside
    cs = k.cs
    env_pmf = float(k.t["env_choice"][1])
    for prim in range(cs.num_triangles):
        sel = ~s["env"] & (s["prim"] == prim)
        v = _tri_vertices(cs, prim)
        cr = np.cross(v[1] - v[0], v[2] - v[0])
        area = 0.5 * np.linalg.norm(cr)
        n = cr / np.linalg.norm(cr)
        d = s["pos"][sel].astype(np.float64) - P
        dist2 = np.sum(d * d, axis=1)
        cos_l = -(d @ n) / np.sqrt(dist2)
        front = cos_l > 0
        assert np.all(front) or not np.any(front)  # one flat triangle is seen from one side only
        if front.all():
            pmf = float(k.t["prim_pmf"][prim]) * (1 - env_pmf)
            np.testing.assert_allclose(s["pdf"][sel], pmf * dist2 / (area * cos_l), rtol=1e-3)
            assert np.all(s["valid"][sel])
        else:  # seen from behind: no radiance, the sample is discarded
            assert not np.any(s["valid"][sel]) and np.all(s["radiance"][sel] == 0)


def test_pdf_of_a_hit_equals_pdf_of_the_sample(outside) -> None:
    """light_pdf_hit (the MIS weight of a BSDF-sampled ray) reproduces every light sample's pdf."""
    k, s = outside
    area = s["valid"] & ~s["env"]
    pdf, prim, escaped = k.pdf(P, s["wo"][area])
    other = prim != s["prim"][area]
    # a sample on the diagonal of the rectangle may be found on its twin triangle (same shape, same pdf)
    shape = k.cs.prim_shape
    assert other.sum() < 1e-4 * area.sum() and np.all(shape[prim[other]] == shape[s["prim"][area][other]])
    np.testing.assert_allclose(pdf, s["pdf"][area], rtol=2e-3)
    env = s["env"]
    _, prim_e, esc_e = k.pdf(P, s["wo"][env][:4096])
    # environment directions either escape or are blocked by a light (then the shadow ray is occluded)
    assert np.all(esc_e | (prim_e >= 0))


def test_sampling_a_sphere_from_inside() -> None:
    k = LightKernels(_inside_scene())
    p = np.array([0.2, -0.3, 0.1])
    s = k.sample(p)
    cs = k.cs
    c = cs.spheres[0, :3].astype(np.float64)
    r = float(cs.spheres[0, 3])
    y = s["pos"].astype(np.float64)
    q = (y - c) / r
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-5)
    # uniform on the sphere: z and phi of the unit point are uniform (Archimedes)
    nz, nphi = 10, 12
    i = np.clip(np.floor((q[:, 2] + 1) / 2 * nz), 0, nz - 1).astype(int)
    j = np.clip(np.floor((np.arctan2(q[:, 1], q[:, 0]) + np.pi) / (2 * np.pi) * nphi), 0, nphi - 1).astype(int)
    obs = np.bincount(i * nphi + j, minlength=nz * nphi).astype(float)
    FAMILY.check("sphere from inside", obs, np.full(nz * nphi, N / (nz * nphi)))
    # every point of the inner surface faces p: all valid, pdf = d^2 / (A cos)
    assert np.all(s["valid"])
    d = y - p
    dist2 = np.sum(d * d, axis=1)
    cos_l = np.sum(d * q, axis=1) / np.sqrt(dist2)  # the inward normal is -q
    np.testing.assert_allclose(s["pdf"], dist2 / (4 * math.pi * r * r * cos_l), rtol=1e-3)
    pdf, _, _ = k.pdf(p, s["wo"][:8192])
    np.testing.assert_allclose(pdf, s["pdf"][:8192], rtol=2e-3)


def test_lane_build_matches_scalar_build() -> None:
    a = LightKernels(_outside_scene(), lanes=1).sample(P, n=4096)
    b = LightKernels(_outside_scene(), lanes=8).sample(P, n=4096)
    for key in ("wo", "pdf", "valid", "env", "prim", "pos"):
        np.testing.assert_allclose(np.asarray(a[key], float), np.asarray(b[key], float), rtol=1e-4, atol=1e-5,
                                   err_msg=key)


