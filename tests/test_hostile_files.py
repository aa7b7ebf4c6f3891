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
