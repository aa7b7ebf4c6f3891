"""Textures (mcocl/render/textures.py, texture_table.py, shape_uvs.py; kernels/render/texture.cl).

- The kernel's bitmap lookups (nearest and bilinear, each wrap mode, to_uv)
  and the checkerboard agree with an independent NumPy lookup; the NumPy
  lookup itself reproduces values measured on Mitsuba 3.9 (scalar_rgb).
- The kernel's (u, v) at hits on the rectangle, cube, cylinder, disk and sphere
  are Mitsuba 3's, measured at the same points on Mitsuba 3.9.
- A checkerboard on a rectangle that fills the view, lit by a white
  environment through one diffuse bounce, renders each pixel as its square's
  colour; a checkerboard of one colour renders bit for bit as that constant.
- Light tracing and bdpt agree with mis on a textured scene (block z-tests).
- Mitsuba XML textures (nested and by <ref>) load, sharing one texture; bad
  texture files and keys give clear errors.
"""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pyopencl as cl
import pytest
from PIL import Image

import mcocl
from mcocl import runtime
from mcocl.errors import InputError
from mcocl.render.compiled import compile_scene
from mcocl.render.device_scene import scene_tables
from mcocl.render.job import RenderJob
from mcocl.render.scene_file import load_scene
from mcocl.render.texture_table import texture_table
from mcocl.render.textures import Texture, srgb_to_linear

WRAP_CODES = {"repeat": 0, "mirror": 1, "clamp": 2}


# ---------------------------------------------------------------- the NumPy reference lookup

def wrap_index(i: np.ndarray, size: int, mode: str) -> np.ndarray:
    """Integer texel indices wrapped into [0, size) (repeat: modulo; mirror: period 2 size; clamp)."""
    if mode == "repeat":
        return np.mod(i, size)
    if mode == "clamp":
        return np.clip(i, 0, size - 1)
    m = np.mod(i, 2 * size)
    return np.where(m >= size, 2 * size - 1 - m, m)


