"""OBJ reading (mcocl/render/obj_reader.py through shapes.read_obj): records, forms, errors with line numbers."""

from __future__ import annotations

import numpy as np
import pytest

from mcocl.errors import InputError
from mcocl.render import obj_reader
from mcocl.render.shapes import read_obj

SQUARE = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"


def read(tmp_path, text: str | bytes):
    p = tmp_path / "m.obj"
    p.write_bytes(text.encode() if isinstance(text, str) else text)
    mesh = read_obj(p, "shapes[0].obj")
    return mesh.vertices, mesh.faces


@pytest.mark.parametrize("text,faces", [
    (SQUARE + "f 1 2 3\nf 1 3 4\n", [[0, 1, 2], [0, 2, 3]]),
    (SQUARE + "vt 0 0\nvn 0 0 1\nf 1/1 2/1 3/1\nf 1//1 3//1 4//1\nf 1/1/1 2/1/1 4/1/1\n",
     [[0, 1, 2], [0, 2, 3], [0, 1, 3]]),
    ("v 0 0 0\nv 1 0 0\nv 1 1 0\nf -3 -2 -1\nv 0 1 0\nf -4 -2 -1\n", [[0, 1, 2], [0, 2, 3]]),  # negatives: so far
    (SQUARE + "f 1 2 3 4\nf 4 3 2 1 1\n", [[0, 1, 2], [0, 2, 3], [3, 2, 1], [3, 1, 0], [3, 0, 0]]),  # fans
    ("# c\n  v 0 0 0 # c\n\tv 1 0 0\nv 1 1 0\n#f 1 2 3\nf 1 2 3#x\n   \n", [[0, 1, 2]]),  # comments, indentation
    ("v 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nf 1 2 3\r\n", [[0, 1, 2]]),
    ("v 0 0 0\rv 1 0 0\rv 1 1 0\rf 1 2 3", [[0, 1, 2]]),  # old Mac line breaks, no final one
    ("o x\ng y\nusemtl m\ns off\nvp 1\nl 1 2\nv 0 0 0\nv 1 0 0\nv 1 1 0\nf +1 0002 000000000003/7//\n", [[0, 1, 2]]),
])
def test_faces_forms_and_records(tmp_path, text, faces):
    v, f = read(tmp_path, text)
    np.testing.assert_array_equal(f, faces)
    assert v.shape[1] == 3 and v.dtype == np.float64


def test_vertex_numbers(tmp_path):
    v, f = read(tmp_path, "v 1e-3 -2.5E+2 .5\nv 1. 0 0 1\nv 1 1 0 0.5 0.5 0.5\nf 1 2 3\n")
    np.testing.assert_array_equal(v, [[1e-3, -250.0, 0.5], [1, 0, 0], [1, 1, 0]])  # extra numbers ignored
    assert f.shape == (1, 3)
    v, f = read(tmp_path, "v 0 0 0\n")
    assert v.shape == (1, 3) and f.shape == (0, 3)
    v, f = read(tmp_path, "")
    assert v.shape == (0, 3) and f.shape == (0, 3)


