"""Inline mesh arrays read by NumPy (mcocl/render/json_arrays.py): the same numbers and the same errors as
``json.loads`` and the checker's list walk, without a Python object per number (issue 13)."""

from __future__ import annotations

import json
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

import mcocl
from mcocl.render import json_arrays
from mcocl.render.json_arrays import read_json_with_arrays
from mcocl.render.scene import Scene, parse_scene
from mcocl.render.scene_file import _read_json_exact, load_scene

SCENE = {
    "camera": {"origin": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 40, "width": 8, "height": 6},
    "integrator": {"type": "nee", "max_depth": 3, "rr_depth": 2, "spp": 4},
    "materials": {"w": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}},
    "shapes": [
        {"type": "sphere", "material": "w", "center": [0, 2, 0], "radius": 0.5,
         "emitter": {"type": "area", "radiance": 3}},
        {"type": "mesh", "material": "w", "vertices": "@V@", "faces": "@F@"},
    ],
}


def write_scene(path: Path, vertices: str, faces: str, scene: dict | None = None) -> Path:
    """SCENE (or ``scene``) with the mesh's vertices and faces given as raw JSON text."""
    text = json.dumps(scene or SCENE, indent=1)
    path.write_text(text.replace('"@V@"', vertices).replace('"@F@"', faces))
    return path


def load_exact(path: Path) -> Scene:
    """The scene read the way load_scene read every JSON file before: json.loads, then the list walk."""
    return parse_scene(_read_json_exact(path), path)


def outcome(load, path: Path) -> tuple[str, str] | tuple[bytes, bytes]:
    """The mesh's array bytes, or the error's type and message."""
    try:
        mesh = load(path).shapes[-1]
    except Exception as e:  # noqa: BLE001 -- the two paths must fail alike, whatever the error
        return type(e).__name__, str(e)
    return mesh.vertices.dtype.str.encode() + mesh.vertices.tobytes(), mesh.faces.dtype.str.encode() + mesh.faces.tobytes()


def number_texts(rng: np.random.Generator, n: int) -> list[str]:
    """``n`` JSON numbers written every way a file may write them (json.loads reads each exactly)."""
    fixed = ["0", "-0", "-0.0", "0.0", "0e0", "-0e-0", "-0E+00", "1e-400", "-1e-400", "5e-324", "4.9e-324",
             "2.2250738585072014e-308", "1e15", "-1e15", "999999999999999", "123456789012345",
             "0.1000000000000000055511151231257827021181583404541015625", "123456789012345678e-3",
             "1E+2", "1e2", "1.5E-7", "9007199254740993", "-9007199254740993", "0.30000000000000004",
             "1.7976931348623157e-300", "3", "-17"]
    out = []
    for k in range(n):
        x = float(rng.standard_normal() * 10.0 ** rng.integers(-12, 12))
        form = k % 8
        if form == 0:
            out.append(repr(x))
        elif form == 1:
            out.append(f"{x:.17g}")
        elif form == 2:
            out.append(f"{x:.3e}")
        elif form == 3:
            out.append(f"{x:.9E}")
        elif form == 4:
            out.append(str(int(rng.integers(-10**15, 10**15))))
        elif form == 5:
            out.append(str(np.float32(x)))  # float32's shortest digits, as mesh exporters write them
        elif form == 6:
            out.append(fixed[int(rng.integers(len(fixed)))])
        else:
            out.append(f"{x:.25f}")
    return out


def rows_text(numbers: list[str], width: int, rng: np.random.Generator) -> str:
    """The numbers as a JSON list of rows, with JSON's four kinds of blank in varied runs."""
    blanks = ["", " ", "  ", "\n", "\t", "\r\n ", " \n\t"]

    def b() -> str:
        return blanks[int(rng.integers(len(blanks)))]

    rows = [f"[{b()}" + f"{b()},{b()}".join(numbers[i:i + width]) + f"{b()}]" for i in range(0, len(numbers), width)]
    return f"[{b()}" + f"{b()},{b()}".join(rows) + f"{b()}]"


