"""Property-based hostile input (issue 10): scenes, problem files, checkpoints and argument lists.

For every generated input, run in-process through :func:`mcocl.cli.main` in a
fresh folder, this suite asserts what the command line promises a careless or
hostile user:

- the exit status is 0 or 2 (130/143 are reserved to signals, which are not
  generated here);
- stderr holds at most one message (one ``mcocl COMMAND: error:`` line) and
  never a traceback;
  an exception other than argparse's exit escapes ``main`` and fails the test;
- no file appears in the folder except the declared outputs (``--out``,
  ``--png``, ``--checkpoint``), so no stray temporaries and nothing written
  beside the inputs;
- no input file changes.

Examples are derandomised (the same ones every run), so a failure reproduces
and PoCL's kernel cache makes reruns fast; budgets are tiny.
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import io
import json
import os
import tempfile
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_hostile_fuzz import json_key_paths

from mcocl.cli import main

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "scenes"
PROBLEMS = ROOT / "docs" / "bench" / "example_problems.json"


def _settings(n: int) -> settings:
    return settings(max_examples=n, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


# Values a hostile file or command line might hold: JSON values of every type and
# nesting, plus the strings that earlier reviews found dangerous.
HOSTILE_TEXT = st.sampled_from([
    "", "../../etc/passwd", "/etc/passwd", "\u0000", "NaN", "1e999", "-0", "x" * 300,
    "__import__('os').system('touch pwned')", "().__class__.__base__.__subclasses__()", "é€🙂",
])
JSON_LEAF = st.one_of(
    st.none(), st.booleans(), st.integers(-(2**70), 2**70), st.floats(), st.text(max_size=12), HOSTILE_TEXT,
    st.sampled_from([0, 1, -1, 2, 3, 0.5, 1e-320, 1e308, -3.4e38, 3.4e38, 2**31, 2**63]),
)
JSON_VALUE = st.recursive(
    JSON_LEAF, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=3),
    max_leaves=8,
)


@st.composite
def mutated(draw: st.DrawFn, doc: Any) -> Any:
    """``doc`` with one to three values replaced, removed or added at random places."""
    doc = copy.deepcopy(doc)
    for _ in range(draw(st.integers(1, 3))):
        paths = json_key_paths(doc)
        if not paths:
            break
        path = paths[draw(st.integers(0, len(paths) - 1))]
        parent = doc
        for k in path[:-1]:
            parent = parent[k]
        move = draw(st.sampled_from(["replace", "replace", "delete", "add"]))
        if move == "replace":
            parent[path[-1]] = draw(JSON_VALUE)
        elif move == "delete":
            del parent[path[-1]]
        elif isinstance(parent, dict):
            key = draw(st.sampled_from(["obj", "typo", "max_depth", "width", "height", "spp", "estimators",
                                        "numpy", "transform", "emitter"]) | st.text(max_size=6))
            parent[key] = draw(JSON_VALUE)
        else:
            parent.append(draw(JSON_VALUE))
    return doc


def _listing(folder: Path) -> dict[str, str]:
    """Every file under ``folder`` (relative path) and the SHA-256 of its bytes."""
    return {p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


OUTPUT_FLAGS = ("--out", "--png", "--checkpoint")


def run_cli(argv: list[str], work: Path) -> tuple[int, str]:
    """Run ``mcocl argv`` in ``work`` and check every promise above; return (status, stderr)."""
    before = _listing(work)
    declared = {str(Path(argv[i + 1])) for i, a in enumerate(argv[:-1]) if a in OUTPUT_FLAGS}
    err, out = io.StringIO(), io.StringIO()
    old = os.getcwd()
    os.chdir(work)
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
            try:
                code = main(argv)
            except SystemExit as e:  # argparse: a usage error (status 2) or --help (0)
                code = e.code if isinstance(e.code, int) else 2
    finally:
        os.chdir(old)
    text = err.getvalue()
    assert code in (0, 2, 130, 143), (argv, code, text)
    assert "Traceback" not in text, (argv, text)
    # One message: one "mcocl COMMAND: error: ..." line (it may go on to list, e.g. the devices).
    errors = [line for line in text.splitlines() if line.startswith("mcocl ") and ": error:" in line]
    assert len(errors) <= 1, (argv, text)
    if code == 2:
        assert errors, (argv, text)
    after = _listing(work)
    # A declared output may replace a file of the same name only when this run does
    # not read it, or when it is the checkpoint being continued (--resume F
    # --checkpoint F); a scene, problem file or resumed file is never written.
    read = {str(Path(a)) for i, a in enumerate(argv) if i == 0 or argv[i - 1] not in OUTPUT_FLAGS}
    checkpoint = {str(Path(argv[i + 1])) for i, a in enumerate(argv[:-1]) if a == "--checkpoint"}
    for name, digest in before.items():
        replaceable = name in declared and (name not in read or name in _resumed(argv) & checkpoint)
        if not replaceable:
            assert after.get(name) == digest, f"{argv}: input {name} changed or vanished"
    stray = {n for n in after if n not in before and n not in declared}
    assert not stray, f"{argv}: wrote {sorted(stray)} beyond its declared outputs {sorted(declared)}"
    return code, text


def _resumed(argv: list[str]) -> set[str]:
    return {str(Path(argv[i + 1])) for i, a in enumerate(argv[:-1]) if a == "--resume"}


@contextlib.contextmanager
def workdir(*inputs: tuple[str, bytes]):
    """A fresh folder holding ``inputs`` (name, bytes) and an empty ``out/`` folder."""
    with tempfile.TemporaryDirectory(prefix="mcocl-prop-") as d:
        work = Path(d)
        (work / "out").mkdir()
        for name, data in inputs:
            (work / name).write_bytes(data)
        yield work


def _dumps(doc: Any) -> bytes:
    return json.dumps(doc, allow_nan=True).encode()


SCENE_DOCS = {name: json.loads((SCENES / name).read_text()) for name in ("furnace.json", "cornell.json")}


@_settings(25)
@given(data=st.data(), name=st.sampled_from(sorted(SCENE_DOCS)))
def test_mutated_scenes_render_or_refuse(data: st.DataObject, name: str) -> None:
    """A scene with random values, types and nesting renders (1 spp) or is refused in one line."""
    doc = data.draw(mutated(SCENE_DOCS[name]))
    with workdir(("scene.json", _dumps(doc))) as work:
        run_cli(["render", "scene.json", "--spp", "1", "--time", "5", "--quiet", "--out", "out/a.exr"], work)


@_settings(30)
@given(doc=mutated(json.loads(PROBLEMS.read_text())))
def test_mutated_problem_files_list_or_refuse(doc: Any) -> None:
    """A bench problem file with random damage is listed or refused; it never runs code or writes."""
    with workdir(("problems.json", _dumps(doc))) as work:
        run_cli(["bench", "--no-plot", "integrate", "--problem", "problems.json", "--list"], work)
        assert not (work / "pwned").exists()


_CHECKPOINTS: dict[str, bytes] = {}
# The runs whose checkpoints are damaged, and (with a larger budget) resumed.
CHECKPOINTED = {
    "integrate": ["integrate", "x[0]*x[0]", "--samples", "4096"],
    "solve": ["solve", "--kernel", "0.5f", "--source", "1.0f", "--at", "0.25", "0.75", "--walks", "512"],
    "render": ["render", "scene.json", "--spp", "2", "--out", "out/a.exr"],
}
RESUMED = {
    "integrate": ["integrate", "x[0]*x[0]", "--samples", "8192"],
    "solve": ["solve", "--kernel", "0.5f", "--source", "1.0f", "--at", "0.25", "0.75", "--walks", "1024"],
    "render": ["render", "scene.json", "--spp", "4", "--out", "out/a.exr"],
}


def _checkpoint(kind: str) -> bytes:
    """A real checkpoint of a tiny integrate or render run, made once per session."""
    if kind not in _CHECKPOINTS:
        with workdir() as work:
            argv = [*CHECKPOINTED[kind], "--seed", "5"]
            if kind == "render":
                argv[1] = str(SCENES / "furnace.json")
            code, text = run_cli([*argv, "--quiet", "--checkpoint", "out/c.npz"], work)
            assert code == 0, text
            _CHECKPOINTS[kind] = (work / "out" / "c.npz").read_bytes()
    return _CHECKPOINTS[kind]


@st.composite
def damaged(draw: st.DrawFn, raw: bytes) -> bytes:
    """``raw`` with bits flipped, cut short, or with bytes inserted."""
    data = bytearray(raw)
    move = draw(st.sampled_from(["flip", "cut", "insert", "flip"]))
    if move == "flip":
        for _ in range(draw(st.integers(1, 4))):
            k = draw(st.integers(0, len(data) - 1))
            data[k] ^= 1 << draw(st.integers(0, 7))
    elif move == "cut":
        data = data[: draw(st.integers(0, len(data) - 1))]
    else:
        k = draw(st.integers(0, len(data)))
        data[k:k] = draw(st.binary(min_size=1, max_size=40))
    return bytes(data)


@_settings(30)
@given(data=st.data(), kind=st.sampled_from(sorted(CHECKPOINTED)))
def test_damaged_checkpoints_resume_or_refuse(data: st.DataObject, kind: str) -> None:
    """A bit-flipped, truncated or padded checkpoint resumes exactly what was saved, or is refused."""
    raw = _checkpoint(kind)
    bad = data.draw(damaged(raw))
    argv = [*RESUMED[kind], "--seed", "5"]
    inputs = [("c.npz", bad), ("scene.json", (SCENES / "furnace.json").read_bytes())]
    with workdir(*inputs) as work:
        code, text = run_cli([*argv, "--quiet", "--resume", "c.npz"], work)
        if code == 2:
            assert "c.npz" in text or "checkpoint" in text, text


def test_checkpoint_with_a_damaged_array_header_is_refused() -> None:
    """Found by the suite above: a flipped byte in an array's header made NumPy raise tokenize.TokenError."""
    raw = _checkpoint("render")  # an array larger than zipfile's first read: the header is parsed before the CRC
    assert raw.count(b"'fortran_order': False,") >= 1
    bad = raw.replace(b"'fortran_order': False,", b"'fortran_order': False(", 1)
    with workdir(("c.npz", bad), ("scene.json", (SCENES / "furnace.json").read_bytes())) as work:
        code, text = run_cli(["render", "scene.json", "--spp", "4", "--out", "out/a.exr", "--quiet",
                              "--resume", "c.npz"], work)
        assert code == 2 and "c.npz is damaged" in text, text


