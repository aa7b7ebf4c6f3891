"""PLY meshes (mcocl/render/ply_reader.py), the tessellated disk and cylinder, and their Mitsuba import.

- ASCII and binary (both byte orders) PLY files written here with NumPy read as
  the same vertices and faces as their OBJ twin; polygons become fans; mixed
  polygon sizes take the vectorised scan and agree with the fixed-size block read;
- a binary file's float32 data stays float32 and compiles to the same device tables as its float64 ASCII twin;
- malformed headers, counts and truncated files are refused naming the file;
  a path outside the scene's folder is refused;
- the disk's and cylinder's areas are the inscribed polygons' (→ π and 2π);
- the importer maps ply, disk and cylinder (with p0, p1, radius);
- the shipped Cornell box with its shapes as PLY files renders bit for bit as with OBJ files.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import mcocl
from mcocl.cli import main
from mcocl.errors import InputError
from mcocl.render import shapes as shape_lib
from mcocl.render.compiled import compile_scene
from mcocl.render.mitsuba import read_mitsuba
from mcocl.render.ply_reader import parse_ply
from mcocl.render.scene import parse_scene
from mcocl.render.scene_file import load_scene
from mcocl.render.shape_uvs import triangle_uvs
from mcocl.render.shapes import read_obj, read_ply

SCENES = Path(__file__).resolve().parent.parent / "scenes"
RNG = np.random.default_rng(7)
VERTS = RNG.standard_normal((6, 3)).astype(np.float32).astype(np.float64)  # exact in float32 and as decimals
NORMALS = RNG.standard_normal((6, 3)).astype(np.float32).astype(np.float64)
UVS = RNG.random((6, 2)).astype(np.float32).astype(np.float64)
POLYS = [[0, 1, 2], [2, 3, 4, 5], [5, 4, 1], [0, 2, 4, 5, 1]]  # triangles, a quad, a pentagon
FANS = [[0, 1, 2], [2, 3, 4], [2, 4, 5], [5, 4, 1], [0, 2, 4], [0, 4, 5], [0, 5, 1]]


def header(fmt: str, nv: int, nf: int, vprops: str = "float x\nproperty float y\nproperty float z",
           face: str = "list uchar int vertex_indices", extra: str = "") -> bytes:
    return (f"ply\nformat {fmt} 1.0\ncomment written by the test\nelement vertex {nv}\nproperty {vprops}\n"
            f"{extra}element face {nf}\nproperty {face}\nend_header\n").encode()


def binary_ply(order: str, polys=POLYS, count: str = "u1", index: str = "i4", uv_names=("u", "v")) -> bytes:
    """A binary PLY of VERTS with normals and UVs, the polygons ``polys``, and an 'edge' element to skip."""
    vt = np.zeros(len(VERTS), np.dtype([(n, order + "f4") for n in ("x", "y", "z", "nx", "ny", "nz", *uv_names)]))
    for i, n in enumerate("xyz"):
        vt[n], vt["n" + n] = VERTS[:, i], NORMALS[:, i]
    vt[uv_names[0]], vt[uv_names[1]] = UVS[:, 0], UVS[:, 1]
    faces = b"".join(np.array([len(p)], order + count).tobytes() + np.array(p, order + index).tobytes() for p in polys)
    names = {"u1": "uchar", "i4": "int", "u4": "uint", "i2": "short"}
    vprops = "\nproperty ".join(f"float {n}" for n in vt.dtype.names)
    fmt = {"<": "binary_little_endian", ">": "binary_big_endian"}[order]
    edges = np.array([[0, 1], [1, 2]], order + "i4").tobytes()
    return (header(fmt, len(VERTS), len(polys), vprops, f"list {names[count]} {names[index]} vertex_indices")
            .replace(b"end_header", b"element edge 2\nproperty int vertex1\nproperty int vertex2\nend_header")
            + vt.tobytes() + faces + edges)


def ascii_ply(polys=POLYS) -> bytes:
    rows = "".join(" ".join(repr(float(x)) for x in (*v, *n, *t)) + "\n" for v, n, t in zip(VERTS, NORMALS, UVS))
    faces = "".join(f"{len(p)} {' '.join(map(str, p))}\n" for p in polys)
    props = "float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz" \
            "\nproperty float s\nproperty float t"
    return header("ascii", len(VERTS), len(polys), props, "list uchar uint vertex_index") + (rows + faces).encode()


def obj_twin(polys=POLYS) -> str:
    return ("".join("v " + " ".join(repr(float(x)) for x in v) + "\n" for v in VERTS)
            + "".join("f " + " ".join(str(i + 1) for i in p) + "\n" for p in polys))


@pytest.mark.parametrize("kind", ["ascii", "<", ">", "<u4", ">i2", "<s/t"])
def test_ply_forms_equal_the_obj_twin(tmp_path, kind):
    if kind == "ascii":
        data = ascii_ply()
    elif kind == "<s/t":
        data = binary_ply("<", uv_names=("s", "t"))
    else:
        data = binary_ply(kind[0], count={"<u4": "u4", ">i2": "i2"}.get(kind, "u1"),
                          index={"<u4": "u4", ">i2": "i2"}.get(kind, "i4"))
    (tmp_path / "m.ply").write_bytes(data)
    (tmp_path / "m.obj").write_text(obj_twin())
    mesh = read_ply(tmp_path / "m.ply", "shapes[0].ply")
    obj = read_obj(tmp_path / "m.obj", "shapes[0].obj")
    v, f = obj.vertices, obj.faces
    np.testing.assert_array_equal(mesh.vertices, v)
    np.testing.assert_array_equal(mesh.faces, f)
    np.testing.assert_array_equal(mesh.faces, FANS)
    np.testing.assert_array_equal(mesh.normals, NORMALS)
    np.testing.assert_array_equal(mesh.uvs, UVS)
    # the file's values in the narrowest exact type (ply_reader.parse_ply): text parses to float64/int64,
    # a binary file's float stays float32, its indices int32 (uint32 for uint)
    real = np.float64 if kind == "ascii" else np.float32
    index = np.int64 if kind == "ascii" else np.uint32 if kind == "<u4" else np.int32
    assert mesh.vertices.dtype == mesh.normals.dtype == mesh.uvs.dtype == real and mesh.faces.dtype == index


def test_ascii_integer_elements_parse_alike_however_laid_out():
    """The faces' integers are parsed apart from the vertices' floats (ply_reader.ascii_numbers): records
    across lines, integers written as floats and a body without faces read as the plain layout does."""
    want = parse_ply(ascii_ply(), "a")
    head, body = ascii_ply().split(b"end_header\n")
    lines = body.split(b"\n")
    for label, text in (("records across lines", b"\n".join(lines).replace(b" ", b"\n", 7)),
                        ("one line", b" ".join(lines)),
                        ("float indices", b"\n".join(lines[:6] + [x + b".0" if x else x for x in lines[6:]])),
                        ("CRLF", b"\r\n".join(lines))):
        got = parse_ply(head + b"end_header\n" + text, label)
        np.testing.assert_array_equal(got.vertices, want.vertices, err_msg=label)
        np.testing.assert_array_equal(got.faces, want.faces, err_msg=label)
        np.testing.assert_array_equal(got.uvs, want.uvs, err_msg=label)
    empty = header("ascii", 1, 0) + b"1 2 3\n\n"  # no faces: the whitespace after the vertex is no number
    assert len(parse_ply(empty, "e").faces) == 0
    with pytest.raises(InputError, match="after the last element"):
        parse_ply(header("ascii", 1, 0) + b"1 2 3\n 4\n", "x")


@pytest.mark.parametrize("order", ["ascii", "<", ">"])
def test_equal_polygons_read_as_a_block_and_mixed_by_the_scan_agree(order):
    tris = [[i, (i + 1) % 6, (i + 3) % 6] for i in range(6)] * 50
    quads = [[i, (i + 1) % 6, (i + 2) % 6, (i + 4) % 6] for i in range(6)] * 50
    mixed = [p for pair in zip(tris, quads) for p in pair]
    make = ascii_ply if order == "ascii" else (lambda polys: binary_ply(order, polys))
    block = np.concatenate([parse_ply(make(tris), "t").faces, parse_ply(make(quads), "q").faces])
    scan = parse_ply(make(mixed), "m").faces
    assert len(scan) == len(block) == 300 + 600
    interleaved = np.concatenate([scan[i * 3:i * 3 + 3] for i in range(300)])  # each triangle, then its quad's two
    np.testing.assert_array_equal(np.sort(interleaved, axis=0), np.sort(block, axis=0))
    np.testing.assert_array_equal(scan[:3], [tris[0], quads[0][:3], [quads[0][0], *quads[0][2:]]])


def test_large_binary_ply_parses(tmp_path):
    n = 10**5
    rng = np.random.default_rng(1)
    f = rng.integers(0, n // 2, (n, 3))
    rec = np.zeros(n, np.dtype([("c", "u1"), ("i", "<i4", (3,))]))
    rec["c"], rec["i"] = 3, f
    verts = rng.random((n // 2, 3)).astype("<f4")
    mesh = parse_ply(header("binary_little_endian", n // 2, n) + verts.tobytes() + rec.tobytes(), "big.ply")
    np.testing.assert_array_equal(mesh.faces, f)
    np.testing.assert_array_equal(mesh.vertices, verts)
    assert mesh.normals is None and mesh.uvs is None


GOOD = binary_ply("<")


@pytest.mark.parametrize("data,message", [
    (b"plx\n" + GOOD[4:], r"not a PLY file"),
    (GOOD.replace(b"comment written", b"remark written"), r":3: unknown header line 'remark written"),
    (GOOD.split(b"end_header")[0], r"no 'end_header' line"),
    (GOOD.replace(b"format binary_little_endian 1.0", b"format binary 1.0"), r":2: bad format line"),
    (GOOD.replace(b"format binary_little_endian 1.0\n", b""), r"no 'format' line"),
    (GOOD.replace(b"element vertex 6", b"element vertex six"), r":4: bad element line"),
    (GOOD.replace(b"property float x", b"property real x"), r":5: bad property line 'property real x'"),
    (GOOD.replace(b"property float x", b"property float q"), r"needs scalar properties x, y and z \(missing 'x'\)"),
    (GOOD.replace(b"list uchar int", b"list float int"), r"count type must be an integer"),
    (GOOD.replace(b"element edge", b"element face"), r":15: a second element 'face'"),
    (GOOD.replace(b"vertex_indices", b"corners"), r"needs a list property vertex_indices"),
    (GOOD.replace(b"element vertex 6", b"element vertex 7"), r"overrun|after the last element"),
    (GOOD.replace(b"element vertex 6", b"element vertex 5"), r"face index 5 is outside 0\.\.4|overrun"),
    (GOOD.replace(b"element face 4", b"element face 3"), r"bytes after the last element"),
    (GOOD.replace(b"element face 4", b"element face 9"), r"overrun"),
    (GOOD[:-9], r"'edge' element's 2 records overrun the file"),
    (GOOD[:-30], r"overrun"),
    (binary_ply("<", [[0, 1, 2], [0, 7, 1]]), r"face index 7 is outside 0\.\.5"),
    (binary_ply("<", [[0, 1, 2], [0, 1]]), r"face 1 has 2 corners"),
    (ascii_ply().replace(b"\n3 ", b"\n3.5 "), r"overrun"),
    (ascii_ply().replace(b"\n3 0 1 2", b"\n3 0 1 x"), r"not a number"),
    (ascii_ply().replace(b"\n3 0 1 2", b"\n3 0 1 2.5"), r"not an integer"),
    (ascii_ply() + b"7\n", r"1 numbers after the last element"),
])
def test_malformed_files_are_refused_naming_the_file(tmp_path, data, message):
    (tmp_path / "m.ply").write_bytes(data)
    with pytest.raises(InputError, match=r"shapes\[0\]\.ply: .*m\.ply.*" + message):
        read_ply(tmp_path / "m.ply", "shapes[0].ply")


def _scene(shape: dict) -> dict:
    return {"camera": {"origin": [0, 0, 3], "target": [0, 0, 0], "fov": 40, "width": 4, "height": 4},
            "materials": {"m": {"type": "diffuse", "reflectance": 0.5}}, "shapes": [shape]}


def test_scene_ply_key_confined_to_the_scene_folder(tmp_path):
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / "m.ply").write_bytes(GOOD)
    (tmp_path / "out.ply").write_bytes(GOOD)
    sh = parse_scene(_scene({"type": "mesh", "material": "m", "ply": "m.ply"}), tmp_path / "s" / "a.json").shapes[0]
    np.testing.assert_array_equal(sh.faces, FANS)
    np.testing.assert_array_equal(sh.normals, NORMALS)  # kept for later shading normals
    with pytest.raises(InputError, match=r"a\.json: shapes\[0\]\.ply: '\.\./out\.ply' lies outside the scene's folder"):
        parse_scene(_scene({"type": "mesh", "material": "m", "ply": "../out.ply"}), tmp_path / "s" / "a.json")
    with pytest.raises(InputError, match=r"shapes\[0\]\.ply: give one of vertices/faces, obj or ply"):
        parse_scene(_scene({"type": "mesh", "material": "m", "ply": "m.ply", "obj": "x.obj"}), tmp_path / "s" / "a.json")
    (tmp_path / "s" / "nofaces.ply").write_bytes(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                                                 b"property float y\nproperty float z\nend_header\n0 0 0\n")
    with pytest.raises(InputError, match=r"shapes\[0\]\.ply: .*nofaces\.ply holds no faces"):
        parse_scene(_scene({"type": "mesh", "material": "m", "ply": "nofaces.ply"}), tmp_path / "s" / "a.json")


def test_disk_and_cylinder_areas_are_the_inscribed_polygons():
    for segments in (16, 128, 1024):
        for build, exact, rel in ((shape_lib.disk, math.pi, (2 * math.pi / segments) ** 2 / 6),
                                  (shape_lib.cylinder, 2 * math.pi, (math.pi / segments) ** 2 / 6)):
            v, f = build(segments)
            t = v[f]
            cross = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
            area = 0.5 * np.linalg.norm(cross, axis=1).sum()
            assert abs(area / exact - (1 - rel)) < 2 * rel ** 2 + 1e-13  # the series' next term bounds the rest
            centre = t.mean(axis=1)
            if build is shape_lib.disk:
                assert np.all(cross[:, 2] > 0) and np.all(v[:, 2] == 0)  # front side +z
            else:
                assert np.all(np.einsum("ij,ij->i", cross[:, :2], centre[:, :2]) > 0)  # outwards
                assert np.all(cross[:, 2] == 0) and v[:, 2].min() == 0 and v[:, 2].max() == 1
    assert len(shape_lib.disk()[1]) == shape_lib.SEGMENTS == 128
    scene = _scene({"type": "disk", "material": "m", "emitter": {"type": "area", "radiance": 1}})
    scene["shapes"].append({"type": "cylinder", "material": "m", "transform": [{"translate": [0, 0, -2]}]})
    cs = compile_scene(parse_scene(scene, "t.json"))
    assert cs.num_triangles == 128 + 256
    r = mcocl.render(cs, spp=2, seed=1)
    assert r.mean[1:3, 1:3].min() > 0  # the camera on +z sees the disk's emitting front side


SENSOR = """<sensor type="perspective"><float name="fov" value="45"/>
    <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film></sensor>"""


def test_importer_maps_ply_disk_and_cylinder(tmp_path):
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "a.ply").write_bytes(GOOD)
    p = tmp_path / "s.xml"
    p.write_text(f"""<scene version="3.0.0">{SENSOR}