@pytest.mark.parametrize("block", [None, 97, 1000])
def test_numbers_equal_json_loads_bit_for_bit(tmp_path, monkeypatch, block):
    """Every number form, across block boundaries (small blocks cut rows and numbers), equals json.loads'."""
    if block is not None:
        monkeypatch.setattr(json_arrays, "BLOCK", block)
        monkeypatch.setattr(json_arrays, "MARGIN", 512)
    rng = np.random.default_rng(20261202)
    numbers = number_texts(rng, 3 * 700)
    nv = len(numbers) // 3
    faces = [str(int(i)) for i in rng.integers(0, nv, 3 * 500)] + ["-0", "0", str(nv - 1)]
    vtext, ftext = rows_text(numbers, 3, rng), rows_text(faces, 3, rng)
    p = write_scene(tmp_path / "s.json", vtext, ftext)
    data, arrays = read_json_with_arrays(p, str(p))
    assert [a.key for a in arrays] == ["vertices", "faces"]
    want_v = np.array(json.loads(vtext), dtype=np.float64)
    want_f = np.array(json.loads(ftext), dtype=np.int64)
    assert arrays[0].values.dtype == np.float64 and arrays[0].values.tobytes() == want_v.tobytes()
    assert arrays[1].values.dtype == np.int64 and arrays[1].values.tobytes() == want_f.tobytes()
    assert np.signbit(want_v).any()  # the forms include -0.0, which must stay negative (and "-0" positive)
    assert isinstance(data["shapes"][1]["vertices"], json_arrays.InlineArray)
    # 2**53 + 1 is beyond the scene's 1e15: both paths refuse the scene alike; without it both read it alike
    assert outcome(load_scene, p) == outcome(load_exact, p)
    p = write_scene(tmp_path / "s.json", vtext.replace("9007199254740993", "900719925474099"), ftext)
    fast = outcome(load_scene, p)
    assert isinstance(fast[0], bytes) and fast == outcome(load_exact, p)


V3 = "[[0, 0, 0], [1, 0, 0], [0, 1, 0]]"
F1 = "[[0, 1, 2]]"


