"""The mesh's arrays after the load and the compiled triangles, against their straightforward conversions (issue 13).

mcocl/render/serialized_reader.py inflates a serialized mesh into one body
without its (unused) vertex colours, and mcocl/render/compiled.py's
``_shape_triangles`` transforms and gathers a mesh a block at a time
(mcocl/render/transform.py's ``apply_points_float32``) to hold no float64
table of every vertex and no intp copy of every face: the arrays must be,
bit for bit, those of inflating the whole stream and slicing it, and of
``apply_points(m, v.astype(float64)).astype(float32)[faces]``.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from mcocl.errors import InputError
from mcocl.render import mesh_normals
from mcocl.render import transform as tf
from mcocl.render.compiled import _GATHER_FACES, _shape_triangles
from mcocl.render.serialized_reader import HAS_COLORS, HAS_NORMALS, HAS_UVS, parse_serialized


def _file(nv: int, nt: int, double: bool, seed: int) -> tuple[bytes, bytes]:
    """A one-mesh serialized file (version 4, normals, UVs and vertex colours) and its inflated stream."""
    rng = np.random.default_rng(seed)
    ftype = "<f8" if double else "<f4"
    flags = (0x2000 if double else 0x1000) | HAS_NORMALS | HAS_UVS | HAS_COLORS
    arrays = [rng.normal(size=(nv, 3)), rng.normal(size=(nv, 3)), rng.random((nv, 2)), rng.random((nv, 3))]
    body = struct.pack("<I", flags) + b"mesh\0" + struct.pack("<QQ", nv, nt)
    body += b"".join(a.astype(ftype).tobytes() for a in arrays) + rng.integers(0, nv, (nt, 3)).astype("<u4").tobytes()
    data = struct.pack("<HH", 0x041C, 4) + zlib.compress(body, 1) + struct.pack("<QI", 0, 1)
    return data, body


@pytest.mark.parametrize("nv,nt,double", [(5, 4, False), (40_000, 70_000, False), (30_000, 20_000, True)])
def test_serialized_arrays_are_the_stream_sliced(nv: int, nt: int, double: bool) -> None:
    """Positions, normals, UVs and faces as slices of the whole inflated stream, over many inflate steps and a
    colour block that starts and ends inside them; the kept body is the stream less the colours."""
    data, body = _file(nv, nt, double, nv)
    real = 8 if double else 4
    ftype = "<f8" if double else "<f4"
    at = 4 + 5 + 16
    want = {}
    for name, width in (("vertices", 3), ("normals", 3), ("uvs", 2)):
        want[name] = np.frombuffer(body, ftype, nv * width, at).reshape(nv, width)
        at += nv * width * real
    at += nv * 3 * real  # the colours
    want["faces"] = np.frombuffer(body, "<u4", nt * 3, at).reshape(nt, 3)
    got = parse_serialized(data, 0, "m")
    for name, a in want.items():
        b = getattr(got, name)
        assert b.dtype == a.dtype and b.shape == a.shape and b.tobytes() == a.tobytes(), name
    held = got.faces
    while held.base is not None and isinstance(held.base, np.ndarray):
        held = held.base
    assert held.nbytes == nv * 8 * real + nt * 12  # positions, normals, UVs, faces: no colours
    with pytest.raises(InputError, match="ends early"):  # a stream cut inside the faces still says so
        cut = zlib.compress(body[:-7], 1)
        parse_serialized(struct.pack("<HH", 0x041C, 4) + cut + struct.pack("<QI", 0, 1), 0, "m")


def _straightforward(shape) -> np.ndarray:
    """The triangles as compile_scene made them before the blocks: one float64 table, one gather."""
    v = tf.apply_points(shape.matrix, np.asarray(shape.vertices, np.float64)).astype(np.float32)
    f = shape.faces[:, [0, 2, 1]] if tf.is_orientation_reversing(shape.matrix) != shape.flip_normals else shape.faces
    return v[f]


@pytest.mark.parametrize("dtype,mirror,flip", [(np.float32, False, False), (np.float32, True, False),
                                               (np.float64, False, True), (np.float64, True, True)])
def test_shape_triangles_match_one_table(dtype, mirror: bool, flip: bool) -> None:
    """More vertices than one block of transform.rows_times and more faces than one gather block; float32 (a
    file's) and float64 (inline) vertices; a mirroring transform and flip_normals swap the corners."""
    rng = np.random.default_rng(7)
    nv = 3 * tf._ROWS + 5
    nt = 2 * _GATHER_FACES + 3
    m = tf.compose([tf.scale([1.3, -0.7 if mirror else 0.7, 2.1]), tf.rotate([1, 2, 3], 37.0),
                    tf.translate([0.1, -3.0, 1e3])])
    shape = SimpleNamespace(vertices=rng.normal(size=(nv, 3)).astype(dtype),
                            faces=rng.integers(0, nv, (nt, 3)).astype(np.uint32), matrix=m, flip_normals=flip,
                            key="shapes[0]")
    out = np.empty((nt, 3, 3), np.float32)
    _shape_triangles(shape, Path("s.json"), out)
    assert out.tobytes() == _straightforward(shape).tobytes()


def test_shape_triangles_non_finite() -> None:
    """A vertex the transform makes infinite is refused only where a face uses it, as before the blocks."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1e300, 0, 0]], np.float64)
    m = tf.scale(1e10)
    shape = SimpleNamespace(vertices=v, faces=np.array([[0, 1, 2]], np.uint32), matrix=m, flip_normals=False,
                            key="shapes[0]")
    out = np.empty((1, 3, 3), np.float32)
    with np.errstate(over="ignore", invalid="ignore"):  # the overflow is the point
        _shape_triangles(shape, Path("s.json"), out)
        assert out.tobytes() == _straightforward(shape).tobytes()
        shape.faces = np.array([[0, 1, 3]], np.uint32)
        with pytest.raises(InputError, match="non-finite"):
            _shape_triangles(shape, Path("s.json"), out)


def _normals_one_table(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """mesh_normals.angle_weighted_normals as it was before the blocks: every face's tables at once."""
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64)
    p = v[f]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    length = np.linalg.norm(n, axis=1)
    valid = length > 0.0
    n = n[valid] / length[valid, None]
    p, f = p[valid], f[valid]
    out = np.zeros_like(v)
    for k in range(3):
        a = p[:, (k + 1) % 3] - p[:, k]
        b = p[:, (k + 2) % 3] - p[:, k]
        a /= np.linalg.norm(a, axis=1, keepdims=True)
        b /= np.linalg.norm(b, axis=1, keepdims=True)
        angle = np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1.0, 1.0))
        for axis in range(3):
            out[:, axis] += np.bincount(f[:, k], weights=n[:, axis] * angle, minlength=len(v))
    norm = np.linalg.norm(out, axis=1)
    bogus = norm == 0.0
    out[~bogus] /= norm[~bogus, None]
    out[bogus] = (1.0, 0.0, 0.0)
    return out