<shape type="ply"><string name="filename" value="m/a.ply"/><boolean name="face_normals" value="true"/>
  <boolean name="flip_normals" value="true"/>
  <transform name="to_world"><translate x="1"/></transform></shape>
<shape type="disk"><transform name="to_world"><scale value="2"/></transform></shape>
<shape type="cylinder"/>
<shape type="cylinder"><point name="p0" x="1" y="2" z="3"/><point name="p1" x="1" y="2" z="1"/>
  <float name="radius" value="0.5"/></shape>
</scene>""")
    d = read_mitsuba(p)
    kinds = [(s["type"], s.get("ply"), s.get("flip_normals", False)) for s in d["shapes"]]
    assert kinds == [("mesh", "m/a.ply", True), ("disk", None, False), ("cylinder", None, False),
                     ("cylinder", None, False)]
    scene = load_scene(p)
    ply, disk, cyl, moved = scene.shapes
    np.testing.assert_array_equal(ply.faces, FANS)
    np.testing.assert_array_equal(ply.matrix[:3, 3], [1, 0, 0])
    assert len(disk.faces) == 128 and np.allclose(disk.matrix[:3, :3], 2 * np.eye(3))
    np.testing.assert_array_equal(cyl.matrix, np.eye(4))
    world = (moved.matrix @ np.c_[moved.vertices, np.ones(len(moved.vertices))].T).T[:, :3]
    np.testing.assert_allclose(np.linalg.norm(world[:, :2] - [1, 2], axis=1), 0.5, atol=1e-12)
    np.testing.assert_allclose(np.sort(np.unique(world[:, 2].round(12))), [1, 3])
    (tmp_path / "out").mkdir()
    assert main(["convert", str(p), "-o", str(tmp_path / "out" / "s.json")]) == 0  # the PLY path rewritten for out/
    assert json.loads((tmp_path / "out" / "s.json").read_text())["shapes"][0]["ply"] == "../m/a.ply"
    p.write_text(f'<scene version="3.0.0">{SENSOR}\n<shape type="ply"/></scene>')
    with pytest.raises(InputError, match=r"s\.xml:\d+: <shape type=\"ply\">: a ply shape needs <string"):
        read_mitsuba(p)


def test_cornell_with_ply_meshes_renders_as_with_obj_meshes(tmp_path):
    data = json.loads((SCENES / "cornell.json").read_text())
    data["camera"].update(width=8, height=8)
    geometry = {"rectangle": shape_lib.rectangle(), "cube": shape_lib.cube()}
    for name, (v, f) in geometry.items():
        (tmp_path / f"{name}.obj").write_text("".join("v " + " ".join(repr(float(x)) for x in r) + "\n" for r in v)
                                              + "".join("f " + " ".join(str(i + 1) for i in t) + "\n" for t in f))
        rec = np.zeros(len(f), np.dtype([("c", "u1"), ("i", ">u4", (3,))]))
        rec["c"], rec["i"] = 3, f
        (tmp_path / f"{name}.ply").write_bytes(
            header("binary_big_endian", len(v), len(f), "double x\nproperty double y\nproperty double z",
                   "list uchar uint vertex_indices") + v.astype(">f8").tobytes() + rec.tobytes())
    twins = {}
    for kind in ("obj", "ply"):
        d = json.loads(json.dumps(data))
        for s in d["shapes"]:
            s[kind] = f"{s['type']}.{kind}"
            s["type"] = "mesh"
        twins[kind] = parse_scene(d, tmp_path / f"{kind}.json")
    a, b = compile_scene(twins["obj"]), compile_scene(twins["ply"])
    np.testing.assert_array_equal(a.tri_vertices, b.tri_vertices)
    np.testing.assert_array_equal(a.tri_vertices, compile_scene(parse_scene(data, SCENES / "cornell.json")).tri_vertices)
    r_obj, r_ply = (mcocl.render(twins[k], spp=2, seed=3) for k in ("obj", "ply"))
    assert np.array_equal(r_obj.mean, r_ply.mean) and np.array_equal(r_obj.variance, r_ply.variance)
    assert (r_ply.mean.sum(-1) > 0).mean() > 0.5  # mostly lit: not two black images


@pytest.mark.parametrize("order", ["<", ">"])
def test_binary_float32_meshes_compile_as_their_float64_twins(tmp_path, order):
    """A binary file's float32 data stays float32 (ply_reader.parse_ply) and widens in compile_scene: the device
    tables, shading normals and UVs equal those of the ASCII twin, read as float64, under a mirroring transform."""
    (tmp_path / "b.ply").write_bytes(binary_ply(order))
    (tmp_path / "a.ply").write_bytes(ascii_ply())
    assert read_ply(tmp_path / "b.ply", "b").vertices.dtype == np.float32
    assert read_ply(tmp_path / "a.ply", "a").vertices.dtype == np.float64
    tables = []
    for name in ("b.ply", "a.ply"):
        scene = {"camera": {"origin": [0, 0, 6], "target": [0, 0, 0], "fov": 40, "width": 4, "height": 4},
                 "materials": {"m": {"type": "diffuse", "reflectance": 0.5}},
                 "shapes": [{"type": "mesh", "ply": name, "material": "m", "emitter": {"type": "area", "radiance": 1},
                             "transform": [{"scale": [1.3, -0.7, 0.9]}, {"rotate": {"axis": [1, 2, 3], "angle": 33}}]}]}
        sc = parse_scene(scene, tmp_path / "s.json")
        cs = compile_scene(sc)
        tables.append({k: v for k, v in cs.__dict__.items() if isinstance(v, np.ndarray)} | {"uvs": triangle_uvs(sc.shapes)})
    assert tables[0].keys() == tables[1].keys() and "normal_table" in tables[0]
    for k in tables[0]:
        assert tables[0][k].dtype == tables[1][k].dtype and np.array_equal(tables[0][k], tables[1][k]), k


def test_mutated_files_raise_input_error_only():
    # Random byte edits, deletions and insertions of PLY files: each one parses or is refused with an
    # InputError (never another exception, never a warning).
    rng = np.random.default_rng(0)
    seeds = [binary_ply("<"), binary_ply(">"), ascii_ply(), binary_ply("<", [[0, 1, 2]] * 5)]
    refused = 0
    for it in range(1500):
        d = bytearray(seeds[it % 4])
        for _ in range(rng.integers(1, 4)):
            i = rng.integers(0, len(d))
            op = rng.integers(0, 3)
            if op == 0:
                d[i] = rng.integers(0, 256)
            elif op == 1:
                del d[i:i + rng.integers(1, 10)]
            else:
                d[i:i] = b"9999999999" if rng.random() < 0.5 else bytes([rng.integers(0, 256)])
        try:
            m = parse_ply(bytes(d), "f.ply")
            shape_lib.check_mesh(m.vertices, m.faces, "f.ply")
        except InputError as e:
            assert str(e).startswith("f.ply")
            refused += 1
    assert 300 < refused < 1500


def test_a_huge_count_is_refused_before_allocating():
    for data in (GOOD.replace(b"element face 4", b"element face 999999999999999"),
                 GOOD.replace(b"element vertex 6", b"element vertex 999999999999999")):
        with pytest.raises(InputError, match=r"999999999999999 records overrun the file"):
            parse_ply(data, "h.ply")
