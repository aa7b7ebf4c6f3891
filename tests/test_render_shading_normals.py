"""Shading normals from vertex normals (kernels/render/shading_normal.cl, mcocl/render/shading_normals.py).

- A coarse polygonal sphere whose PLY gives the true sphere normals at its
  vertices renders like the analytic sphere, compared per 8 x 8 block with
  z-tests; the same mesh with ``face_normals`` (the negative control) does not.
- Light tracing, with Veach's adjoint correction, agrees with the mis path
  tracer on the smooth mesh (block z-tests), so both estimate one image.
- The device table: corners in the compiled triangle order, world space
  (inverse transpose), turned to the face's front; none without normals (the
  kernels are then built as before); bdpt refuses shading normals.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from test_render_textures import block_z  # 8 x 8 block z-scores of two renders

import mcocl
from mcocl.errors import InputError
from mcocl.render.compiled import compile_scene
from mcocl.render.device_scene import scene_tables
from mcocl.render.job import RenderJob
from mcocl.render.shading_normals import facing_dot


def uv_sphere(rings: int = 24, segments: int = 48) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (unit sphere) and outward-wound triangles of a latitude-longitude sphere."""
    theta = np.linspace(0.0, np.pi, rings + 1)[1:-1]
    phi = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    ring = np.stack([np.sin(t) * np.cos(p), np.cos(t), np.sin(t) * np.sin(p)], -1).reshape(-1, 3)
    v = np.concatenate([[[0.0, 1.0, 0.0]], ring, [[0.0, -1.0, 0.0]]])
    south = len(v) - 1

    def at(r: int, s: int) -> int:
        return 1 + r * segments + s % segments

    f = []
    for s in range(segments):
        f.append([0, at(0, s), at(0, s + 1)])
        f.append([south, at(rings - 2, s + 1), at(rings - 2, s)])
        for r in range(rings - 2):
            f += [[at(r, s), at(r + 1, s), at(r + 1, s + 1)], [at(r, s), at(r + 1, s + 1), at(r, s + 1)]]
    f = np.array(f)
    tri = v[f]
    out = np.einsum("ij,ij->i", np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), tri.mean(1)) < 0
    f[out] = f[out][:, [0, 2, 1]]
    return v, f


def write_ply(path: Path, v: np.ndarray, f: np.ndarray, normals: np.ndarray | None) -> None:
    """An ASCII PLY with optional vertex normals."""
    head = ["ply", "format ascii 1.0", f"element vertex {len(v)}", "property float x", "property float y",
            "property float z"]
    if normals is not None:
        head += ["property float nx", "property float ny", "property float nz"]
    head += [f"element face {len(f)}", "property list uchar int vertex_indices", "end_header"]
    rows = [" ".join(f"{x:.9g}" for x in (*v[i], *(normals[i] if normals is not None else ()))) for i in range(len(v))]
    rows += ["3 " + " ".join(str(int(i)) for i in tri) for tri in f]
    path.write_text("\n".join(head + rows) + "\n")


GLOSSY = {"type": "roughconductor", "alpha": 0.2, "specular_reflectance": [0.9, 0.7, 0.5]}
DIFFUSE = {"type": "diffuse", "reflectance": [0.8, 0.6, 0.4]}


def scene(tmp_path: Path, sphere: dict, name: str, material: dict = GLOSSY) -> Path:
    data = {"camera": {"origin": [0, 0, 4], "target": [0, 0, 0], "fov": 36, "width": 32, "height": 32},
            "integrator": {"type": "mis", "max_depth": 3},
            "materials": {"clay": material,
                          "lamp": {"type": "diffuse", "reflectance": [0, 0, 0]}},
            "environment": {"type": "constant", "radiance": [0.1, 0.1, 0.1]},
            "shapes": [{**sphere, "material": "clay"},
                       {"type": "sphere", "center": [2.5, 2.0, 1.5], "radius": 0.5, "material": "lamp",
                        "emitter": {"type": "area", "radiance": [8, 8, 8]}}]}
    p = tmp_path / name
    p.write_text(json.dumps(data))
    return p