@pytest.mark.parametrize("block,nt", [(None, 150_000), (1000, 7_001), (1000, 7_000), (1000, 999)])
def test_angle_weighted_normals_match_one_table(monkeypatch, block: int | None, nt: int) -> None:
    """Computed block by block, the normals are those of every face at once, bit for bit: a real block size and
    small ones (a last block of one face, exact blocks, a single block), with degenerate faces (repeated
    vertices), vertices no face uses, and many faces per vertex (sums whose order matters)."""
    rng = np.random.default_rng(11)
    nv = max(nt // 3, 10)
    vertices = rng.normal(size=(nv, 3)).astype(np.float32)
    faces = rng.integers(0, nv - 5, (nt, 3)).astype(np.uint32)
    faces[::97, 1] = faces[::97, 0]  # degenerate: zero area
    if block is not None:
        monkeypatch.setattr(mesh_normals, "_FACES", block)
    got = mesh_normals.angle_weighted_normals(vertices, faces)
    assert got.tobytes() == _normals_one_table(vertices, faces).tobytes()


def _world_normals_one_table(vertices: np.ndarray, faces: np.ndarray, m: np.ndarray) -> np.ndarray:
    """mesh_normals.world_space_vertex_normals as it was before the blocks: a float64 table of every world-space
    vertex (transform.apply_points), the normals of every face at once, then one product back to the mesh's frame."""
    world = tf.apply_points(m, np.asarray(vertices, np.float64))
    return _normals_one_table(world, faces) @ m[:3, :3]


@pytest.mark.parametrize("block,nt,mirror", [(None, 100_001, True), (None, 100_001, False), (1000, 7_001, True),
                                             (1000, 7_000, False), (1000, 999, True), (4096, 20_000, True)])
def test_world_space_normals_match_one_table(monkeypatch, block: int | None, nt: int, mirror: bool) -> None:
    """The world-space corners computed a block of faces at a time (no table of every world-space vertex), the
    corners' sums taken one axis at a time and the normals normalised and taken back to the mesh's frame in place,
    block by block: bit for bit the whole-table computation, at several block sizes, under a rotating, shearing
    and (or not) mirroring transform with a large translation, with degenerate faces and more vertices than one
    block of transform.rows_times."""
    rng = np.random.default_rng(nt + mirror)
    nv = 3 * tf._ROWS + 5 if block is None else max(nt // 3, 10)
    vertices = rng.normal(size=(nv, 3)).astype(np.float32)
    faces = rng.integers(0, nv - 5, (nt, 3)).astype(np.uint32)
    faces[::97, 1] = faces[::97, 0]  # degenerate: zero area
    faces[::89, 2] = faces[::89, 1]
    m = tf.compose([tf.scale([1.3, -0.7 if mirror else 0.7, 2.1]), tf.rotate([1, 2, 3], 37.0, normalise=False),
                    tf.translate([0.1, -3.0, 1e3])])
    if block is not None:
        monkeypatch.setattr(mesh_normals, "_FACES", block)
    got = mesh_normals.world_space_vertex_normals(vertices, faces, m)
    want = _world_normals_one_table(vertices, faces, m)
    assert got.dtype == want.dtype and got.shape == want.shape and got.tobytes() == want.tobytes()


def _grid_ply_xyz(path: Path, n: int) -> None:
    """A binary PLY of an n x n grid of float positions (a bumpy sheet) and its triangles, without normals."""
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    v = np.stack([i, j, np.sin(i * 0.3) * np.cos(j * 0.2)], -1).reshape(-1, 3).astype("<f4")
    q = (i[:-1, :-1] * n + j[:-1, :-1]).ravel()
    faces = np.concatenate([np.stack([q, q + n, q + 1], 1), np.stack([q + 1, q + n, q + n + 1], 1)])
    rec = np.zeros(len(faces), np.dtype([("n", "u1"), ("i", "<i4", 3)]))
    rec["n"], rec["i"] = 3, faces
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(v)}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
    path.write_bytes(head.encode() + v.tobytes() + rec.tobytes())


def test_computed_normals_load_under_twice_the_file(tmp_path, monkeypatch) -> None:
    """A Mitsuba XML scene naming a PLY without normals (the load computes them, mesh_normals.py) peaks, in the
    allocations tracemalloc sees (NumPy's included), under twice the files' size (issue 13); the whole-table
    computation held the world-space vertices and three (V, 3) float64 tables besides, about 2.8x.  Blocks of 1000
    faces keep the blocks' temporaries small beside a 4 MB mesh."""
    import tracemalloc

    from mcocl.render.scene_file import load_scene

    _grid_ply_xyz(tmp_path / "sheet.ply", 320)
    scene = tmp_path / "scene.xml"
    scene.write_text(
        '<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/>'
        '<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>'
        '<emitter type="constant"/><shape type="ply"><string name="filename" value="sheet.ply"/>'
        '<transform name="to_world"><rotate y="1" angle="30"/><translate x="-2.5"/></transform></shape></scene>')
    size = scene.stat().st_size + (tmp_path / "sheet.ply").stat().st_size
    monkeypatch.setattr(mesh_normals, "_FACES", 1000)
    tracemalloc.start()
    try:
        loaded = load_scene(scene)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert any(getattr(s, "normals", None) is not None for s in loaded.shapes)  # the normals were computed
    assert peak < 2.0 * size, (peak / size, size)