def reference_lookup(tex: Texture, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(N, 3) float64: the texture at (u, v), computed directly from the definition (textures.py docstring)."""
    a, b, c, d, e, f = tex.to_uv
    su, sv = a * u + b * v + c, d * u + e * v + f
    if tex.kind == "checkerboard":
        odd = ((su - np.floor(su)) > 0.5) != ((sv - np.floor(sv)) > 0.5)
        return np.where(odd[:, None], tex.color1[None, :], tex.color0[None, :]).astype(np.float64)
    img = tex.image.astype(np.float64)
    h, w = img.shape[:2]
    if tex.filter_type == "nearest":
        x = wrap_index(np.floor(su * w).astype(np.int64), w, tex.wrap_mode)
        y = wrap_index(np.floor(sv * h).astype(np.int64), h, tex.wrap_mode)
        return img[y, x]
    px, py = su * w - 0.5, sv * h - 0.5
    x0, y0 = np.floor(px).astype(np.int64), np.floor(py).astype(np.int64)
    fx, fy = (px - x0)[:, None], (py - y0)[:, None]
    xs = [wrap_index(x0 + k, w, tex.wrap_mode) for k in (0, 1)]
    ys = [wrap_index(y0 + k, h, tex.wrap_mode) for k in (0, 1)]
    return ((1 - fy) * ((1 - fx) * img[ys[0], xs[0]] + fx * img[ys[0], xs[1]])
            + fy * ((1 - fx) * img[ys[1], xs[0]] + fx * img[ys[1], xs[1]]))


def test_reference_lookup_reproduces_mitsuba() -> None:
    # A 3 x 2 image (rows top first) looked up by Mitsuba 3.9's bitmap (scalar_rgb, raw) at these (u, v):
    # measured values, rounded to 4 digits.
    img = np.array([[[1, 0, 0], [0, 1, 0], [0, 0, 1]], [[1, 1, 0], [0, 1, 1], [1, 0, 1]]], np.float32)
    uv = np.array([(0.1, 0.1), (0.5, 0.9), (1.3, -0.2), (-0.45, 1.7), (2.9, 0.3)])
    measured = {
        ("repeat", "nearest"): [(1, 0, 0), (0, 1, 1), (1, 1, 0), (0, 1, 1), (0, 0, 1)],
        ("repeat", "bilinear"): [(0.86, 0.24, 0.2), (0, 1, 0.7), (0.6, 0.94, 0.36), (0.135, 0.85, 0.915),
                                 (0.28, 0.02, 0.8)],
        ("mirror", "nearest"): [(1, 0, 0), (0, 1, 1), (0, 0, 1), (0, 1, 0), (0, 0, 1)],
        ("mirror", "bilinear"): [(1, 0, 0), (0, 1, 1), (0, 0.4, 0.6), (0.15, 0.865, 0.085), (0.1, 0, 1)],
        ("clamp", "nearest"): [(1, 0, 0), (0, 1, 1), (0, 0, 1), (1, 1, 0), (0, 0, 1)],
        ("clamp", "bilinear"): [(1, 0, 0), (0, 1, 1), (0, 0, 1), (1, 1, 0), (0.1, 0, 1)],
    }
    for (wrap, filt), want in measured.items():
        tex = Texture("bitmap", image=img, filter_type=filt, wrap_mode=wrap)
        np.testing.assert_allclose(reference_lookup(tex, uv[:, 0], uv[:, 1]), want, atol=6e-5, err_msg=f"{wrap} {filt}")
    # Mitsuba's checkerboard defaults: 0.4 where frac(u) > 1/2 and frac(v) > 1/2 agree, else 0.2
    chk = Texture("checkerboard")
    got = reference_lookup(chk, np.array([0.1, 0.6, 0.1, 0.6]), np.array([0.1, 0.1, 0.6, 0.6]))[:, 0]
    np.testing.assert_allclose(got, [0.4, 0.2, 0.2, 0.4])


# ---------------------------------------------------------------- the kernel's lookups and (u, v)

class TextureKernels:
    """The kernels of texture_test.cl (one build for the module)."""

    def __init__(self, lanes: int = 8) -> None:
        self.ctx = runtime.device_context()
        self.lanes = lanes
        self.prg = runtime.build(self.ctx, runtime.compose(["render/texture_test.cl"]), [f"-DLANES={lanes}"],
                                 what="texture test kernels")

    def _run(self, name: str, args: list, cols: np.ndarray, nout: int) -> np.ndarray:
        n0 = cols.shape[1]
        n = -(-n0 // 16) * 16
        data = np.zeros((cols.shape[0], n), np.float32)
        data[:, :n0] = cols
        mf = cl.mem_flags
        bi = cl.Buffer(self.ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=data)
        out = np.empty((nout, n), np.float32)
        bo = cl.Buffer(self.ctx.context, mf.WRITE_ONLY, out.nbytes)
        g, lsz = self.ctx.work_size(n // self.lanes)
        runtime.kernel(self.prg, name)(self.ctx.queue, g, lsz, *args, np.uint32(n), bi, bo)
        cl.enqueue_copy(self.ctx.queue, out, bo)
        return out[:, :n0].astype(np.float64)

    def buffer(self, a: np.ndarray) -> cl.Buffer:
        return cl.Buffer(self.ctx.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR,
                         hostbuf=np.ascontiguousarray(a, np.float32))

    def lookup(self, table: np.ndarray, ids: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._run("texture_lookup", [self.buffer(table)], np.stack([u, v, ids]), 3).T

    def coordinates(self, table: np.ndarray, spheres: np.ndarray, ntris: int, prim, b1, b2, p) -> np.ndarray:
        sph = spheres if len(spheres) else np.zeros((1, 4), np.float32)
        cols = np.stack([prim, b1, b2, *np.asarray(p, np.float64).T])
        return self._run("texture_coordinates", [self.buffer(table), self.buffer(sph), np.uint32(ntris),
                                                 np.uint32(len(spheres))], cols, 2).T


@pytest.fixture(scope="module")
def kernels() -> TextureKernels:
    return TextureKernels()


def test_kernel_lookups_match_numpy(kernels) -> None:
    rng = np.random.default_rng(3)
    img = rng.random((5, 7, 3)).astype(np.float32)
    textures = [Texture("bitmap", image=img, filter_type=f, wrap_mode=w) for f in ("nearest", "bilinear")
                for w in WRAP_CODES]
    textures.append(Texture("bitmap", image=img, to_uv=(2.0, 0.5, 0.25, -0.3, 1.5, -0.1)))
    textures.append(Texture("checkerboard", color0=np.array([0.9, 0.1, 0.3]), color1=np.array([0.05, 0.6, 0.7]),
                            to_uv=(4.0, 0.0, 0.1, 0.0, 3.0, -0.2)))
    table = texture_table([SimpleNamespace(textures={"rgb": t}) for t in textures], [])
    n = 4000
    u, v = rng.uniform(-3, 3, n), rng.uniform(-3, 3, n)
    for k, tex in enumerate(textures):
        got = kernels.lookup(table, np.full(n, k), u, v)
        want = reference_lookup(tex, u.astype(np.float32).astype(np.float64), v.astype(np.float32).astype(np.float64))
        # float32 texel positions: a texel edge may round either way (nearest, checkerboard) in a few of 4000
        bad = np.abs(got - want).max(axis=1) > 2e-5
        assert bad.mean() < 2e-3, (k, tex.filter_type, tex.wrap_mode, np.flatnonzero(bad)[:5])


# Points on Mitsuba 3.9's shapes (local = world here) and the (u, v) its scalar_rgb variant reports there.
MITSUBA_UVS = {
    "rectangle": [((0.3, -0.5, 0.0), (0.65, 0.25))],
    "cube": [((0.3, -0.5, 1.0), (0.25, 0.65)), ((0.3, -0.5, -1.0), (0.75, 0.65)), ((1.0, 0.3, -0.5), (0.65, 0.75)),
             ((-1.0, 0.3, -0.5), (0.65, 0.25)), ((0.3, 1.0, -0.5), (0.35, 0.75)), ((0.3, -1.0, -0.5), (0.25, 0.65))],
    "cylinder": [((0.866026, -0.5, 0.3), (0.916667, 0.3)), ((0.866026, 0.5, 0.3), (0.0833334, 0.3))],
    "disk": [((0.3, 0.4, 0.0), (0.5, 0.147584)), ((0.0, -0.5, 0.0), (0.5, 0.75))],
    "sphere": [((0.3, 0.4, 0.866025), (0.147584, 1 / 6)), ((0.3, -0.4, 0.866025), (0.852416, 1 / 6))],
}


def _barycentric(tris: np.ndarray, p: np.ndarray) -> tuple[int, float, float]:
    """The triangle of ``tris`` (T, 3, 3) nearest to p (on it), and p's barycentrics b1, b2 there."""
    a, e1, e2 = tris[:, 0], tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    best = None
    for k in range(len(tris)):
        m = np.stack([e1[k], e2[k]], axis=1)
        b, *_ = np.linalg.lstsq(m, p - a[k], rcond=None)
        off = np.linalg.norm(m @ b - (p - a[k]))
        inside = b.min() >= -1e-6 and b.sum() <= 1 + 1e-6
        if inside and (best is None or off < best[0]):
            best = (off, k, b)
    assert best is not None and best[0] < 1e-3
    return best[1], float(best[2][0]), float(best[2][1])


def test_shape_uvs_are_mitsubas(kernels, tmp_path: Path) -> None:
    shapes = [{"type": kind, "material": "t"} for kind in MITSUBA_UVS]
    data = {"camera": {"origin": [0, 0, 5], "target": [0, 0, 0], "fov": 40, "width": 8, "height": 8},
            "materials": {"t": {"type": "diffuse", "reflectance": {"type": "checkerboard"}}}, "shapes": shapes}
    p = tmp_path / "shapes.json"
    p.write_text(json.dumps(data))
    cs = compile_scene(p)
    tris = cs.tri_vertices[:, :, :3].astype(np.float64)
    owner = cs.prim_shape[:cs.num_triangles]
    rows = []
    for k, (kind, cases) in enumerate(MITSUBA_UVS.items()):
        for point, uv in cases:
            if kind == "sphere":
                rows.append((cs.num_triangles, 0.0, 0.0, point, uv, 1e-5))
                continue
            ids = np.flatnonzero(owner == k)
            t, b1, b2 = _barycentric(tris[ids], np.array(point))
            # the disk is a fan of triangles: r is linear across one, phi nearly so
            rows.append((int(ids[t]), b1, b2, point, uv, 2e-3 if kind == "disk" else 1e-5))
    got = kernels.coordinates(cs.textures, cs.spheres, cs.num_triangles, np.array([r[0] for r in rows], np.float64),
                              np.array([r[1] for r in rows]), np.array([r[2] for r in rows]),
                              np.array([r[3] for r in rows]))
    for (prim, _, _, point, uv, tol), g in zip(rows, got):
        np.testing.assert_allclose(g, uv, atol=tol, err_msg=f"prim {prim} at {point}")


# ---------------------------------------------------------------- renders

def checker_scene(tmp_path: Path, color0, color1, name: str, textured: bool = True, light_sampler: str = "auto") -> Path:
    """A rectangle filling a 32 x 32 view (fov 90 at distance 1; it spans ±1.25), one diffuse bounce to a white sky.

    to_uv makes (u', v') = (x + 1, y + 1) in view: 4 x 4 squares of 8 x 8 pixels."""
    refl = ({"type": "checkerboard", "color0": color0, "color1": color1,
             "to_uv": [{"scale": [2.5, 2.5, 1]}, {"translate": [-0.25, -0.25, 0]}]} if textured else color0)
    data = {"camera": {"origin": [0, 0, 1], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 90, "width": 32,
                       "height": 32},
            "integrator": {"type": "path", "max_depth": 2, "light_sampler": light_sampler},
            "materials": {"m": {"type": "diffuse", "reflectance": refl}},
            "environment": {"type": "constant", "radiance": 1.0},
            "shapes": [{"type": "rectangle", "material": "m", "transform": [{"scale": [1.25, 1.25, 1]}]}]}
    p = tmp_path / name
    p.write_text(json.dumps(data))
    return p


def test_checkerboard_on_a_rectangle_is_analytic(tmp_path: Path) -> None:
    c0, c1 = [0.8, 0.3, 0.1], [0.1, 0.5, 0.7]
    # path samples no light, so the light sampler is incidental: bvh makes the build the one
    # tests/test_emitter_textures.py's path render takes (a build costs 7 to 10 s on a cold PoCL cache)
    img = mcocl.render(checker_scene(tmp_path, c0, c1, "c.json", light_sampler="bvh"), spp=16, seed=7)
    j = np.arange(32)
    qx = (j // 8) % 2 == 1  # frac(x + 1) > 1/2 in column square j // 8
    qy = ((31 - j) // 8) % 2 == 1  # row 0 is the top (y = +1)
    want = np.where((qy[:, None] == qx[None, :])[..., None], np.array(c0), np.array(c1))
    # each sample is the albedo exactly (cosine sampling, a white sky): the pixels equal it to float32 rounding
    np.testing.assert_allclose(img.mean, want, rtol=2e-6, atol=1e-7)


def test_constant_texture_renders_bit_for_bit_as_the_constant(tmp_path: Path) -> None:
    c = [0.7, 0.45, 0.2]
    plain = mcocl.render(checker_scene(tmp_path, c, c, "p.json", textured=False), spp=4, seed=3, integrator="mis")
    tex = mcocl.render(checker_scene(tmp_path, c, c, "t.json"), spp=4, seed=3, integrator="mis")
    assert np.array_equal(plain.mean, tex.mean) and np.array_equal(plain.stderr, tex.stderr)
    job = RenderJob(scene_tables(compile_scene(tmp_path / "p.json")), 32, 32, "mis", 2, 5, seed=1, spp_per_block=1)
    assert "-DTEXTURES" not in job.options(1) and "textures" not in job.tables


def textured_scene(tmp_path: Path) -> Path:
    """A checkerboard floor, a bitmap-textured glossy sphere, a rough glass sphere and an area light (bdpt
    takes no sky).  The rough glass makes the builds those of tests/test_render_dielectric_tints.py's
    textured glass (textures and rough refraction): a build costs 10 to 30 s on a cold cache."""
    img = (np.random.default_rng(0).random((4, 6, 3)) * 255).astype(np.uint8)
    Image.fromarray(img).save(tmp_path / "img.png")
    data = {"camera": {"origin": [0, -4, 2.5], "target": [0, 0, 0], "fov": 40, "width": 32, "height": 32},
            "integrator": {"type": "mis", "max_depth": 3},
            "materials": {"chk": {"type": "diffuse", "reflectance": {"type": "checkerboard", "color0": [0.9, 0.1, 0.1],
                                                                     "color1": 0.3, "to_uv": [{"scale": [2, 2, 1]}]}},
                          "bm": {"type": "roughconductor", "alpha": 0.3,
                                 "specular_reflectance": {"type": "bitmap", "filename": "img.png"}},
                          "frost": {"type": "roughdielectric", "alpha": 0.3},
                          "lamp": {"type": "diffuse", "reflectance": 0}},
            "shapes": [{"type": "rectangle", "material": "chk", "transform": [{"scale": [2, 2, 1]}]},
                       {"type": "sphere", "center": [0, 0, 0.5], "radius": 0.5, "material": "bm"},
                       {"type": "sphere", "center": [-1.0, -0.7, 0.3], "radius": 0.3, "material": "frost"},
                       {"type": "rectangle", "material": "lamp", "transform": [{"translate": [0, 0, 3]}],
                        "flip_normals": True, "emitter": {"type": "area", "radiance": 5}}]}
    p = tmp_path / "textured.json"
    p.write_text(json.dumps(data))
    return p


def block_z(a, b, block: int = 8) -> np.ndarray:
    """z of the difference of two renders' block means, per block and channel."""
    def blocks(x: np.ndarray) -> np.ndarray:
        h, w = x.shape[:2]
        return x.reshape(h // block, block, w // block, block, -1)

    ma, mb = blocks(a.mean).mean((1, 3)), blocks(b.mean).mean((1, 3))
    va = (blocks(a.stderr) ** 2).sum((1, 3)) / block**4
    vb = (blocks(b.stderr) ** 2).sum((1, 3)) / block**4
    return (ma - mb) / np.sqrt(va + vb + 1e-30)


def assert_splatting_agrees_with_mis(p: Path) -> None:
    """lt and bdpt (64 spp) agree with a 256-spp mis render of ``p`` per 8x8 block, |z| < 4.5."""
    ref = mcocl.render(p, spp=256, seed=1, integrator="mis")
    assert ref.mean.max() > 0.05
    for seed, integ in ((2, "lt"), (3, "bdpt")):
        img = mcocl.render(p, spp=64, seed=seed, integrator=integ, spp_per_block=8)
        z = block_z(img, ref)
        assert np.abs(z).max() < 4.5, (integ, np.round(z[..., 0], 1))


def test_light_tracing_and_bdpt_agree_with_mis_on_textures(tmp_path: Path) -> None:
    assert_splatting_agrees_with_mis(textured_scene(tmp_path))


# ---------------------------------------------------------------- files and errors

def write_xml(tmp_path: Path, body: str) -> Path:
    xml = f"""<scene version="3.0.0">
  <sensor type="perspective"><float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0,0,4" target="0,0,0" up="0,1,0"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
  {body}
</scene>"""
    p = tmp_path / "t.xml"
    p.write_text(xml)
    return p


def test_mitsuba_xml_textures(tmp_path: Path) -> None:
    Image.fromarray(np.full((2, 2, 3), 128, np.uint8)).save(tmp_path / "grey.png")
    p = write_xml(tmp_path, """
  <texture type="checkerboard" id="chk"><rgb name="color0" value="0.9,0.1,0.1"/>
    <transform name="to_uv"><scale x="4" y="4"/></transform></texture>
  <bsdf type="diffuse" id="a"><ref id="chk" name="reflectance"/></bsdf>
  <bsdf type="plastic" id="b"><ref id="chk" name="diffuse_reflectance"/></bsdf>
  <bsdf type="roughconductor" id="c"><texture type="bitmap" name="specular_reflectance">
      <string name="filename" value="grey.png"/><string name="filter_type" value="nearest"/>
      <string name="wrap_mode" value="clamp"/></texture>
    <texture type="bitmap" name="alpha"><string name="filename" value="grey.png"/>
      <boolean name="raw" value="true"/></texture></bsdf>
  <shape type="rectangle"><ref id="a"/></shape>
  <shape type="sphere"><ref id="b"/></shape>
  <shape type="cube"><ref id="c"/></shape>""")
    scene = load_scene(p)
    a, b, c = scene.materials
    assert a.textures["rgb"] is b.textures["rgb"]  # one texture, one copy of its texels
    assert a.textures["rgb"].to_uv == (4.0, 0.0, 0.0, 0.0, 4.0, 0.0)
    np.testing.assert_allclose(a.textures["rgb"].color1, 0.2)  # Mitsuba's default
    sr = c.textures["rgb"]
    assert (sr.filter_type, sr.wrap_mode) == ("nearest", "clamp")
    np.testing.assert_allclose(sr.image, srgb_to_linear(128 / 255), rtol=1e-6)  # 8-bit: sRGB-decoded
    np.testing.assert_allclose(c.textures["alpha"].image, 128 / 255, rtol=1e-6)  # raw
    cs = compile_scene(scene)
    assert cs.textures is not None and "textures" in scene_tables(cs)


@pytest.mark.parametrize("filename, content, match", [
    ("missing.png", None, "not found"),
    ("text.png", b"not an image", "not an image file"),
    ("sky.hdr", b"#?RADIANCE\n", "no end of the header"),
    ("/etc/passwd", None, "outside the scene's folder"),
    ("../up.png", None, "outside the scene's folder"),
])
def test_bad_texture_files(tmp_path: Path, filename: str, content: bytes | None, match: str) -> None:
    scene_dir = tmp_path / "scene"
    scene_dir.mkdir()
    if content is not None:
        (scene_dir / filename).write_bytes(content)
    if filename.startswith(".."):
        Image.fromarray(np.zeros((2, 2, 3), np.uint8)).save(tmp_path / "up.png")
    p = checker_scene(scene_dir, 0.5, 0.5, "bad.json")
    data = json.loads(p.read_text())
    data["materials"]["m"]["reflectance"] = {"type": "bitmap", "filename": filename}
    p.write_text(json.dumps(data))
    with pytest.raises(InputError, match=match) as e:
        load_scene(p)
    assert "materials.m.reflectance.filename" in str(e.value)


def test_texture_keys_are_checked(tmp_path: Path) -> None:
    p = checker_scene(tmp_path, 0.5, 0.5, "k.json")
    base = json.loads(p.read_text())
    cases = [({"type": "thindielectric", "ext_ior": {"type": "checkerboard"}}, "ext_ior"),
             ({"type": "dielectric", "int_ior": {"type": "checkerboard"}}, "int_ior"),
             ({"type": "diffuse", "reflectance": {"type": "wood"}}, "type"),
             ({"type": "diffuse", "reflectance": {"type": "bitmap"}}, "filename"),
             ({"type": "diffuse", "reflectance": {"type": "bitmap", "filename": "x.png", "wrap_mode": "tile"}},
              "wrap_mode"),
             ({"type": "roughconductor", "alpha": {"type": "checkerboard"}, "alpha_u": 0.1, "alpha_v": 0.2}, "alpha")]
    for mat, key in cases:
        base["materials"]["m"] = mat
        p.write_text(json.dumps(base))
        with pytest.raises(InputError, match=key):
            load_scene(p)


def test_convert_rewrites_texture_paths(tmp_path: Path) -> None:
    from mcocl.cli import main

    xml = Path(__file__).parent / "data" / "mitsuba" / "textures.xml"
    out = tmp_path / "out" / "t.json"
    out.parent.mkdir()
    assert main(["convert", str(xml), "-o", str(out)]) == 0
    data = json.loads(out.read_text())
    names = sorted(v["filename"] for m in data["materials"].values() for v in m.values()
                   if isinstance(v, dict) and v.get("type") == "bitmap")
    assert len(names) == 3 and all((out.parent / n).resolve().is_file() for n in names)
    scene = load_scene(out, mesh_folder=xml.parent)
    assert sum(len(m.textures) for m in scene.materials) == 6


def test_one_image_one_copy_and_mesh_corner_order() -> None:
    xml = Path(__file__).parent / "data" / "mitsuba" / "textures.xml"
    cs = compile_scene(xml)
    header = cs.textures[0].view(np.int32)
    ntex = 6  # floor, sphere, cube, cylinder checks, wall checks (<ref>), wall roughness
    texel_row = header[3] + 3 * ntex
    # tex_colour.png (8 x 6) once for the sphere's and the cube's textures, tex_rough.png (4 x 4), 3 x 2 checker colours
    assert len(cs.textures) - texel_row == 8 * 6 + 4 * 4 + 3 * 2
    # mesh UVs follow the corners when a mirroring transform reorders them (as compile_scene does)
    from mcocl.render.shape_uvs import triangle_uvs

    uvs = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    mesh = SimpleNamespace(kind="mesh", faces=np.array([[0, 1, 2]]), uvs=uvs, flip_normals=False,
                           vertices=np.eye(3), matrix=np.diag([-1.0, 1.0, 1.0, 1.0]))
    np.testing.assert_array_equal(triangle_uvs([mesh])[0], uvs[[0, 2, 1]])
    mesh.matrix = np.eye(4)
    np.testing.assert_array_equal(triangle_uvs([mesh])[0], uvs)


@pytest.mark.parametrize("bsdf, match", [
    ('<bsdf type="plastic"><texture type="checkerboard" name="specular_reflectance"/></bsdf>',
     r"t\.xml:\d+: <texture .*a texture for 'specular_reflectance' is not supported on a 'plastic' BSDF"),
    ('<bsdf type="diffuse"><texture type="perlin" name="reflectance"/></bsdf>',
     r"t\.xml:\d+: <texture .*unsupported texture plugin 'perlin'"),
    ('<bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="no.png"/>'
     '</texture></bsdf>', r"t\.xml:\d+: .*image file 'no.png' not found"),
    ('<bsdf type="diffuse"><texture type="checkerboard"/></bsdf>', r"t\.xml:\d+: .*needs name=\"<property>\""),
])
def test_mitsuba_texture_errors_name_the_line(tmp_path: Path, bsdf: str, match: str) -> None:
    p = write_xml(tmp_path, f'<shape type="rectangle">{bsdf}</shape>')
    with pytest.raises(InputError, match=match):
        load_scene(p)
