"""OBJ texture coordinates and normals (mcocl/render/obj_reader.py, obj_corners.py, obj_vertices.py).

- Round trips: files the test writes with ``vt``/``vn`` records and every
  corner form, read back against the arrays they were written from (corner
  by corner, since vertices are split into distinct (v, vt, vn) triples).
- Negative indices count back from the last record of their kind; a first
  ``vt``/``vn`` record after a chunk's faces makes the chunks be read again.
- Corners with and without normals (texture indices): the mesh gets none, with
  a warning naming the line; bad indices and records are errors naming the line.
- An OBJ sphere with vertex normals compiles to the same triangles and corner
  normals as its PLY twin, so it renders bit for bit like the PLY sphere,
  whose shading tests/test_render_shading_normals.py checks against the analytic one.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from test_render_shading_normals import scene, uv_sphere, write_ply

import mcocl
from mcocl.errors import InputError
from mcocl.render import obj_reader
from mcocl.render.compiled import compile_scene
from mcocl.render.obj_vertices import ObjAttributeWarning, split_vertices
from mcocl.render.shapes import read_obj

TRI = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"


def read(tmp_path: Path, text: str):
    p = tmp_path / "m.obj"
    p.write_text(text)
    return read_obj(p, "shapes[0].obj")


def random_obj(rng: np.random.Generator, kinds: str, interleave: bool) -> tuple[str, dict, list]:
    """OBJ text of random polygons whose corners give the index kinds ``kinds`` ("vt", "vtn", "vn"), and its arrays.

    Returns (text, {"v": positions, "vt": uvs, "vn": normals}, the fan
    triangles' corners as (v, vt, vn) index triples, -1 where not given).
    Corner indices are positive or negative (counting back from the records
    written so far); with ``interleave`` the records are written in portions
    between the faces.
    """
    sizes = {"v": 300, "vt": 200, "vn": 150}
    arrays = {"v": np.round(rng.normal(size=(300, 3)), 6), "vt": np.round(rng.uniform(size=(200, 2)), 6),
              "vn": np.round(rng.normal(size=(150, 3)), 6)}
    written = {k: 0 for k in sizes}
    lines, tris = [], []

    def ref(i: int, k: str) -> str:
        """Record i of kind k as a 1-based index or one counting back from the last written."""
        return str(i + 1) if rng.uniform() < 0.5 else str(i - written[k])

    for portion in range(4 if interleave else 1):
        for k, a in arrays.items():
            stop = sizes[k] * (portion + 1) // (4 if interleave else 1)
            lines += [f"{k} " + " ".join(f"{x:.6f}" for x in row) for row in a[written[k]:stop]]
            written[k] = stop
        for _ in range(100):
            m = int(rng.integers(3, 7))
            triples = [[int(rng.integers(0, written["v"])),
                        int(rng.integers(0, written["vt"])) if "t" in kinds else -1,
                        int(rng.integers(0, written["vn"])) if "n" in kinds else -1] for _ in range(m)]
            lines.append("f " + " ".join(ref(v, "v") + ("/" + ref(t, "vt") if t >= 0 else "/" if n >= 0 else "")
                                         + ("/" + ref(n, "vn") if n >= 0 else "") for v, t, n in triples))
            tris += [[triples[0], triples[k], triples[k + 1]] for k in range(1, m - 1)]
    return "\n".join(lines) + "\n", arrays, tris


@pytest.mark.parametrize("chunk", [None, 1500])
@pytest.mark.parametrize("kinds,interleave", [("vtn", False), ("vtn", True), ("vt", True), ("vn", False)])
def test_round_trip_corner_by_corner(tmp_path, monkeypatch, kinds, interleave, chunk):
    if chunk:
        monkeypatch.setattr(obj_reader, "CHUNK_BYTES", chunk)
    rng = np.random.default_rng(len(kinds) + 2 * interleave)
    text, arrays, tris = random_obj(rng, kinds, interleave)
    mesh = read(tmp_path, text)
    corners = np.array(tris)  # (T, 3, 3): v, vt, vn index of each corner
    np.testing.assert_array_equal(mesh.vertices[mesh.faces], arrays["v"][corners[..., 0]])
    if "t" in kinds:
        np.testing.assert_array_equal(mesh.uvs[mesh.faces], arrays["vt"][corners[..., 1]])
    else:
        assert mesh.uvs is None
    if "n" in kinds:
        np.testing.assert_array_equal(mesh.normals[mesh.faces], arrays["vn"][corners[..., 2]])
    else:
        assert mesh.normals is None
    # one vertex per distinct triple the corners use, in (v, vt, vn) order
    used = np.unique(corners.reshape(-1, 3), axis=0)
    assert len(mesh.vertices) == len(used)
    np.testing.assert_array_equal(mesh.vertices, arrays["v"][used[:, 0]])


def test_known_arrays_and_negative_indices(tmp_path):
    mesh = read(tmp_path, TRI + "vt 0 0\nvt 1 0\nvt 1 1 0.5\nvt 0.5\nvn 0 0 1\nvn 0 0 -1\n"
                "f 1/1/1 2/2/1 3/3/1\nf 1/4/2 3/3/2 -1/-1/-2\n")
    np.testing.assert_array_equal(mesh.vertices, [[0, 0, 0], [0, 0, 0], [1, 0, 0], [1, 1, 0], [1, 1, 0], [0, 1, 0]])
    np.testing.assert_array_equal(mesh.faces, [[0, 2, 3], [1, 4, 5]])
    np.testing.assert_array_equal(mesh.normals, [[0, 0, 1], [0, 0, -1], [0, 0, 1], [0, 0, 1], [0, 0, -1], [0, 0, 1]])
    # vt w is dropped, a missing v is 0
    np.testing.assert_array_equal(mesh.uvs, [[0, 0], [0.5, 0], [1, 0], [1, 1], [1, 1], [0.5, 0]])
    assert mesh.faces.dtype == np.int64 and mesh.normals.dtype == mesh.uvs.dtype == np.float64
    # negative: from the last record of each kind before the face's line
    mesh = read(tmp_path, "v 0 0 0\nv 1 0 0\nvn 1 0 0\nv 1 1 0\nf -3//-1 -2//-1 -1//-1\nvn 0 1 0\nv 9 9 9\n"
                "f -2//-1 -3//-2 -4//-1\n")
    np.testing.assert_array_equal(mesh.vertices[mesh.faces], [[[0, 0, 0], [1, 0, 0], [1, 1, 0]],
                                                             [[1, 1, 0], [1, 0, 0], [0, 0, 0]]])
    np.testing.assert_array_equal(mesh.normals[mesh.faces], [[[1, 0, 0]] * 3, [[0, 1, 0], [1, 0, 0], [0, 1, 0]]])


def test_files_without_used_attributes_read_as_before(tmp_path):
    plain = read(tmp_path, TRI + "f 1 2 3 4\n")
    # vt/vn records no face uses, and texture/normal parts without records: positions and faces as read
    for text in (TRI + "vt 0 0\nvn 0 0 1\nf 1 2 3 4\n", TRI + "f 1/5 2/6 3//7 4/1/1\n"):
        mesh = read(tmp_path, text)
        np.testing.assert_array_equal(mesh.vertices, plain.vertices)
        np.testing.assert_array_equal(mesh.faces, plain.faces)
        assert mesh.normals is None and mesh.uvs is None
    # normals given without texture coordinates records: the texture parts are not read
    mesh = read(tmp_path, TRI + "vn 0 0 1\nf 1/7/1 2/8/1 3/-9/1\n")
    assert mesh.uvs is None and len(mesh.vertices) == 3
    np.testing.assert_array_equal(mesh.normals, [[0, 0, 1]] * 3)


def test_first_attribute_record_after_a_chunk_of_faces(tmp_path, monkeypatch):
    monkeypatch.setattr(obj_reader, "CHUNK_BYTES", 64)
    text = TRI + "f 1//1 2//2 3//1\n" * 8 + "vn 0 0 1\nvn 0 1 0\n"  # faces first (forward references)
    passes = []
    parse_chunks = obj_reader._parse_chunks
    monkeypatch.setattr(obj_reader, "_parse_chunks", lambda *a: passes.append(a[1]) or parse_chunks(*a))
    mesh = read(tmp_path, text)
    assert passes == [(False, False), (False, True)]  # read again once the normals were found
    np.testing.assert_array_equal(mesh.normals[mesh.faces], [[[0, 0, 1], [0, 1, 0], [0, 0, 1]]] * 8)


@pytest.mark.parametrize("text,line,lost", [
    (TRI + "vt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1\nf 1/1 3/1 4/1\n", 8, "normals"),
    (TRI + "vt 0 0\nvn 0 0 1\nf 1/1/1 2//1 3/1/1\n", 7, "texture coordinates"),
])
def test_corners_with_and_without_attributes(tmp_path, text, line, lost):
    with pytest.warns(ObjAttributeWarning, match=rf"m.obj:{line}: a face corner without .* no {lost}"):
        mesh = read(tmp_path, text)
    assert (mesh.normals if lost == "normals" else mesh.uvs) is None
    kept = mesh.uvs if lost == "normals" else mesh.normals
    assert kept is not None and len(kept) == len(mesh.vertices)


@pytest.mark.parametrize("text,message", [
    (TRI + "vt 0 0\nf 1/1 2/0 3/1\n", r"m.obj:6: OBJ indices start at 1, got 0"),
    (TRI + "vn 0 0 1\nf 1//1 2//1 3//0\n", r"m.obj:6: OBJ indices start at 1, got 0"),
    (TRI + "vt 0 0\nf 1/1 2/1 3/1\nf 1/1 2/2 3/1\n", r"m.obj:7: texture coordinate index 1 is outside 0..0 .*1 texture"),
    (TRI + "vn 0 0 1\nf 1//1 2//1 3//-2\n", r"m.obj:6: normal index -1 is outside 0..0 .*'3//-2' counts back"),
    (TRI + "vt 0 0\nf 1/1 2/1 -5/1\n", r"m.obj:6: face index -1 is outside 0..3 .*'-5/1'"),
    (TRI + "vn 0 0 1\nf 1//1 2//1 7//1\n", r"m.obj:6: face index 6 is outside 0..3 .*4 vertices"),
    (TRI + "vn 0 0 1\nf 1//1 2//1 3//\n", r"m.obj:6: bad face corner '3//'"),
    (TRI + "vn 0 0 1\nf 1//1 2//1 3/1/\n", r"m.obj:6: bad face corner '3/1/'"),
    (TRI + "vn 0 0 1\nf 1//1 2//1 3/1/1/1\n", r"m.obj:6: bad face corner '3/1/1/1'"),
    (TRI + "vn 0 0 1\nf 1//1 2//1 3/x/1\n", r"m.obj:6: bad face corner '3/x/1'"),
    (TRI + "vn 0 0\n", r"m.obj:5: a normal needs three numbers"),
    (TRI + "vn 0 0 x\n", r"m.obj:5: a normal needs three numbers"),
    (TRI + "vt\n", r"m.obj:5: a texture coordinate needs one to three numbers"),
    (TRI + "vt 1 nan\nf 1/1 2/1 3/1\n", r"non-finite"),
])
def test_errors_name_the_line(tmp_path, text, message):
    with pytest.raises(InputError, match=r"shapes\[0\]\.obj: .*" + message):
        read(tmp_path, text)


def test_split_ranks_a_key_that_would_overflow():
    rng = np.random.default_rng(3)
    columns = [rng.integers(0, 5, (40, 3)) * 2**40, rng.integers(0, 2, (40, 3)) * 2**30 + 5, rng.integers(0, 4, (40, 3))]
    faces, first = split_vertices(columns, [2**41, 2**31, 4])
    triples = np.stack([c.ravel() for c in columns], 1)
    want, inverse = np.unique(triples, axis=0, return_inverse=True)
    np.testing.assert_array_equal(triples[first], want)
    np.testing.assert_array_equal(faces.ravel(), inverse.ravel())


def test_obj_sphere_renders_like_the_ply_sphere(tmp_path):
    v, f = uv_sphere(8, 16)
    write_ply(tmp_path / "s.ply", v, f, v)
    # The OBJ lists the normals in another order than the positions, and a texture coordinate per corner
    # position, so that vertices are split and joined again; numbers as write_ply writes them.
    perm = np.random.default_rng(1).permutation(len(v))
    where = np.argsort(perm)  # normal of vertex i is record where[i]
    rows = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in v] + [f"vn {x:.9g} {y:.9g} {z:.9g}" for x, y, z in v[perm]]
    rows += ["vt 0 0", "vt 1 0", "vt 0 1"]
    rows += ["f " + " ".join(f"{i + 1}/{k + 1}/{where[i] + 1}" for k, i in enumerate(tri)) for tri in f]
    (tmp_path / "s.obj").write_text("\n".join(rows) + "\n")
    ply = scene(tmp_path, {"type": "mesh", "ply": "s.ply"}, "p.json")
    obj = scene(tmp_path, {"type": "mesh", "obj": "s.obj"}, "o.json")
    a, b = compile_scene(ply), compile_scene(obj)
    np.testing.assert_array_equal(a.tri_vertices, b.tri_vertices)
    assert b.vertex_normals is not None
    np.testing.assert_array_equal(a.vertex_normals, b.vertex_normals)
    flat = json.loads(obj.read_text())
    flat["shapes"][0]["face_normals"] = True
    (tmp_path / "f.json").write_text(json.dumps(flat))
    assert compile_scene(tmp_path / "f.json").vertex_normals is None
    with warnings.catch_warnings():
        warnings.simplefilter("error", ObjAttributeWarning)
        # independent (auto takes sobol at 8 spp): bit-identity holds for any sample points, and mis's independent
        # shading-normal build is the one tests/test_mitsuba_references.py makes (7 to 10 s on a cold PoCL cache)
        ra = mcocl.render(ply, spp=8, seed=3, sampler="independent")
        rb = mcocl.render(obj, spp=8, seed=3, sampler="independent")
    np.testing.assert_array_equal(ra.mean, rb.mean)