def test_huge_exposure_is_refused_before_rendering() -> None:
    """Found by the suite below: --exposure 1e30 with --png raised OverflowError after the render."""
    with workdir(("scene.json", (SCENES / "furnace.json").read_bytes())) as work:
        code, text = run_cli(["render", "scene.json", "--spp", "1", "--quiet", "--out", "out/a.exr",
                              "--png", "out/a.png", "--exposure", "1e30"], work)
        assert code == 2 and "--exposure" in text, text
        assert not (work / "out" / "a.exr").exists()


def test_empty_output_name_is_refused() -> None:
    """Found by the suite below: --out '' read as "not given" and wrote SCENE.exr unasked."""
    with workdir(("scene.json", (SCENES / "furnace.json").read_bytes())) as work:
        code, text = run_cli(["render", "scene.json", "--spp", "1", "--quiet", "--out", ""], work)
        assert code == 2 and "--out" in text and "empty" in text, text


# Hostile values for command-line options: numbers past every range, words, empty text.
NUMBER = st.sampled_from(["0", "-1", "1", "2", "3", "1e30", "-1e30", "nan", "inf", "-inf", "abc", "", "1.5",
                          "99999999999", "1e-9", "0x10", "1e3", "-0"])
PATH = st.sampled_from(["out/x.exr", "out/y.png", "out/c.npz", "out", "/nonexistent/x.exr", "scene.json",
                        "ck.npz", "", "out/x.exr"])
