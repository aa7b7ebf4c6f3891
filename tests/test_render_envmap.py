"""The environment map (mcocl/render/envmap.py, kernels/render/envmap.cl).

- Sampling: chi-square of sampled directions over half-cells of the table
  (expected counts: the exact cell masses, uniform within a cell), the
  sampler's reported density against the evaluated one and the host's, the
  density integrating to 1 over the sphere, the bilinear lookup against the
  host's, and Mitsuba's orientation (+y up, the centre column along +z).
- Furnace-like: a uniform map renders like the constant environment.
- Agreement: path, nee, mis, lt and bdpt on a small scene under a map with
  a bright sun, and under a uniform map and the constant environment, in
  8 x 8-pixel blocks.
- Scene files and Mitsuba XML: the envmap keys and errors.  (Against Mitsuba 3 itself:
  tests/data/mitsuba/envmap_scene.xml in tests/test_mitsuba_references.py.)
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pyopencl as cl
import pytest
from chi2 import Chi2Family
from scipy import stats

from mcocl import runtime
from mcocl.cli import main
from mcocl.errors import InputError
from mcocl.render import transform as tf
from mcocl.render.api import render
from mcocl.render.compiled import compile_scene
from mcocl.render.envmap import EnvMap, envmap_pdf_np, envmap_radiance_np, envmap_tables
from mcocl.render.image_io import write_exr
from mcocl.render.scene import parse_scene
from mcocl.render.scene_file import load_scene

FAMILY = Chi2Family("envmap directions", 2)
N = 1 << 18


def sky_image(h: int = 16, w: int = 32) -> np.ndarray:
    """A dim, noisy sky with a small bright sun (strongly non-uniform: importance sampling matters)."""
    rng = np.random.default_rng(1)
    img = np.full((h, w, 3), 0.4, np.float32) + rng.random((h, w, 3)).astype(np.float32) * 0.3
    img[3:5, 20:23] = [40, 30, 20]
    img[h - 1] = 0.0  # a black bottom row: cells next to it keep mass, none is all black
    return img


class EnvKernels:
    """The test kernels of envmap_test.cl for one map."""

    def __init__(self, env: EnvMap, lanes: int = 8) -> None:
        self.env = env
        self.ctx = runtime.device_context()
        self.lanes = lanes
        prg = runtime.build(self.ctx, runtime.compose(["render/envmap_test.cl"]), [f"-DLANES={lanes}"],
                            what="envmap test kernels")
        self.prg = prg
        tex, cdf = envmap_tables(env)
        mf = cl.mem_flags
        self.tex = cl.Buffer(self.ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=tex)
        self.cdf = cl.Buffer(self.ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=cdf)

    def samples(self, n: int = N, seed: int = 4) -> dict[str, np.ndarray]:
        out = np.empty((8, n), np.float32)
        bo = cl.Buffer(self.ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
        g, lsz = self.ctx.work_size(n // self.lanes)
        runtime.kernel(self.prg, "envmap_samples")(self.ctx.queue, g, lsz, self.tex, self.cdf, np.uint64(seed),
                                                   np.uint32(n), bo)
        cl.enqueue_copy(self.ctx.queue, out, bo)
        o = out.astype(np.float64)
        return {"d": o[0:3].T, "pdf": o[3], "pdf_eval": o[4], "radiance": o[5:8].T}

    def eval(self, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n0 = len(dirs)
        n = -(-n0 // 16) * 16
        d = np.zeros((3, n), np.float32)
        d[:, :n0] = dirs.T
        d[1, n0:] = 1.0
        mf = cl.mem_flags
        bd = cl.Buffer(self.ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=d)
        out = np.empty((4, n), np.float32)
        bo = cl.Buffer(self.ctx.context, mf.WRITE_ONLY, out.nbytes)
        g, lsz = self.ctx.work_size(n // self.lanes)
        runtime.kernel(self.prg, "envmap_eval")(self.ctx.queue, g, lsz, self.tex, self.cdf, np.uint32(n), bd, bo)
        cl.enqueue_copy(self.ctx.queue, out, bo)
        o = out[:, :n0].astype(np.float64)
        return o[0], o[1:4].T


ROTATED = tf.compose([tf.rotate([0, 1, 0], 70), tf.rotate([1, 0, 0], 30)])


@pytest.fixture(scope="module", params=["identity", "rotated"])
def kern(request) -> EnvKernels:
    m = np.eye(4) if request.param == "identity" else ROTATED
    return EnvKernels(EnvMap(sky_image(), 1.5, m))


def _local_uv(env: EnvMap, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    local = d @ np.asarray(env.matrix)[:3, :3]
    u = np.mod(np.arctan2(local[:, 0], -local[:, 2]) / (2 * math.pi) - 0.5 / env.image.shape[1], 1.0)
    v = np.arccos(np.clip(local[:, 1], -1, 1)) / math.pi
    return u, v


def test_directions_follow_the_table(kern) -> None:
    s = kern.samples()
    h, w = kern.env.image.shape[:2]
    na, nb = h - 1, w
    _, cdf = envmap_tables(kern.env)
    mass = (np.diff(cdf[:na + 1].astype(np.int64))[:, None]
            * np.diff(cdf[na + 1:].astype(np.int64).reshape(na, nb + 1), axis=1)) / float(1 << 23) ** 2
    u, v = _local_uv(kern.env, s["d"])
    # half-cells: the density is uniform in (u, v) within a cell
    i = np.minimum((v * na * 2).astype(np.int64), 2 * na - 1)
    j = np.minimum((u * nb * 2).astype(np.int64), 2 * nb - 1)
    obs = np.bincount(i * 2 * nb + j, minlength=4 * na * nb).astype(float)
    exp = np.repeat(np.repeat(mass, 2, axis=0), 2, axis=1).ravel() / 4 * len(u)
    FAMILY.check(f"half-cells {kern.env.matrix[0, 0]:.3f}", obs, exp)


def test_reported_density_matches_evaluation(kern) -> None:
    s = kern.samples(1 << 14)
    ok = s["pdf"] > 0
    assert ok.mean() > 0.999
    np.testing.assert_allclose(s["pdf_eval"][ok], s["pdf"][ok], rtol=2e-3)
    np.testing.assert_allclose(envmap_pdf_np(kern.env, s["d"][ok]), s["pdf"][ok], rtol=2e-3)
    np.testing.assert_allclose(np.linalg.norm(s["d"], axis=1), 1.0, atol=1e-5)


def test_density_integrates_to_one_and_lookup_matches_host(kern) -> None:
    rng = np.random.default_rng(3)
    d = rng.normal(size=(1 << 16, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    pdf, rad = kern.eval(d)
    x = pdf * 4 * math.pi  # E[4 pi pdf(d)] = 1 for uniform d
    assert abs(x.mean() - 1) < 5 * x.std() / math.sqrt(len(x)), (x.mean(), x.std() / math.sqrt(len(x)))
    np.testing.assert_allclose(pdf, envmap_pdf_np(kern.env, d), rtol=2e-3, atol=1e-6)
    np.testing.assert_allclose(rad, envmap_radiance_np(kern.env, d), rtol=1e-4, atol=1e-5)


def test_mitsuba_orientation() -> None:
    """+y is the top row, +z the centre column, +x a quarter of the way across, -z the seam (Mitsuba 3's envmap)."""
    h, w = 9, 8
    img = np.zeros((h, w, 3), np.float32)
    img[0] = [1, 0, 0]  # top row
    img[4, 3:5] = [0, 1, 0]  # centre: u = 1/2 between texels 3 and 4, v = 1/2
    img[4, 1:3] = [0, 0, 1]  # u = 1/4
    img[4, 0] = img[4, 7] = [1, 1, 1]  # u = 0: the seam
    k = EnvKernels(EnvMap(img, 1.0, np.eye(4)), lanes=1)
    _, rad = k.eval(np.array([[0, 1.0, 0], [0, 0, 1.0], [1.0, 0, 0], [0, 0, -1.0]]))
    np.testing.assert_allclose(rad, np.vstack([np.eye(3), np.ones(3)]), atol=1e-5)


# ---- renders ----------------------------------------------------------------------


def _scene(folder: Path, environment: dict, size: int = 16) -> dict:
    return {
        "camera": {"origin": [0, 1.5, 3], "target": [0, 0.3, 0], "up": [0, 1, 0], "fov": 60,
                   "width": size, "height": size},
        "integrator": {"type": "mis", "max_depth": 3},
        "materials": {"white": {"type": "diffuse", "reflectance": 0.6},
                      "metal": {"type": "roughconductor", "alpha": 0.3}},
        "shapes": [
            {"type": "rectangle", "material": "white",
             "transform": [{"scale": 2}, {"rotate": {"axis": [1, 0, 0], "angle": -90}}]},
            {"type": "sphere", "material": "metal", "center": [0, 0.5, 0], "radius": 0.5},
        ],
        "environment": environment,
    }


def _blocks_agree(a, b, what: str) -> None:
    h, w = a.mean.shape[:2]
    dm = (a.mean - b.mean).astype(np.float64).reshape(h // 8, 8, w // 8, 8, 3).mean(axis=(1, 3))
    dv = (a.variance + b.variance).astype(np.float64).reshape(h // 8, 8, w // 8, 8, 3).sum(axis=(1, 3)) / 64**2
    z = np.abs(dm / np.sqrt(dv))
    assert 2 * stats.norm.sf(z.max()) > 1 - (1 - 1e-3) ** (1 / z.size), (what, z.max())


def test_uniform_map_renders_like_the_constant_environment(tmp_path: Path) -> None:
    rgb = [0.3, 0.4, 0.5]
    write_exr(tmp_path / "flat.exr", np.tile(np.float32(rgb), (4, 8, 1)))
    const = compile_scene(parse_scene(_scene(tmp_path, {"type": "constant", "radiance": rgb}), tmp_path / "s.json"))
    emap = compile_scene(parse_scene(_scene(tmp_path, {"type": "envmap", "filename": "flat.exr"}),
                                     tmp_path / "s.json"))
    ref = render(const, spp=256, integrator="mis", seed=1)
    for integ, spp in (("path", 256), ("mis", 256), ("nee", 256)):
        _blocks_agree(ref, render(emap, spp=spp, integrator=integ, seed=2), integ)
    _blocks_agree(ref, render(emap, spp=512, integrator="lt", seed=3, spp_per_block=8), "lt")
    # bdpt under both: escaped camera rays end at infinity, light paths start on the disk
    _blocks_agree(ref, render(const, spp=128, integrator="bdpt", seed=4, spp_per_block=4), "bdpt constant")
    _blocks_agree(ref, render(emap, spp=128, integrator="bdpt", seed=5, spp_per_block=4), "bdpt map")


def test_integrators_agree_under_a_sky_with_a_sun(tmp_path: Path) -> None:
    write_exr(tmp_path / "sky.exr", sky_image())
    env = {"type": "envmap", "filename": "sky.exr", "scale": 0.5,
           "transform": [{"rotate": {"axis": [0, 1, 0], "angle": 40}}]}
    cs = compile_scene(parse_scene(_scene(tmp_path, env), tmp_path / "s.json"))
    assert cs.env_pmf == 1.0  # the map is the only light: every light sample goes to it, mis included
    ref = render(cs, spp=512, integrator="mis", seed=1)
    assert ref.nonfinite == 0
    for integ, spp in (("path", 1024), ("nee", 256)):
        _blocks_agree(ref, render(cs, spp=spp, integrator=integ, seed=2), integ)
    _blocks_agree(ref, render(cs, spp=1024, integrator="lt", seed=3, spp_per_block=16), "lt")
    _blocks_agree(ref, render(cs, spp=256, integrator="bdpt", seed=4, spp_per_block=4), "bdpt")


def test_envmap_share_with_other_lights(tmp_path: Path) -> None:
    write_exr(tmp_path / "sky.exr", sky_image())
    s = _scene(tmp_path, {"type": "envmap", "filename": "sky.exr"})
    s["lights"] = [{"type": "point", "position": [0, 2, 0], "intensity": 1}]
    cs = compile_scene(parse_scene(s, tmp_path / "s.json"))
    assert cs.env_pmf == 0.5 and cs.env_threshold == 0.5


# ---- files ------------------------------------------------------------------------


@pytest.mark.parametrize("env, message", [
    ({"type": "envmap"}, "environment.filename: missing required key"),
    ({"type": "envmap", "filename": "none.exr"}, "not found"),
    ({"type": "envmap", "filename": "sky.hdr"}, "sky.hdr: no end of the header"),
    ({"type": "envmap", "filename": "sky.png"}, "read from OpenEXR .* or Radiance"),
    ({"type": "envmap", "filename": "../sky.exr"}, "outside the scene's folder"),
    ({"type": "envmap", "filename": "sky.exr", "scale": -1}, "environment.scale: must be >= 0"),
    ({"type": "envmap", "filename": "sky.exr", "transform": [{"scale": 2}]}, "must be a rotation"),
    ({"type": "envmap", "filename": "sky.exr", "radiance": 1}, "environment.radiance: unknown key"),
    ({"type": "sky"}, "environment.type: unknown value 'sky'"),
])
def test_bad_envmaps_are_rejected(tmp_path: Path, env: dict, message: str) -> None:
    sub = tmp_path / "scene"
    sub.mkdir()
    write_exr(sub / "sky.exr", sky_image(4, 8))
    write_exr(tmp_path / "sky.exr", sky_image(4, 8))
    (sub / "sky.hdr").write_bytes(b"#?RADIANCE\n")
    (sub / "sky.png").write_bytes(b"")
    with pytest.raises(InputError, match=message):
        parse_scene(_scene(sub, env), sub / "s.json")


def test_bad_pixels_are_rejected(tmp_path: Path) -> None:
    img = sky_image(4, 8)
    img[1, 2, 0] = np.nan
    write_exr(tmp_path / "nan.exr", img)
    with pytest.raises(InputError, match=r"pixel \(2, 1\) channel R is nan"):
        parse_scene(_scene(tmp_path, {"type": "envmap", "filename": "nan.exr"}), tmp_path / "s.json")




XML = """<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="60"/>
    <transform name="to_world"><lookat origin="0, 1.5, 3" target="0, 0.3, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
  </sensor>
  <shape type="sphere"><point name="center" x="0" y="0.5" z="0"/><float name="radius" value="0.5"/></shape>
  <emitter type="envmap"><string name="filename" value="sky.exr"/><float name="scale" value="0.5"/>
    <transform name="to_world"><rotate y="1" angle="40"/></transform></emitter>
</scene>
"""


def test_mitsuba_envmap_reads_into_the_same_tables(tmp_path: Path) -> None:
    write_exr(tmp_path / "sky.exr", sky_image())
    (tmp_path / "s.xml").write_text(XML)
    cs = compile_scene(load_scene(tmp_path / "s.xml"))
    want = EnvMap(sky_image(), 0.5, tf.rotate([0, 1, 0], 40))
    a, b = envmap_tables(cs.env_map), envmap_tables(want)
    np.testing.assert_allclose(a[0], b[0], rtol=1e-6, atol=1e-7)
    np.testing.assert_array_equal(a[1], b[1])
    converted = json.loads(json.dumps(cs.env_map.filename))
    assert converted == "sky.exr"


def test_convert_rewrites_the_image_path(tmp_path: Path) -> None:
    write_exr(tmp_path / "sky.exr", sky_image())
    (tmp_path / "s.xml").write_text(XML)
    (tmp_path / "out").mkdir()
    assert main(["convert", str(tmp_path / "s.xml"), "-o", str(tmp_path / "out" / "s.json")]) == 0
    data = json.loads((tmp_path / "out" / "s.json").read_text())
    assert data["environment"]["filename"] == "../sky.exr"
    converted = compile_scene(load_scene(tmp_path / "out" / "s.json", mesh_folder=tmp_path))
    direct = compile_scene(load_scene(tmp_path / "s.xml"))
    for a, b in zip(envmap_tables(converted.env_map), envmap_tables(direct.env_map)):
        np.testing.assert_array_equal(a, b)
