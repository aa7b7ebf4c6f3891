"""Seeded random damage to scenes, problem files and checkpoints: an InputError or a valid result, nothing else.

A dependency-free stand-in for the property-based suite of issue 10: each
case replaces, removes or adds one value somewhere in a valid file (or flips,
cuts or inserts bytes of a checkpoint) and asserts that loading it either
succeeds or raises :class:`InputError` — never another exception, and never
a file written outside the test's folder.  Seeds are fixed, so a failure
reproduces; the whole file runs in a few seconds.
"""

from __future__ import annotations

import copy
import json
import random
from pathlib import Path
from typing import Any

import pytest

from mcocl.accumulate import Accumulator
from mcocl.bench.problems import load_problem_file
from mcocl.errors import InputError
from mcocl.render.compiled import compile_scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"
PROBLEMS = Path(__file__).resolve().parent.parent / "docs" / "bench" / "example_problems.json"

HOSTILE_VALUES: list[Any] = [
    None, True, False, 0, -1, 1, 2**31, 2**63, 10**23, -(10**30), 0.5, 1e-320, 1e308, -3.4e38, 3.4e38,
    "", "x" * 5000, "../../etc/passwd", "/etc/passwd", "\u0000", "NaN", "1e999", [], {}, [[[[[]]]]],
    [1, 2], [1, 2, 3, 4], [None, None, None], {"comment": 1}, ["a", "b", "c"], [1e308, -1e308, 1e308],
    "().__class__.__base__.__subclasses__()", "__import__('os').system('touch pwned')",
    {"checkpoint": "pwned.npz"}, {"roulette": 0.5, "client": "tcp://x:1"},
]


def json_key_paths(obj: Any, prefix: tuple = ()) -> list[tuple]:
    """Every key path in a JSON value (the root excluded)."""
    out = []
    items = obj.items() if isinstance(obj, dict) else enumerate(obj) if isinstance(obj, list) else []
    for k, v in items:
        out.append(prefix + (k,))
        out += json_key_paths(v, prefix + (k,))
    return out


def _mutate(doc: Any, rng: random.Random) -> Any:
    doc = copy.deepcopy(doc)
    path = rng.choice(json_key_paths(doc))
    parent = doc
    for k in path[:-1]:
        parent = parent[k]
    key = path[-1]
    move = rng.random()
    if move < 0.7:
        parent[key] = copy.deepcopy(rng.choice(HOSTILE_VALUES))
    elif move < 0.85:
        del parent[key]
    elif isinstance(parent, dict):
        parent[rng.choice(["obj", "numpy", "estimators", "typo", "max_depth", "width"])] = copy.deepcopy(
            rng.choice(HOSTILE_VALUES))
    else:
        parent.append(copy.deepcopy(rng.choice(HOSTILE_VALUES)))
    return doc


def _loads_or_input_error(load, path: Path) -> None:
    try:
        load(path)
    except InputError as e:
        assert str(e).strip() and "\n" not in str(e).strip()[:200]


@pytest.mark.filterwarnings("error::RuntimeWarning")  # an overflow to float32 inf is a damaged number let through
@pytest.mark.parametrize("scene", ["cornell.json", "veach_mis.json"])
def test_damaged_scenes_compile_or_raise_input_error(scene, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    doc = json.loads((SCENES / scene).read_text())
    rng = random.Random(scene)
    for _ in range(150):
        p = tmp_path / "s.json"
        p.write_text(json.dumps(_mutate(doc, rng)))
        _loads_or_input_error(compile_scene, p)
    assert sorted(f.name for f in tmp_path.iterdir()) == ["s.json"]


def test_damaged_problem_files_load_or_raise_input_error(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    doc = json.loads(PROBLEMS.read_text())
    rng = random.Random(10)
    for _ in range(300):
        p = tmp_path / "p.json"
        p.write_text(json.dumps(_mutate(doc, rng)))
        try:
            for prob in load_problem_file(p):
                prob.baseline()  # the NumPy twin is built (never run as Python)
                for kw in prob.estimator_options().values():
                    assert not {"checkpoint", "resume", "client", "devices", "device"} & set(kw)
        except InputError:
            pass
    assert sorted(f.name for f in tmp_path.iterdir()) == ["p.json"]


def test_damaged_checkpoints_load_or_raise_input_error(tmp_path):
    good = tmp_path / "good.npz"
    acc = Accumulator((5, 4, 8), {"kind": "render", "spp_per_block": 4, "shift": 0.25})
    acc.totals[:] = 1.5
    acc.blocks_done = 3
    acc.save(good)
    raw = good.read_bytes()
    rng = random.Random(7)
    bad = tmp_path / "bad.npz"
    for _ in range(200):
        data = bytearray(raw)
        move = rng.random()
        if move < 0.5:
            for _ in range(rng.randint(1, 4)):
                data[rng.randrange(len(data))] ^= 1 << rng.randrange(8)
        elif move < 0.8:
            data = data[: rng.randrange(len(data))]
        else:
            k = rng.randrange(len(data))
            data[k:k] = rng.randbytes(rng.randint(1, 50))
        bad.write_bytes(bytes(data))
        try:
            back = Accumulator.load(bad)
        except InputError:
            continue
        # anything that loads is the checkpoint that was written
        assert back.blocks_done == 3 and (back.totals == 1.5).all() and back.meta["spp_per_block"] == 4