FLAGS = {
    "integrate": {
        "--dim": NUMBER, "--samples": st.sampled_from(["0", "-1", "1e30", "abc", "nan", "1.5", "100", "1e3"]),
        "--sampler": st.sampled_from(["independent", "stratified", "nrooks", "sobol", "vegas", "bogus"]),
        "--seed": NUMBER, "--proposal": st.sampled_from(["uniform", "power:a=-0.5", "exponential:rate=-1",
                                                           "truncnorm:mu=0,sigma=0", "bogus", "[]", "{}"]),
        "--roulette": NUMBER, "--control": st.sampled_from(["x[0]", "x[9]", "", "return;"]),
        "--control-integral": NUMBER, "--replicates": NUMBER, "--iterations": NUMBER, "--vegas-bins": NUMBER,
        "--alpha": NUMBER, "--beta": NUMBER, "--lanes": NUMBER, "--split": NUMBER, "--target-error": NUMBER,
        "--scrambling": st.sampled_from(["hash", "linear", "bogus", ""]),
        "--precision": st.sampled_from(["single", "double", "bogus"]),
        "--design-samples": NUMBER, "--checkpoint": PATH, "--resume": PATH, "--device": NUMBER,
        "--json": None, "--time": st.sampled_from(["0", "-1", "nan", "1e-9", "0.5", "abc"]),
    },
    "solve": {
        "--dim": NUMBER, "--walks": st.sampled_from(["0", "-1", "1e30", "abc", "nan", "100"]),
        "--estimator": st.sampled_from(["truncated", "roulette", "subcritical", "nee", "bogus"]),
        "--depth": NUMBER, "--survival": NUMBER, "--row-integral": NUMBER, "--source-integral": NUMBER,
        "--max-walk-length": NUMBER, "--table-cells": NUMBER, "--table-bins": NUMBER, "--order": NUMBER,
        "--seed": NUMBER, "--lanes": NUMBER, "--split": NUMBER, "--checkpoint": PATH, "--resume": PATH,
        "--reference": None, "--json": None, "--time": st.sampled_from(["0", "-1", "nan", "1e-9", "0.5"]),
    },
    "render": {
        "--spp": st.sampled_from(["0", "-1", "1e30", "abc", "nan", "1", "2"]),
        "--integrator": st.sampled_from(["path", "nee", "mis", "lt", "bogus"]),
        "--max-depth": NUMBER, "--rr-depth": NUMBER, "--seed": NUMBER, "--out": PATH, "--png": PATH,
        "--exposure": NUMBER, "--checkpoint": PATH, "--resume": PATH, "--lanes": NUMBER, "--split": NUMBER,
        "--target-error": NUMBER, "--json": None, "--lenient": None,
        "--time": st.sampled_from(["0", "-1", "nan", "1e-9", "0.5"]),
    },
}
BASE = {
    "integrate": ["integrate", "x[0]*x[0]", "--samples", "2000"],
    "solve": ["solve", "--kernel", "0.5f", "--source", "1.0f", "--at", "0.5", "--walks", "200"],
    "render": ["render", "scene.json", "--spp", "1", "--out", "out/a.exr"],
}