@pytest.fixture(scope="module")
def scenes(tmp_path_factory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("shading")
    v, f = uv_sphere()
    write_ply(tmp / "smooth.ply", v, f, v)
    return {"analytic": scene(tmp, {"type": "sphere", "center": [0, 0, 0], "radius": 1.0}, "a.json"),
            "smooth": scene(tmp, {"type": "mesh", "ply": "smooth.ply"}, "s.json"),
            "flat": scene(tmp, {"type": "mesh", "ply": "smooth.ply", "face_normals": True}, "f.json"),
            "diffuse": scene(tmp, {"type": "mesh", "ply": "smooth.ply"}, "d.json", DIFFUSE)}


def test_smooth_mesh_renders_like_the_analytic_sphere(scenes) -> None:
    # independent samples: the mean z^2 bounds below hold for per-sample variances (many degrees of freedom)
    ref = mcocl.render(scenes["analytic"], spp=256, seed=1, sampler="independent")
    smooth = mcocl.render(scenes["smooth"], spp=256, seed=2, sampler="independent")
    flat = mcocl.render(scenes["flat"], spp=256, seed=3, sampler="independent")
    z = block_z(smooth, ref)
    assert np.abs(z).max() < 4.5, np.round(z[..., 0], 1)
    # Per pixel: the mean z^2 of a correct image is 1 (sd 0.04 over ~1600 pixels); the glossy
    # highlights of the face-normal mesh break into facets (measured: 3.4), the smooth mesh's do not (1.0).
    assert pixel_z2(smooth, ref) < 1.3
    assert pixel_z2(flat, ref) > 2.0


def pixel_z2(a, b) -> float:
    """The mean squared per-pixel z of two renders over the pixels where both vary."""
    m = (a.stderr > 0) & (b.stderr > 0)
    return float((((a.mean - b.mean)[m]) ** 2 / (a.stderr[m] ** 2 + b.stderr[m] ** 2)).mean())


def test_light_tracing_agrees_with_mis_on_shading_normals(scenes) -> None:
    # diffuse: light tracing sees a glossy highlight too rarely for its batch errors to be trusted
    a = mcocl.render(scenes["diffuse"], spp=256, seed=4, integrator="mis")
    b = mcocl.render(scenes["diffuse"], spp=256, seed=5, integrator="lt", spp_per_block=16)
    z = block_z(a, b)
    assert np.abs(z).max() < 4.5, np.round(z[..., 0], 1)


def test_vertex_normal_table(tmp_path: Path, scenes) -> None:
    cs = compile_scene(scenes["smooth"])
    v, f = uv_sphere()
    assert cs.vertex_normals.shape == (len(f), 3, 4) and np.all(cs.vertex_normals[..., 3] == 1.0)
    corners = cs.tri_vertices[:, :, :3].astype(np.float64)
    np.testing.assert_allclose(cs.vertex_normals[..., :3], corners, atol=1e-6)  # unit sphere: n = p
    assert "vertex_normals" in scene_tables(cs)
    assert compile_scene(scenes["flat"]).vertex_normals is None
    assert "vertex_normals" not in scene_tables(compile_scene(scenes["analytic"]))
    # a non-uniform scale and a mirror: normals by the inverse transpose, still on the front side
    data = json.loads(scenes["smooth"].read_text())
    data["shapes"][0]["transform"] = [{"scale": [2.0, -0.5, 1.0]}]
    (tmp_path / "smooth.ply").write_text((scenes["smooth"].parent / "smooth.ply").read_text())
    p = tmp_path / "m.json"
    p.write_text(json.dumps(data))
    cs = compile_scene(p)
    x = cs.tri_vertices[:, :, :3].astype(np.float64)
    want = x / np.array([2.0, -0.5, 1.0]) ** 2 * np.array([1, 1, 1])  # M^-T (M^-1 x) for a diagonal M
    want /= np.linalg.norm(want, axis=2, keepdims=True)
    face = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    sign = np.sign(np.einsum("ijk,ik->ij", want, face))[..., None]
    np.testing.assert_allclose(cs.vertex_normals[..., :3], want * sign, atol=1e-5)


def test_vertex_normals_are_stored_once_per_vertex(scenes) -> None:
    # the kernels' table: a record of three row numbers and a sign per triangle, then each vertex normal once
    cs = compile_scene(scenes["smooth"])
    v, f = uv_sphere()
    nt = cs.num_triangles
    table = scene_tables(cs)["vertex_normals"]
    assert nt == len(f) and table.shape == (nt + len(v), 4)
    rows = table[:nt].view(np.uint32)[:, :3]
    assert rows.min() == nt and rows.max() == len(table) - 1
    assert np.all(table[:nt, 3] == 1.0) and np.all(table[nt:, 3] == 0.0)  # outward normals: none negated
    np.testing.assert_array_equal(table[rows, :3], cs.vertex_normals[..., :3])
    # a mirror with flip_normals keeps the winding and turns the faces inwards: every triangle's normals negated
    data = json.loads(scenes["smooth"].read_text())
    data["shapes"][0].update(transform=[{"scale": [1.0, -1.0, 1.0]}], flip_normals=True)
    p = scenes["smooth"].parent / "mirror.json"
    p.write_text(json.dumps(data))
    cs = compile_scene(p)
    table = scene_tables(cs)["vertex_normals"]
    assert np.all(table[:nt, 3] == -1.0)
    np.testing.assert_array_equal(-table[table[:nt].view(np.uint32)[:, :3], :3], cs.vertex_normals[..., :3])


def test_bdpt_refuses_shading_normals(scenes) -> None:
    data = json.loads(scenes["smooth"].read_text())
    del data["environment"]  # bdpt takes area emitters only
    p = scenes["smooth"].parent / "no_env.json"
    p.write_text(json.dumps(data))
    cs = compile_scene(p)
    with pytest.raises(InputError, match="face_normals"):
        mcocl.render(cs, spp=1, integrator="bdpt")
    job = RenderJob(scene_tables(compile_scene(scenes["analytic"])), 32, 32, "mis", 3, 5, seed=1, spp_per_block=1)
    assert "-DSHADING_NORMALS" not in job.options(1)


def test_facing_dot_is_einsum_of_cross_bit_for_bit() -> None:
    # vertex_normal_table's elementwise dot product repeats NumPy's operations (a changed order would round otherwise)
    rng = np.random.default_rng(7)
    n = 200_000
    corner = rng.standard_normal((n, 3, 3)) * 10.0 ** rng.uniform(-3, 3, (n, 1, 1))
    tri = (rng.standard_normal((n, 3, 3)) * 10.0 ** rng.uniform(-3, 3, (n, 1, 1))).astype(np.float32)
    t = tri.astype(np.float64)
    want = np.einsum("ij,ij->i", corner.sum(axis=1), np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]))
    np.testing.assert_array_equal(facing_dot(corner, tri).view(np.uint64), want.view(np.uint64))