@pytest.mark.parametrize("vertices,faces,where", [
    ("5", F1, "shapes[1].vertices"),
    ('"abc"', F1, "shapes[1].vertices"),
    ("[[0, 0, 0], [1, 0], [0, 1, 0]]", F1, "shapes[1].vertices[1]"),
    ("[[0, 0, 0], [1, 0, 0, 1], [0, 1, 0]]", F1, "shapes[1].vertices[1]"),
    ("[[0, 0, 0, 1], [1, 0, 0, 1], [0, 1, 0, 1]]", F1, "shapes[1].vertices[0]"),
    ("[[0, 0, 0], [1, true, 0], [0, 1, 0]]", F1, "shapes[1].vertices[1][1]"),
    ('[[0, 0, 0], [1, 0, "0"], [0, 1, 0]]', F1, "shapes[1].vertices[1][2]"),
    ("[[0, 0, 0], [1, 0, null], [0, 1, 0]]", F1, "shapes[1].vertices[1][2]"),
    ("[[0, 0, 0], [1, 0, NaN], [0, 1, 0]]", F1, "NaN is not valid JSON"),
    ("[[0, 0, 0], [Infinity, 0, 0], [0, 1, 0]]", F1, "Infinity is not valid JSON"),
    ("[[0, 0, 0], [-Infinity, 0, 0], [0, 1, 0]]", F1, "Infinity is not valid JSON"),
    ("[[0, 0, 0], [1e16, 0, 0], [0, 1, 0]]", F1, "shapes[1].vertices[1]"),
    ("[[0, 0, 0], [1000000000000001, 0, 0], [0, 1, 0]]", F1, "shapes[1].vertices[1]"),
    ("[[0, 0, 0], [1e999, 0, 0], [0, 1, 0]]", F1, "shapes[1].vertices[1]"),
    ("[[0, 0, 0], [01, 0, 0], [0, 1, 0]]", F1, "not valid JSON"),
    ("[[0, 0, 0], [+1, 0, 0], [0, 1, 0]]", F1, "not valid JSON"),
    ("[[0, 0, 0], [.5, 0, 0], [0, 1, 0]]", F1, "not valid JSON"),
    ("[[0, 0, 0], [1., 0, 0], [0, 1, 0]]", F1, "not valid JSON"),
    ("[[0, 0, 0], [1e, 0, 0], [0, 1, 0]]", F1, "not valid JSON"),
    ("[[0, 0, 0], [1 0, 0], [0, 1, 0]]", F1, "not valid JSON"),
    ("[[0, 0, 0], [1, 0, 0], [0, 1, 0],]", F1, "not valid JSON"),
    ("[[0, 0, 0] [1, 0, 0], [0, 1, 0]]", F1, "not valid JSON"),
    ("[[[0, 0, 0]], [1, 0, 0], [0, 1, 0]]", F1, "shapes[1].vertices[0]"),
    ("[]", "[]", None),
    ("[[]]", F1, "shapes[1].vertices[0]"),
    (V3, "[[0, 1, 2.0]]", "shapes[1].faces[0][2]"),
    (V3, "[[0, 1, 2], [0, 1e0, 2]]", "shapes[1].faces[1][1]"),
    (V3, "[[0, 1, 2], [0, 1, 2], [0, 1, 3]]", "shapes[1].faces[2]"),
    (V3, "[[0, 1, -1]]", "shapes[1].faces[0]"),
    (V3, "[[0, 1, 2147483648]]", "shapes[1].faces[0]"),
    (V3, "[[0, 1, 100000000000000000000000000000]]", "shapes[1].faces[0]"),
    (V3, "[[0, 1], [2, 0]]", "shapes[1].faces[0]"),
    (V3, "[[0, 1, 123456789012345678]]", "shapes[1].faces[0]"),  # 18 digits: parsed as int64
    (V3, "[[0, 1, -9223372036854775809]]", "shapes[1].faces[0]"),  # beyond int64: parsed as float64
    (V3, "[[0," + " " * 30 + "1, 2], [2, 1, 0]]", None),  # a long gap between commas: parsed as float64
    (V3, "[[0, 1, 2]", "not valid JSON"),  # the file ends inside the array
])
def test_bad_arrays_give_the_exact_paths_errors(tmp_path, vertices, faces, where):
    """A malformed inline array is refused with the message json.loads and the list walk give, key path and
    row included (the fast path hands such a file to them)."""
    p = write_scene(tmp_path / "bad.json", vertices, faces)
    fast, exact = outcome(load_scene, p), outcome(load_exact, p)
    assert fast == exact
    if where is not None:
        assert fast[0] == "InputError" and where in fast[1], fast


def test_arrays_outside_a_mesh_and_odd_files_read_as_before(tmp_path, monkeypatch):
    """Arrays under these keys where the checker takes no array, repeated keys, a BOM, bytes that are not
    UTF-8 and the placeholder's own key in the file: each read as json.loads reads it."""
    comment = dict(SCENE, comment=["a mesh kept for later", {"vertices": [[1, 2, 3]], "faces": [[0, 0, 0]]}])
    cases = {
        "comment.json": write_scene(tmp_path / "comment.json", V3, F1, comment),
        "twice.json": write_scene(tmp_path / "twice.json", V3 + ', "faces": ' + F1, F1),
        "material.json": write_scene(tmp_path / "material.json", V3, F1, dict(
            SCENE, materials={"w": {"type": "diffuse", "reflectance": 0.5, "faces": [[1, 2, 3]]}})),
    }
    cases["string.json"] = write_scene(tmp_path / "string.json", V3, F1, dict(
        SCENE, comment='a scene once had "vertices": [[1, 2, 3]], "faces": [[0, 1, 2]] here'))
    for name, p in cases.items():
        assert outcome(load_scene, p) == outcome(load_exact, p), name
    for name in ("comment.json", "string.json"):  # valid scenes: the first read the exact way
        assert isinstance(outcome(load_scene, cases[name])[0], bytes), name
    p = write_scene(tmp_path / "bom.json", V3, F1)
    p.write_bytes(b"\xef\xbb\xbf" + p.read_bytes())
    assert outcome(load_scene, p) == outcome(load_exact, p)
    p = write_scene(tmp_path / "latin1.json", V3, F1, dict(SCENE, comment="cafX"))
    p.write_bytes(p.read_bytes().replace(b"cafX", b"caf\xe9"))
    assert outcome(load_scene, p)[0] == "InputError" and outcome(load_scene, p) == outcome(load_exact, p)
    monkeypatch.setattr(json_arrays.secrets, "token_hex", lambda n: "k" * 2 * n)
    p = write_scene(tmp_path / "nonce.json", V3, F1, dict(SCENE, comment={"k" * 32: 0}))
    assert outcome(load_scene, p) == outcome(load_exact, p)