@st.composite
def argument_lists(draw: st.DrawFn) -> list[str]:
    """A command with its tiny base budget and up to four random options (the drawn ones come last and win)."""
    command = draw(st.sampled_from(sorted(FLAGS)))
    argv = [*BASE[command], "--quiet"]
    if command == "integrate":  # snippets that must be refused or give a finite, honest answer
        argv[1] = draw(st.sampled_from(["x[0]*x[0]", "x[0]*x[0]", "x[5]", "", "return;", "x[0] < 0.5f ? 3e38f : -3e38f",
                                        "1.0f / x[0]", "sqrt(-x[0])", "float s = x[1]; return s;", "}{"]))
    if command == "solve":
        argv[2] = draw(st.sampled_from(["0.5f", "0.5f", "2.0f", "-0.9f", "x[0]*y[0]", "y[3]", "", "1e38f"]))
        argv[4] = draw(st.sampled_from(["1.0f", "1.0f", "x[0]", "x[7]", "nan", "3e38f"]))
    for flag in draw(st.lists(st.sampled_from(sorted(FLAGS[command])), max_size=4, unique=True)):
        values = FLAGS[command][flag]
        argv += [flag] if values is None else [flag, draw(values)]
    return argv


@_settings(40)
@given(argv=argument_lists())
def test_random_argument_lists(argv: list[str]) -> None:
    """Random flags and values for integrate, solve and render end in 0 or 2 with at most one message."""
    inputs = [("scene.json", (SCENES / "furnace.json").read_bytes()), ("ck.npz", _checkpoint("integrate"))]
    with workdir(*inputs) as work:
        run_cli(argv, work)
