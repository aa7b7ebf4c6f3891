"""Mitsuba serialized meshes (mcocl/render/serialized_reader.py) and ``face_normals``.

A tiny writer here produces files from the format's documented layout
(uint16 0x041C and the version, a zlib stream with flags, the v4 name, the
counts and the arrays, the table of mesh offsets and the mesh count at the
end); Mitsuba 3.9.1 reads files from this writer back to the same arrays
(checked by hand when the reader was written).  Round trips in both versions
and precisions, ``shape_index``, the XML plugin, and the errors of corrupt files.
"""

from __future__ import annotations

import json
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

from mcocl.errors import InputError
from mcocl.render.compiled import compile_scene
from mcocl.render.scene_file import load_scene
from mcocl.render.serialized_reader import mesh_count, parse_serialized
from mcocl.render.shapes import read_serialized

QUAD = {"vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], "faces": [[0, 1, 2], [1, 3, 2]],
        "normals": [[0, 0, 1], [0, 0.6, 0.8], [0.6, 0, 0.8], [0, 0, 1]], "uvs": [[0, 0], [1, 0], [0, 1], [1, 1]],
        "name": "quad"}
TET = {"vertices": [[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2.5]],
       "faces": [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], "name": "tet", "face_normals": True}


def write_serialized(path: Path, meshes: list[dict], version: int = 4, double: bool = False) -> bytes:
    """Write ``meshes`` in Mitsuba's serialized layout; returns the bytes."""
    out, offsets = bytearray(), []
    ftype = "<f8" if double else "<f4"
    for m in meshes:
        offsets.append(len(out))
        flags = 0x2000 if double else 0x1000
        flags |= (0x0001 if "normals" in m else 0) | (0x0002 if "uvs" in m else 0)
        flags |= 0x0010 if m.get("face_normals") else 0
        body = struct.pack("<I", flags) + ((m.get("name", "").encode() + b"\0") if version == 4 else b"")
        body += struct.pack("<QQ", len(m["vertices"]), len(m["faces"]))
        for k in ("vertices", "normals", "uvs"):
            if k in m:
                body += np.asarray(m[k], np.float64).astype(ftype).tobytes()
        body += np.asarray(m["faces"], "<u4").tobytes()
        out += struct.pack("<HH", 0x041C, version) + zlib.compress(body)
    out += np.array(offsets, "<u8" if version == 4 else "<u4").tobytes() + struct.pack("<I", len(meshes))
    path.write_bytes(bytes(out))
    return bytes(out)


@pytest.mark.parametrize("version,double", [(4, False), (3, True), (4, True)])
def test_round_trip(tmp_path: Path, version: int, double: bool) -> None:
    data = write_serialized(tmp_path / "m.serialized", [QUAD, TET], version, double)
    assert mesh_count(data, "m") == 2
    q = parse_serialized(data, 0, "m")
    tol = 0 if double else 1e-7
    np.testing.assert_allclose(q.vertices, QUAD["vertices"], atol=tol)
    np.testing.assert_array_equal(q.faces, QUAD["faces"])
    np.testing.assert_allclose(q.normals, QUAD["normals"], atol=tol)
    np.testing.assert_allclose(q.uvs, QUAD["uvs"], atol=tol)
    assert q.name == ("quad" if version == 4 else "") and not q.face_normals
    # the file's precision and uint32 indices, as views of one inflated body (serialized_reader.parse_serialized)
    assert q.vertices.dtype == q.normals.dtype == q.uvs.dtype == (np.float64 if double else np.float32)
    assert q.faces.dtype == np.uint32 and not (q.vertices.flags.owndata or q.faces.flags.owndata)
    t = parse_serialized(data, 1, "m")
    np.testing.assert_allclose(t.vertices, TET["vertices"], atol=tol)
    np.testing.assert_array_equal(t.faces, TET["faces"])
    assert t.normals is None and t.uvs is None and t.face_normals