@pytest.mark.parametrize("vertices", [1, 2, 700])
@pytest.mark.parametrize("flip", [False, True])
@pytest.mark.parametrize("recomputed", [False, True])
def test_corner_normals_recomputed_per_chunk_are_the_vertex_normals_bit_for_bit(monkeypatch, vertices, flip,
                                                                                recomputed) -> None:
    """vertex_normal_table turns each triangle to its front from its corners' float64 world normals, for a big
    mesh computed again chunk by chunk (no float64 table of every vertex): the same corners and table, bit for
    bit, as from the world normals of the vertices taken at the corners, with chunks of a few triangles, under
    a skewing, mirroring transform; a mesh of one vertex (a single row's product rounds apart) included."""
    from types import SimpleNamespace

    from mcocl.render import shading_normals as sn

    rng = np.random.default_rng(vertices)
    m = np.eye(4)
    m[:3, :3] = rng.normal(size=(3, 3))
    m[:3, :3] *= np.sign(np.linalg.det(m[:3, :3]))  # orientation-preserving, then made mirroring by flip
    if flip:
        m[0] *= -1.0
    faces = rng.integers(0, vertices, size=(257, 3)).astype(np.int32)
    sh = SimpleNamespace(kind="mesh", normals=rng.normal(size=(vertices, 3)).astype(np.float32), faces=faces,
                         matrix=m, flip_normals=False)
    tris = rng.normal(size=(len(faces), 3, 3)).astype(np.float32)
    monkeypatch.setattr(sn, "_CHUNK", 10)
    if recomputed:  # every mesh counts as big
        monkeypatch.setattr(sn, "_WORLD_TABLE_BYTES", 0)
    seen = []  # the corners' normals each chunk's facing test gets
    monkeypatch.setattr(sn, "facing_dot", lambda corner, t: seen.append(corner.copy()) or facing_dot(corner, t))
    table = sn.vertex_normal_table([sh], tris)
    world = sn._world_normals(sh)
    ordered = faces[:, [0, 2, 1]] if flip else faces
    assert np.array_equal(np.concatenate(seen).view(np.uint64), np.take(world, ordered, axis=0).view(np.uint64))
    behind = facing_dot(np.take(world, ordered, axis=0), tris) < 0.0
    want = np.where(behind, np.float32(-1.0), np.float32(1.0))
    assert np.array_equal(table[:len(faces), 3], want) and behind.any() and not behind.all()
    assert np.array_equal(table[len(faces):, :3], world.astype(np.float32))