@pytest.mark.parametrize("text,message", [
    ("v 0 0 0\nv 1 0\n", r"m.obj:2: a vertex needs three numbers"),
    ("v 0 0 0\nv 1 x 0\n", r"m.obj:2: a vertex needs three numbers"),
    ("v\n", r"m.obj:1: a vertex needs three numbers"),
    ("v nan 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n", r"non-finite"),
    (SQUARE + "f 0 1 2\n", r"m.obj:5: OBJ indices start at 1, got 0"),
    (SQUARE + "f 1 2 3\nf 1 2\n", r"m.obj:6: a face needs at least three corners"),
    (SQUARE + "f 1 2 x\n", r"m.obj:5: bad face corner 'x'"),
    (SQUARE + "f /1 2 3\n", r"m.obj:5: bad face corner '/1'"),
    (SQUARE + "f 1 2 3.0\n", r"m.obj:5: bad face corner '3.0'"),
    (SQUARE + "f 1 2 -\n", r"m.obj:5: bad face corner '-'"),
    (SQUARE + "f 1 2 3-1\n", r"m.obj:5: bad face corner '3-1'"),
    (SQUARE + "f 1 2 1234567890123456789012\n", r"m.obj:5: bad face corner"),
    (SQUARE + "f 1 2 7\n", r"face index 6 is outside 0..3"),
    (SQUARE + "f -1 -2 -5\n", r"face index -1 is outside 0..3"),
])
def test_errors_name_the_line(tmp_path, text, message):
    with pytest.raises(InputError, match=r"shapes\[0\]\.obj: .*" + message):
        read(tmp_path, text)


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match=r"shapes\[0\]\.obj: cannot read OBJ file"):
        read_obj(tmp_path / "none.obj", "shapes[0].obj")


def random_obj(rng: np.random.Generator, nv: int, nf: int, interleave: bool) -> tuple[str, np.ndarray, np.ndarray]:
    """OBJ text of a random polygon mesh in mixed corner forms and index signs, and its vertices and fan triangles."""
    v = np.round(rng.normal(size=(nv, 3)), 6)
    corners = rng.integers(3, 7, nf)
    idx = [rng.integers(0, nv, m) for m in corners]
    vlines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in v]
    tri = []
    flines = []
    for ids in idx:
        parts = []
        for i in ids:
            num = str(i + 1) if rng.uniform() < 0.5 else str(i - nv)  # negative: from the end (all read first)
            form = rng.integers(0, 4)
            parts.append([num, f"{num}/{rng.integers(1, 9)}", f"{num}//{rng.integers(1, 9)}",
                          f"{num}/{rng.integers(1, 9)}/{rng.integers(1, 9)}"][form])
        flines.append("f " + " ".join(parts))
        tri += [[ids[0], ids[k], ids[k + 1]] for k in range(1, len(ids) - 1)]
    if interleave:  # vertices first, then faces alternating with other records
        lines = vlines + [x for fl in flines for x in (fl, "vn 0 0 1")]
    else:
        lines = vlines + flines
    return "\n".join(lines) + "\n", v, np.array(tri)


@pytest.mark.parametrize("chunk", [None, 997, 20])  # the file in one chunk, in many, lines longer than one
@pytest.mark.parametrize("interleave", [False, True])
def test_random_polygon_meshes_round_trip(tmp_path, monkeypatch, interleave, chunk):
    if chunk:
        monkeypatch.setattr(obj_reader, "CHUNK_BYTES", chunk)
    rng = np.random.default_rng(5 + interleave)
    text, v, tri = random_obj(rng, 500, 2000, interleave)
    if interleave:  # negative indices that count back across chunk boundaries
        text += "v 7 8 9\nf -1 -2 -501\n"
        v = np.concatenate([v, [[7, 8, 9]]])
        tri = np.concatenate([tri, [[500, 499, 0]]])
    rv, rf = read(tmp_path, text)
    np.testing.assert_array_equal(rv, v)
    np.testing.assert_array_equal(rf, tri)


@pytest.mark.parametrize("chunk", [None, 4096])
def test_bad_line_deep_in_a_large_file(tmp_path, monkeypatch, chunk):
    if chunk:
        monkeypatch.setattr(obj_reader, "CHUNK_BYTES", chunk)
    rng = np.random.default_rng(9)
    text, v, tri = random_obj(rng, 3000, 100, False)
    lines = text.splitlines()
    lines[1234] = "v 1 2 3e"
    with pytest.raises(InputError, match=r"m.obj:1235: a vertex needs three numbers"):
        read(tmp_path, "\n".join(lines))
    lines[1234] = "v 1 2 3"
    lines[3050] = lines[3050] + " 7x"
    with pytest.raises(InputError, match=r"m.obj:3051: bad face corner '7x'"):
        read(tmp_path, "\n".join(lines))