def test_open_file_reads_as_bytes(tmp_path: Path, monkeypatch) -> None:
    """An open file (read where the parse looks: shapes.read_serialized, which never reads it whole) gives the
    bytes' arrays bit for bit, over a mesh whose compressed bytes span many inflate slices, and the same errors."""
    rng = np.random.default_rng(5)
    big = {"vertices": rng.random((60_000, 3)), "faces": rng.integers(0, 60_000, (40_000, 3)),
           "normals": rng.random((60_000, 3)), "uvs": rng.random((60_000, 2)), "name": "big"}
    path = tmp_path / "m.serialized"
    data = write_serialized(path, [QUAD, big, TET])
    assert len(data) > 20 * 65536  # many slices of serialized_reader._INFLATE_STEP
    with path.open("rb") as f:
        assert mesh_count(f, "m") == 3
        for k in range(3):
            a, b = parse_serialized(data, k, "m"), parse_serialized(f, k, "m")
            for name in ("vertices", "faces", "normals", "uvs"):
                x, y = getattr(a, name), getattr(b, name)
                assert (x is None and y is None) or (x.dtype == y.dtype and x.tobytes() == y.tobytes())
            assert (a.name, a.face_normals) == (b.name, b.face_normals)
    monkeypatch.setattr(Path, "read_bytes", lambda self: pytest.fail(f"{self} read whole"))
    got = read_serialized(path, 1, "k")
    assert got.vertices.tobytes() == parse_serialized(data, 1, "m").vertices.tobytes()
    monkeypatch.undo()
    cut = bytearray(data)
    cut[10:30] = bytes(20)
    path.write_bytes(bytes(cut))
    with path.open("rb") as f, pytest.raises(InputError, match="corrupt zlib data"):
        parse_serialized(f, 0, "m")


def test_scene_json_and_xml(tmp_path: Path) -> None:
    write_serialized(tmp_path / "m.serialized", [QUAD, TET])
    cam = {"origin": [0.5, 0.5, 5], "target": [0.5, 0.5, 0], "fov": 40, "width": 8, "height": 8}
    scene = {"camera": cam, "materials": {"w": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}},
             "shapes": [{"type": "mesh", "serialized": "m.serialized", "shape_index": 1, "material": "w"},
                        {"type": "mesh", "serialized": "m.serialized", "material": "w"},
                        {"type": "mesh", "serialized": "m.serialized", "material": "w", "face_normals": True}]}
    (tmp_path / "s.json").write_text(json.dumps(scene))
    s = load_scene(tmp_path / "s.json")
    assert len(s.shapes[0].faces) == 4 and s.shapes[0].normals is None
    assert len(s.shapes[1].faces) == 2 and s.shapes[1].normals is not None
    assert s.shapes[2].normals is None  # face_normals drops the vertex normals
    assert compile_scene(s).num_triangles == 8
    (tmp_path / "s.xml").write_text(
        '<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/></sensor>'
        '<shape type="serialized"><string name="filename" value="m.serialized"/>'
        '<integer name="shape_index" value="1"/></shape></scene>')
    sx = load_scene(tmp_path / "s.xml")
    np.testing.assert_allclose(sx.shapes[0].vertices, TET["vertices"], atol=1e-7)


def test_corrupt_files(tmp_path: Path) -> None:
    data = write_serialized(tmp_path / "m.serialized", [QUAD, TET])
    with pytest.raises(InputError, match="shape_index 2 is out of range"):
        parse_serialized(data, 2, "m")
    with pytest.raises(InputError, match="not a serialized"):
        parse_serialized(b"ply\n" + data[4:], 0, "m")
    with pytest.raises(InputError, match="table"):
        parse_serialized(data[:-4] + struct.pack("<I", 7), 0, "m")
    cut = bytearray(data)
    cut[10:30] = bytes(20)  # inside the first zlib stream
    with pytest.raises(InputError, match="mesh 0"):
        parse_serialized(bytes(cut), 0, "m")
    # counts that the compressed bytes cannot hold: refused before inflating
    body = struct.pack("<I", 0x1000) + b"x\0" + struct.pack("<QQ", 10**9, 10**9)
    bomb = struct.pack("<HH", 0x041C, 4) + zlib.compress(body)
    bomb += struct.pack("<Q", 0) + struct.pack("<I", 1)
    with pytest.raises(InputError, match="cannot come from"):
        parse_serialized(bomb, 0, "m")
    with pytest.raises(InputError, match="shape_index"):
        bad = {"camera": {"origin": [0, 0, 5], "target": [0, 0, 0], "fov": 40, "width": 8, "height": 8},
               "materials": {"w": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}},
               "shapes": [{"type": "mesh", "ply": "m.ply", "shape_index": 1, "material": "w"}]}
        (tmp_path / "b.json").write_text(json.dumps(bad))
        load_scene(tmp_path / "b.json")
