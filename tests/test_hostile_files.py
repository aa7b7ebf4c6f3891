"""Data files are data: a problem file, a scene or a checkpoint never runs code or reaches outside its place.

Issue 10, class 1: a bench problem's ``numpy`` twin is parsed by a whitelist
(never ``eval``), its ``estimators`` take only estimator options, and a scene's
meshes live in the scene's folder.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from mcocl.bench.numpy_baseline import compile_numpy, translate_opencl
from mcocl.bench.problems import load_problem_file
from mcocl.errors import InputError

GOOD = {"name": "bump", "expression": "exp(-x[0]*x[0])", "dim": 1, "exact": 0.746824132812427}

ESCAPES = [
    "().__class__.__base__.__subclasses__()",
    "__import__('os').system('touch pwned')",
    "np.load('x')",
    "np.__builtins__",
    "(lambda: 1)()",
    "[v for v in x]",
    "x[0].__class__",
    "np.exp(x[0], out=x[0])",
    "'a' * 10",
    "np.sum(x)",
    "x",
    "x[0:1]",
    "x[7]",
    "open('f')",
    "-" * 300 + "x[0]",
    "+".join(["x[0]"] * 3000),
    "9" * 400,
]


@pytest.mark.parametrize("text", ESCAPES, ids=range(len(ESCAPES)))
def test_numpy_twin_outside_the_whitelist_is_refused(text, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ValueError):
        compile_numpy(text, 1)
    f = tmp_path / "p.json"
    f.write_text(json.dumps({**GOOD, "numpy": text}))
    with pytest.raises(InputError, match=r"p\.json.*field 'numpy'"):
        load_problem_file(f)
    assert not (tmp_path / "pwned").exists()


def test_numpy_twin_whitelist_keeps_arithmetic():
    x = np.random.default_rng(1).random((2, 9))
    cases = {
        "np.where(x[0]*x[0] + x[1]*x[1] < 1.0, 1.0, 0.0)": np.where(x[0] ** 2 + x[1] ** 2 < 1, 1.0, 0.0),
        "np.where((x[0] > 0.3) | (x[1] > 0.6), 0.0, np.exp(2*x[0]))": np.where((x[0] > 0.3) | (x[1] > 0.6), 0.0,
                                                                                 np.exp(2 * x[0])),
        "(1.0 + x[0] + 2*x[1]) ** -3.0": (1 + x[0] + 2 * x[1]) ** -3.0,
        "math.pi * np.abs(x[0] - 0.5) % 0.3": np.fmod(np.pi * np.abs(x[0] - 0.5), 0.3),
        "0.2 < x[0] <= 0.7": ((0.2 < x[0]) & (x[0] <= 0.7)).astype(float),
        "1.0 if x[0] > 0.5 else -2.0": np.where(x[0] > 0.5, 1.0, -2.0),
        translate_opencl("fmax(exp(-x[0]) , M_PI_F * x[1])"): np.maximum(np.exp(-x[0]), np.pi * x[1]),
    }
    for text, want in cases.items():
        assert np.allclose(compile_numpy(text, 2)(x), want), text


@pytest.mark.parametrize("option", ["checkpoint", "resume", "client", "devices", "device", "seed", "progress"])
def test_problem_estimators_take_only_estimator_options(option, tmp_path):
    f = tmp_path / "p.json"
    f.write_text(json.dumps({**GOOD, "estimators": {"mine": {"roulette": 0.5, option: "x"}}}))
    with pytest.raises(InputError, match=rf"estimators'\.mine: '{option}' is not an estimator option"):
        load_problem_file(f)
    f.write_text(json.dumps({**GOOD, "estimators": {"mine": {"roulette": 0.5}}}))
    assert load_problem_file(f)[0].extra == {"mine": {"roulette": 0.5}}


SCENE = {
    "camera": {"origin": [0, 0, 4], "target": [0, 0, 0], "fov": 40, "width": 8, "height": 6},
    "materials": {"w": {"type": "diffuse", "reflectance": 0.5}},
    "shapes": [{"type": "mesh", "material": "w", "obj": "quad.obj"}],
}


def _scene(folder, obj: str):
    folder.mkdir(parents=True, exist_ok=True)
    p = folder / "s.json"
    p.write_text(json.dumps({**SCENE, "shapes": [{"type": "mesh", "material": "w", "obj": obj}]}))
    return p


@pytest.mark.parametrize("obj", ["/etc/passwd", "../outside.obj", "sub/../../outside.obj", "link.obj"])
def test_scene_meshes_stay_inside_the_scene_folder(obj, tmp_path):
    from mcocl.render.scene_file import load_scene

    (tmp_path / "outside.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    (tmp_path / "scene").mkdir()
    (tmp_path / "scene" / "link.obj").symlink_to(tmp_path / "outside.obj")
    p = _scene(tmp_path / "scene", obj)
    with pytest.raises(InputError, match=r"s\.json: shapes\[0\]\.obj: .* lies outside the scene's folder"):
        load_scene(p)
    # an explicit folder allows it (the API's mesh_folder, the CLI's --mesh-folder)
    if obj != "/etc/passwd":
        assert len(load_scene(p, mesh_folder=tmp_path).shapes[0].faces) == 1


def test_scene_mesh_that_is_not_a_mesh_is_refused(tmp_path):
    from mcocl.render.scene_file import load_scene

    (tmp_path / "text.obj").write_text("hello\nworld\n")
    with pytest.raises(InputError, match=r"shapes\[0\]\.obj: .*text\.obj holds no faces"):
        load_scene(_scene(tmp_path, "text.obj"))
    (tmp_path / "bin.obj").write_bytes(b"v 0 0 0\n\xff\xfe\x00binary")
    with pytest.raises(InputError, match=r"bin\.obj: not UTF-8 text \(byte 0xff at line 2"):
        load_scene(_scene(tmp_path, "bin.obj"))


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/null"])
def test_a_device_given_as_a_data_file_is_refused(device, tmp_path):
    """/dev/zero as a scene or mesh was read until memory ran out (4.5 GB and rising); a device,
    pipe or socket is now refused as not a regular file."""
    from mcocl.bench.problems import load_problem_file
    from mcocl.render.scene_file import load_scene

    with pytest.raises(InputError, match="not a regular file"):
        load_scene(device)
    with pytest.raises(InputError, match="not a regular file"):
        load_problem_file(device)
    (tmp_path / "m.obj").symlink_to(device)
    with pytest.raises(InputError, match=r"shapes\[0\]\.obj: .*not a regular file"):
        load_scene(_scene(tmp_path, "m.obj"), mesh_folder="/dev")


def test_repeated_keys_in_a_data_file_are_refused(tmp_path):
    """json.loads keeps the last of two equal keys and drops the first without a word."""
    from mcocl.render.scene_file import load_scene

    p = tmp_path / "s.json"
    text = json.dumps(SCENE)
    p.write_text(text[:-1] + ', "materials": {"w": {"type": "diffuse", "reflectance": 0.9}}}')
    with pytest.raises(InputError, match=r"s\.json: the key 'materials' appears twice"):
        load_scene(p)
    f = tmp_path / "p.json"
    f.write_text('{"problems": [{"name": "a", "name": "b", "expression": "x[0]", "dim": 1, "exact": 0.5}]}')
    with pytest.raises(InputError, match="the key 'name' appears twice"):
        load_problem_file(f)


def test_a_missing_mesh_folder_is_refused(tmp_path):
    from mcocl.render.scene_file import load_scene

    with pytest.raises(InputError, match=r"mesh_folder \(--mesh-folder\): .*nothere is not a folder"):
        load_scene(_scene(tmp_path, "quad.obj"), mesh_folder=tmp_path / "nothere")


def test_an_absurdly_long_snippet_is_refused_before_compiling():
    import time

    import mcocl
    from mcocl.snippet_size import MAX_SNIPPET_CHARS

    t0 = time.perf_counter()
    with pytest.raises(InputError, match=rf"integrand: the code is [\d,]+ characters long; the limit is "
                                         rf"{MAX_SNIPPET_CHARS:,}"):
        mcocl.integrate("+".join(["x[0]"] * 200_000), samples=1000)
    assert time.perf_counter() - t0 < 5  # refused, not compiled


def test_deeply_nested_xml_is_an_input_error(tmp_path):
    """100,000 nested elements overflowed Python's recursion in the Mitsuba readers (a traceback)."""
    from mcocl.render.scene_file import load_scene

    p = tmp_path / "deep.xml"
    p.write_text('<?xml version="1.0"?>\n<scene version="3.0.0">' + "<a>" * 100_000 + "</a>" * 100_000 + "</scene>")
    with pytest.raises(InputError, match=r"deep\.xml:2: elements are nested more than 200 deep"):
        load_scene(p)