def test_inline_mesh_renders_the_same_image(tmp_path):
    """A scene with an inline mesh, loaded by the fast path and the exact one, renders bit-identically."""
    rng = np.random.default_rng(5)
    grid = np.stack(np.meshgrid(np.linspace(-1, 1, 6), np.linspace(-1, 1, 6)), -1).reshape(-1, 2)
    verts = np.column_stack([grid, 0.2 * rng.standard_normal(len(grid))])
    quads = [(j * 6 + i, j * 6 + i + 1, (j + 1) * 6 + i + 1, (j + 1) * 6 + i) for j in range(5) for i in range(5)]
    faces = [[a, b, c] for a, b, c, _ in quads] + [[a, c, d] for a, _, c, d in quads]
    p = write_scene(tmp_path / "mesh.json", json.dumps([[repr(float(x)) for x in v] for v in verts]).replace('"', ""),
                    json.dumps(faces))
    fast, exact = load_scene(p), load_exact(p)
    a = mcocl.render(fast, spp=4, seed=11)
    b = mcocl.render(exact, spp=4, seed=11)
    assert a.mean.tobytes() == b.mean.tobytes() and a.variance.tobytes() == b.variance.tobytes()
    assert a.mean.max() > 0  # the mesh and the light are in view


def _traced_peak(load, path: Path) -> int:
    """tracemalloc's peak bytes over ``load(path)``."""
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        scene = load(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert len(scene.shapes[-1].faces) > 0
    return peak


def test_loading_a_big_inline_mesh_holds_under_twice_its_file(tmp_path):
    """Issue 13: the load peaks under 2x the file's size (the mesh's arrays included); the exact path, a
    Python object per number, peaks far above the same bound."""
    rng = np.random.default_rng(3)
    nv = 40_000
    verts = rng.standard_normal((nv, 3)).astype(np.float32)
    faces = rng.integers(0, nv, (2 * nv, 3))
    p = tmp_path / "big.json"
    with open(p, "w") as f:
        head, tail = json.dumps(SCENE, indent=1).split('"@V@"')
        mid, tail = tail.split('"@F@"')
        f.write(head + "[")
        np.savetxt(f, verts, fmt="[%.7g, %.7g, %.7g]", newline=",\n")
        f.seek(f.tell() - 2)
        f.write("]" + mid + "[")
        np.savetxt(f, faces, fmt="[%d, %d, %d]", newline=",\n")
        f.seek(f.tell() - 2)
        f.write("]" + tail)
    size = p.stat().st_size
    load_scene(p)  # first-use costs (imports, compiled patterns) out of the measure
    fast = _traced_peak(load_scene, p)
    assert fast < 2 * size, (fast, size)
    exact = _traced_peak(load_exact, p)
    assert exact > 4 * size, (exact, size)


def test_rows_longer_than_the_margin_are_read_the_exact_way(tmp_path, monkeypatch):
    """A row (or a run of blanks) longer than the bytes kept ahead is not cut: the exact reader takes the file."""
    monkeypatch.setattr(json_arrays, "BLOCK", 300)
    monkeypatch.setattr(json_arrays, "MARGIN", 256)
    p = write_scene(tmp_path / "wide.json", "[[0, 0, 0], [1," + " " * 1000 + "0, 0], [0, 1, 0]]", F1)
    with pytest.raises(json_arrays.ExactReadNeededError):
        read_json_with_arrays(p, str(p))
    fast = outcome(load_scene, p)
    assert isinstance(fast[0], bytes) and fast == outcome(load_exact, p)
