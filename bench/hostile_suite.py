"""A reproducible hostile-input run of the ``mcocl`` command line and API (issue 10).

Not part of pytest: a script that throws a few hundred bad inputs and
situations at mcocl, as a careless or hostile user would, and classifies each
outcome automatically:

- ``traceback``  a Python traceback on stderr;
- ``crash``      killed by a signal, an exit status other than 0/2/130/143, or a
                 failure without a message line;
- ``hang``       outlived ``--time`` by more than 5 s, not counting the compile time the
                 supervisor names (or the case's time limit);
- ``silent``     a silently wrong result: exit 0 where a refusal was due, or a
                 numeric result that misses an independent expected value by
                 more than 5 reported standard errors (or is not finite while
                 ``nonfinite`` says 0);
- ``lost``       a signal or failure lost work that existed (no image, no
                 checkpoint, no printed estimate);
- ``escape``     a file written outside the case's output folder, an input
                 file changed, or a canary file created (code run from data).

Every case runs in its own temporary folder: inputs in ``in/`` (checked
unchanged afterwards), the working directory ``out/`` (only declared outputs
may appear there).  The repository's ``scenes/`` and ``docs/bench/`` are
hashed before and after the whole run.

    PYTHONPATH=. python bench/hostile_suite.py                 # everything
    PYTHONPATH=. python bench/hostile_suite.py --every 4       # ~145 cases from every class, ~3-5 min
    PYTHONPATH=. python bench/hostile_suite.py --class signal,env
    PYTHONPATH=. python bench/hostile_suite.py --list
    PYTHONPATH=. python bench/hostile_suite.py --case snippet-oob-write -v

Prints a table of counts per class and the failing cases; exit status 1 when
any case failed.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import dataclasses
import hashlib
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "scenes"
PY = sys.executable
FAILURES = ("traceback", "crash", "hang", "silent", "lost", "escape", "suite")
OK_CODES = {0, 2, 130, 143}
AS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0


@dataclasses.dataclass
class Outcome:
    """What one run did: exit status, output, wall time and the folders afterwards."""

    rc: int
    out: str
    err: str
    wall: float
    case_dir: Path

    @property
    def in_dir(self) -> Path:
        return self.case_dir / "in"

    @property
    def out_dir(self) -> Path:
        return self.case_dir / "out"

    def json(self) -> dict[str, Any] | None:
        """The ``--json`` document on stdout, if any."""
        start = self.out.find("{")
        if start < 0:
            return None
        try:
            return json.loads(self.out[start:])
        except ValueError:
            return None


Check = Callable[[Outcome], "str | None"]


@dataclasses.dataclass
class Case:
    """One hostile input or situation.

    ``argv`` runs ``python -m mcocl ARGV`` (``{in}``/``{out}`` are replaced by
    the case's folders); ``api`` runs Python code instead, in which an
    ``MCOCLError`` becomes a one-line message and exit 2.  ``expect`` is
    ``error`` (a refusal, exit 2), ``ok`` (exit 0), ``signal`` (exit 130/143)
    or ``any``.  ``checks`` return a failure text ``"CLASS: what"`` or None.
    """

    name: str
    cls: str
    argv: list[str] | None = None
    api: str | None = None
    expect: str = "error"
    time: float | None = None
    env: dict[str, str | None] = dataclasses.field(default_factory=dict)
    files: dict[str, bytes | str] = dataclasses.field(default_factory=dict)
    outputs: tuple[str, ...] = ()
    signals: tuple[tuple[str | float, int], ...] = ()
    checks: tuple[Check, ...] = ()
    limit: float = 120.0
    prepare: Callable[[Path], None] | None = None
    mutable: tuple[str, ...] = ()  # inputs the case may change (a checkpoint continued in place)


# ---------------------------------------------------------------- checks


def estimate_near(exact: float, k: float = 5.0, rel: float = 1e-6) -> Check:
    """The JSON estimate lies within k reported standard errors of ``exact``."""

    def check(o: Outcome) -> str | None:
        if o.rc != 0:
            return None
        d = o.json()
        if d is None:
            return "silent: no JSON result on stdout"
        est, se = d.get("estimate"), d.get("stderr")
        if est is None:
            vals, ses = d.get("values"), d.get("stderr")
            est, se = (vals[0], ses[0]) if vals else (None, None)
        if est is None or not math.isfinite(est):
            return f"silent: estimate {est} with exit 0"
        if abs(est - exact) > k * (se or 0.0) + rel * abs(exact) + 1e-300:
            return f"silent: estimate {est!r} is {abs(est - exact) / max(se or 1e-300, 1e-300):.1f} se from {exact!r}"
        return None

    return check


def loud_if_nonfinite(o: Outcome) -> str | None:
    """A non-finite estimate with exit 0 must come with a non-finite count or a warning."""
    d = o.json()
    if o.rc != 0 or d is None:
        return None
    est = d.get("estimate", (d.get("values") or [0.0])[0])
    nonfinite = d.get("nonfinite")
    nonfinite = sum(nonfinite) if isinstance(nonfinite, list) else nonfinite
    if est is not None and not math.isfinite(est) and not nonfinite and "nonfinite" not in o.err.lower() \
            and "non-finite" not in o.err.lower():
        return f"silent: estimate {est} but nonfinite {nonfinite} and no warning"
    return None


def says(*words: str) -> Check:
    """stderr (or stdout) names every one of ``words``."""

    def check(o: Outcome) -> str | None:
        text = o.err + o.out
        missing = [w for w in words if w.lower() not in text.lower()]
        return f"crash: message lacks {missing}" if missing else None

    return check


def file_kept(name: str, kind: str) -> Check:
    """After a signal, the output ``name`` exists in out/ and reads back as ``kind`` (exr/ckpt)."""

    def check(o: Outcome) -> str | None:
        p = o.out_dir / name
        if not p.exists():
            return f"lost: no {name} after rc {o.rc}"
        try:
            if kind == "exr":
                from mcocl.render.image_io import read_exr

                img = read_exr(p)
                if img.samples is None or int(img.samples.max()) == 0:
                    return f"lost: {name} holds no samples"
            else:
                from mcocl.accumulate import Accumulator

                Accumulator.load(p)
        except Exception as e:  # noqa: BLE001 - any failure to read back is lost work
            return f"lost: {name} does not read back ({type(e).__name__}: {e})"
        return None

    return check


def printed_estimate(o: Outcome) -> str | None:
    """An interrupted run still prints what it computed."""
    if not any(w in o.out for w in ("estimate", "values", "f(")):  # integrate / --json / solve's "f(x) = ..."
        return "lost: interrupted run printed no result"
    return None


def furnace_is_one(name: str) -> Check:
    """Every pixel of the unbounded white furnace is exactly (1, 1, 1) (scenes/furnace.json)."""

    def check(o: Outcome) -> str | None:
        if o.rc != 0:
            return None
        import numpy as np

        from mcocl.render.image_io import read_exr

        img = read_exr(o.out_dir / name)
        mean = float(np.mean(img.mean))
        se = float(np.sqrt(np.sum(img.variance)) / img.variance.size) if img.variance is not None else 0.0
        if not math.isfinite(mean) or abs(mean - 1.0) > 5 * se + 1e-4:
            return f"silent: furnace mean {mean} (se {se:.2g}) is not 1"
        return None

    return check


def ended_in_time(o: Outcome, budget: float) -> str | None:
    """The run ended within 5 s of ``--time``, not counting the compiling (and, once sampling began,
    start-up) that the supervisor leaves out of the budget and names when it stops a run: a fresh
    compile on a busy machine takes longer than the budget itself."""
    m = re.search(r"not counting ([\d.]+) s of", o.err)
    uncounted = float(m.group(1)) if m else 0.0
    if o.wall - uncounted > budget + 5.0:
        return f"hang: ran {o.wall:.1f} s ({uncounted:.1f} s of it not counted) with --time {budget:g}"
    return None


# ---------------------------------------------------------------- inputs

TINY_SCENE = json.loads((SCENES / "cornell.json").read_text())
TINY_SCENE["camera"].update(width=16, height=16)
TINY_SCENE["integrator"]["spp"] = 2
QUAD_OBJ = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n"
PLY_HEAD = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n" \
           "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
GOOD_PLY = PLY_HEAD + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
PROBLEM = {"problems": [{"name": "bump", "expression": "exp(-x[0]*x[0])", "dim": 1, "exact": 0.746824132812427}]}
BUMP = 0.746824132812427


def scene_with(**edits: Any) -> str:
    """The tiny Cornell scene with top-level keys replaced (a dotted key edits one level down)."""
    s = json.loads(json.dumps(TINY_SCENE))
    for k, v in edits.items():
        if "__" in k:
            a, b = k.split("__")
            s[a][b] = v
        else:
            s[k] = v
    return json.dumps(s)


def mesh_scene(mesh: str, **shape: Any) -> str:
    return scene_with(shapes=[{"type": "mesh", "material": "white", "obj": mesh, **shape}])


def make_base(base: Path) -> None:
    """Inputs every case gets a copy of: scenes, meshes, a problem file and checkpoints of each kind."""
    base.mkdir(parents=True)
    (base / "tiny.json").write_text(json.dumps(TINY_SCENE))
    (base / "quad.obj").write_text(QUAD_OBJ)
    (base / "tri.ply").write_text(GOOD_PLY)
    (base / "problem.json").write_text(json.dumps(PROBLEM))
    xml = (SCENES / "xml" / "cornell.xml").read_text()
    (base / "tiny.xml").write_text(xml.replace('value="256"', 'value="16"').replace('value="64"', 'value="2"'))
    env = {**os.environ, "MCOCL_SUPERVISE": "0", "PYTHONPATH": str(ROOT)}
    runs = [
        ["integrate", "exp(-x[0]*x[0])", "--samples", "65536", "--checkpoint", str(base / "int.ckpt"), "--quiet"],
        ["solve", "--kernel", "0.5f", "--source", "1.0f", "--at", "0.5", "--walks", "4096",
         "--checkpoint", str(base / "solve.ckpt"), "--quiet"],
        ["render", str(base / "tiny.json"), "--spp", "2", "--out", str(base / "img.exr"),
         "--checkpoint", str(base / "render.ckpt"), "--quiet"],
        # batches of 256 spp on 16 x 16 pixels: 4 blocks of 64-pixel ranges a batch (block_pixels 64)
        ["render", str(base / "tiny.json"), "--sampler", "sobol", "--spp", "1024", "--out", str(base / "sob.exr"),
         "--checkpoint", str(base / "sobol.ckpt"), "--quiet"],
    ]
    for argv in runs:
        subprocess.run([PY, "-m", "mcocl", *argv], env=env, check=True, capture_output=True, cwd=base)


def flipped(name: str, at: float) -> Callable[[Path], None]:
    """Flip one bit at fraction ``at`` of in/NAME."""

    def prep(case_dir: Path) -> None:
        p = case_dir / "in" / name
        b = bytearray(p.read_bytes())
        b[int(len(b) * at)] ^= 0x04
        p.write_bytes(bytes(b))

    return prep


def truncated(name: str, frac: float) -> Callable[[Path], None]:
    def prep(case_dir: Path) -> None:
        p = case_dir / "in" / name
        p.write_bytes(p.read_bytes()[: int(p.stat().st_size * frac)])

    return prep


DELETE = object()  # edited_meta's value that removes the key


def edited_meta(name: str, key: str, value: Any) -> Callable[[Path], None]:
    """Edit one metadata field of a checkpoint (``DELETE``: remove it) and re-save it with a consistent
    digest (a deliberate forgery)."""

    def prep(case_dir: Path) -> None:
        code = textwrap.dedent(f"""
            from mcocl.accumulate import Accumulator
            a = Accumulator.load({str(case_dir / 'in' / name)!r})
            a.meta[{key!r}] = {None if value is DELETE else value!r}
            if {value is DELETE!r}:
                del a.meta[{key!r}]
            a.save({str(case_dir / 'in' / name)!r})
        """)
        subprocess.run([PY, "-c", code], env={**os.environ, "PYTHONPATH": str(ROOT)}, check=True)

    return prep


def edited_blocks(name: str, blocks: int) -> Callable[[Path], None]:
    """Set a checkpoint's count of folded blocks and re-save it with a consistent digest (a forgery)."""

    def prep(case_dir: Path) -> None:
        code = textwrap.dedent(f"""
            from mcocl.accumulate import Accumulator
            a = Accumulator.load({str(case_dir / 'in' / name)!r})
            a.blocks_done = {int(blocks)!r}
            a.save({str(case_dir / 'in' / name)!r})
        """)
        subprocess.run([PY, "-c", code], env={**os.environ, "PYTHONPATH": str(ROOT)}, check=True)

    return prep


def exr_has_samples(name: str) -> Check:
    """A successful render wrote ``name`` with samples in it."""

    def check(o: Outcome) -> str | None:
        if o.rc != 0:
            return None
        return file_kept(name, "exr")(o)

    return check


def readonly_out(case_dir: Path) -> None:
    (case_dir / "ro").mkdir()
    (case_dir / "ro").chmod(0o555)


# ---------------------------------------------------------------- the cases

INTEG = ["integrate"]
LOOP = "float s = 0; for (;;) { s += 1; } return s;"


def cli_cases() -> list[Case]:
    """Bad command-line arguments of every command."""
    c: list[Case] = []

    def add(name: str, *argv: str, expect: str = "error", **kw: Any) -> None:
        c.append(Case(f"cli-{name}", "cli", list(argv), expect=expect, **kw))

    for v in ["1e30", "-5", "abc", "nan", "inf", "0", "1.5"]:
        add(f"samples-{v}", *INTEG, "x[0]", "--samples", v, expect="any" if v in ("1.5",) else "error")
    for v in ["0", "-1", "100000", "1e3", "x"]:
        add(f"dim-{v}", *INTEG, "x[0]", "--dim", v)
    for v in ["-1", str(2**64), "abc", "1.5"]:
        add(f"seed-{v[:6]}", *INTEG, "x[0]", "--seed", v)
    add("sampler-bogus", *INTEG, "x[0]", "--sampler", "bogus")
    for v in ["-1", "nan", "inf", "0"]:
        add(f"time-{v}", *INTEG, "x[0]", "--time", v, expect="any" if v == "0" else "error")
    for v in ["0", "-1", "nan"]:
        add(f"target-error-{v}", *INTEG, "x[0]", "--target-error", v)
    for v in ["0", "1.5", "nan", "-0.1"]:
        add(f"roulette-{v}", *INTEG, "x[0]", "--roulette", v)
    add("proposal-rate-negative", *INTEG, "x[0]", "--proposal", "exponential:rate=-1", "--json", "--quiet",
        expect="ok", checks=(estimate_near(0.5),))  # a truncated exponential growing towards 1 is a density
    for spec in ["bogus", "power:a=-1", "power:a=nan", "exponential:rate=0", "exponential:rate=inf", "truncnorm:mu=0.5,sigma=0", "truncnorm:mu=nan,sigma=1",
                 '{"type": "tabulated", "weights": []}', '{"type": "tabulated", "weights": [-1, 2]}',
                 '{"type": "tabulated", "weights": [1e400]}', '{"type": "tabulated", "weights": [0, 0]}',
                 '{"type": "tabulated2d", "weights": [[1], [1, 2]]}', '[', '{"type": "analytic"}',
                 '{"type": "analytic", "pdf": "-1.0f", "inverse": "u"}',
                 '{"type": "analytic", "pdf": "2*x", "inverse": "u"}',
                 '{"type": "analytic", "pdf": "1.0f", "inverse": "u*2"}',
                 '{"type": "analytic", "pdf": "1.0f", "inverse": "u; } kernel void k() {"}']:
        add(f"proposal-{hashlib.sha1(spec.encode()).hexdigest()[:6]}", *INTEG, "x[0]", "--proposal", spec)
    add("shares-count", *INTEG, "x[0]", "--proposals", "uniform", "power:a=0.5", "--shares", "1")
    add("shares-negative", *INTEG, "x[0]", "--proposals", "uniform", "power:a=0.5", "--shares", "-1", "2")
    add("shares-nan", *INTEG, "x[0]", "--proposals", "uniform", "power:a=0.5", "--shares", "nan", "1")
    add("beta-nan", *INTEG, "x[0]", "--proposals", "uniform", "power:a=0.5", "--heuristic", "power", "--beta", "nan")
    add("control-no-integral", *INTEG, "x[0]", "--control", "x[0]")
    add("control-integral-nan", *INTEG, "x[0]", "--control", "x[0]", "--control-integral", "nan")
    for opt, v in [("--replicates", "0"), ("--replicates", "1e30"), ("--iterations", "0"), ("--vegas-bins", "0"),
                   ("--vegas-bins", "1e9"), ("--alpha", "nan"), ("--design-samples", "0"),
                   ("--design-samples", "1e30")]:
        sampler = "sobol" if opt == "--replicates" else "vegas" if opt in ("--iterations", "--vegas-bins", "--alpha") \
            else "stratified"
        add(f"{opt[2:]}-{v}", *INTEG, "x[0]", "--sampler", sampler, opt, v)
    for opt, v in [("--lanes", "3"), ("--lanes", "0"), ("--lanes", "1000"), ("--device", "99"), ("--device", "zzz"),
                   ("--devices", "zzz9"), ("--devices", "0,99"), ("--split", "0"), ("--split", "100000")]:
        add(f"{opt[2:]}-{v}", *INTEG, "x[0]", "--samples", "1e4", opt, v)
    add("dask-nowhere", *INTEG, "x[0]", "--samples", "1e4", "--dask", "tcp://127.0.0.1:9", limit=60)
    add("integrand-empty", *INTEG, "")
    add("integrand-injection", *INTEG, "x[0]; } __kernel void evil(__global float* p) { p[0] = 1; ")
    add("integrand-include", *INTEG, "#include </etc/passwd>\nreturn x[0];")
    add("integrand-error-directive", *INTEG, "#error boom\nreturn 1.0f;")
    add("integrand-unicode", *INTEG, "x[0]·2")
    for name, argv in [
        ("solve-at-2", ["--at", "2.0"]), ("solve-at-nan", ["--at", "nan"]), ("solve-at-abc", ["--at", "abc"]),
        ("solve-at-2d-in-1d", ["--at", "0.5,0.5"]), ("solve-walks-0", ["--at", "0.5", "--walks", "0"]),
        ("solve-walks-1e30", ["--at", "0.5", "--walks", "1e30"]),
        ("solve-depth-neg", ["--at", "0.5", "--estimator", "truncated", "--depth", "-1"]),
        ("solve-depth-huge", ["--at", "0.5", "--estimator", "truncated", "--depth", "1e12"]),
        ("solve-survival-0", ["--at", "0.5", "--estimator", "roulette", "--survival", "0"]),
        ("solve-survival-2", ["--at", "0.5", "--estimator", "roulette", "--survival", "2"]),
        ("solve-survival-nan", ["--at", "0.5", "--estimator", "roulette", "--survival", "nan"]),
        ("solve-survival-word", ["--at", "0.5", "--estimator", "roulette", "--survival", "bogus"]),
        ("solve-mwl-0", ["--at", "0.5", "--max-walk-length", "0"]),
        ("solve-mwl-huge", ["--at", "0.5", "--max-walk-length", "1e30"]),
        ("solve-cells-0", ["--at", "0.5", "--table-cells", "0"]),
        ("solve-cells-huge", ["--at", "0.5", "--table-cells", "1000000000"]),
        ("solve-bins-huge", ["--at", "0.5", "--table-bins", "1000000000"]),
        ("solve-order-neg", ["--at", "0.5", "--reference", "--order", "-1"]),
        ("solve-sampler-bogus", ["--at", "0.5", "--sampler", "bogus"]),
    ]:
        c.append(Case(f"cli-{name}", "cli", ["solve", "--kernel", "0.5f*y[0]", "--source", "1.0f", *argv,
                                              "--walks" if "--walks" not in argv else "--quiet",
                                              *(["1e3"] if "--walks" not in argv else [])]))
    add("solve-kernel-empty", "solve", "--kernel", "", "--source", "1.0f", "--at", "0.5")
    add("solve-kernel-z", "solve", "--kernel", "z[0]", "--source", "1.0f", "--at", "0.5")
    add("solve-supercritical", "solve", "--kernel", "2.0f", "--source", "1.0f", "--at", "0.5", "--walks", "1e3",
        "--estimator", "subcritical")
    tiny = "{in}/tiny.json"
    for name, argv in [("spp-0", ["--spp", "0"]), ("spp-neg", ["--spp", "-1"]), ("spp-1e30", ["--spp", "1e30"]),
                       ("spp-nan", ["--spp", "nan"]), ("max-depth-huge", ["--max-depth", "99999999999"]),
                       ("max-depth--2", ["--max-depth", "-2"]), ("rr-depth-neg", ["--rr-depth", "-5"]),
                       ("strategy-99", ["--integrator", "bdpt", "--strategy", "99,99"]),
                       ("strategy-ab", ["--integrator", "bdpt", "--strategy", "a,b"]),
                       ("lanes-7", ["--lanes", "7"]), ("define-noeq", ["-D", "spp"]),
                       ("exposure-1e30", ["--png", "p.png", "--exposure", "1e30"]),
                       ("exposure-inf", ["--png", "p.png", "--exposure", "inf"]),
                       ("mesh-folder-missing", ["--mesh-folder", "{in}/nothere"]),
                       ("time-nan", ["--time", "nan"]), ("target-error-neg", ["--target-error", "-1"])]:
        c.append(Case(f"cli-render-{name}", "cli", ["render", tiny, "--out", "x.exr", *argv]))
    add("render-missing-scene", "render", "{in}/nothere.json", "--out", "x.exr")
    add("render-scene-folder", "render", "{in}", "--out", "x.exr")
    add("render-dev-null", "render", "/dev/null", "--out", "x.exr")
    add("render-dev-zero", "render", "/dev/zero", "--out", "x.exr", limit=60)
    add("render-define-on-json", "render", tiny, "--out", "x.exr", "-D", "spp=4", expect="any", outputs=("x.exr",))
    for name, argv in [("budget-neg", ["--budget", "-1"]), ("budget-nan", ["--budget", "nan"]),
                       ("budget-huge", ["--budget", "1e30"]), ("lanes-3", ["--lanes", "3"]),
                       ("estimators-bogus", ["--estimators", "bogus"]), ("only-bogus", ["integrate", "--only", "zz"]),
                       ("problem-missing", ["integrate", "--problem", "{in}/nothere.json"]),
                       ("out-file", ["--out", "{in}/problem.json"])]:
        argv = argv if "integrate" in argv else [*argv, "integrate"]
        c.append(Case(f"cli-bench-{name}", "cli", ["bench", "--no-plot", "--no-numpy", *argv]))
    add("bench-out-created", "bench", "--no-plot", "--no-numpy", "--budget", "0.05", "--out", "new/b", "integrate",
        "--problem", "{in}/problem.json", expect="ok", outputs=("new",))  # a missing --out folder is made
    add("convert-missing", "convert", "{in}/nothere.xml")
    add("convert-json", "convert", "{in}/tiny.json")
    add("convert-out-is-input", "convert", "{in}/tiny.xml", "-o", "{in}/tiny.xml")
    add("convert-out-missing-folder", "convert", "{in}/tiny.xml", "-o", "{out}/a/b.json")
    add("convert-define-bogus", "convert", "{in}/tiny.xml", "-D", "resx=abc")
    add("convert-define-unknown", "convert", "{in}/tiny.xml", "-D", "nosuch=1", expect="any")
    for v in ["0", "abc", "100000"]:  # 100000 is shown as "used whole", which is the truth
        add(f"devices-split-{v}", "devices", "--split", v, expect="any" if v == "100000" else "error")
    add("devices-json", "devices", "--json", expect="ok")
    add("no-command", expect="error")
    add("unknown-command", "frobnicate")
    return c


def render_option_cases() -> list[Case]:
    """The render options of sobol batches, bdpt's strategies and heuristics, and light samplers."""
    c: list[Case] = []
    tiny = "{in}/tiny.json"

    def add(name: str, *argv: str, expect: str = "error", **kw: Any) -> None:
        outs = ("x.exr",) if expect != "error" else ()
        checks = (exr_has_samples("x.exr"),) if expect != "error" else ()
        c.append(Case(f"render-{name}", "render", ["render", tiny, "--out", "x.exr", "--quiet", *argv],
                      expect=expect, outputs=outs, checks=checks, limit=90, **kw))

    sobol = ["--sampler", "sobol"]
    for v in ["0", "1", "-3", "abc", "1e30", "1.5", "nan", "inf", ""]:
        add(f"batches-{v or 'empty'}", *sobol, "--batches", v)
    # more batches than samples: as many batches as samples (documented), never a giant allocation
    add("batches-1e9", *sobol, "--batches", "1e9", "--spp", "4", expect="ok")
    add("batches-1e9-time", *sobol, "--batches", "1e9", "--time", "2", expect="ok")
    add("batches-independent", "--sampler", "independent", "--batches", "4")
    add("batches-scene-sampler", "--batches", "4", expect="ok")  # the scene's sampler is auto: batches choose sobol
    # bdpt has a sobol back end: batches choose it (auto) or size its batches; lt has none
    add("batches-bdpt", "--integrator", "bdpt", "--batches", "4", expect="ok")
    add("batches-bdpt-sobol", "--integrator", "bdpt", *sobol, "--batches", "4", expect="ok")
    add("batches-lt", "--integrator", "lt", "--batches", "4")
    add("batches-lt-sobol", "--integrator", "lt", *sobol)
    add("sobol-spp-1", *sobol, "--spp", "1", expect="ok")
    add("sobol-spp-3", *sobol, "--spp", "3", expect="ok")
    add("sobol-spp-3-batches-2", *sobol, "--spp", "3", "--batches", "2", expect="ok")
    add("sobol-target-error", *sobol, "--target-error", "0.5", "--time", "20", expect="ok")
    for v in ["2", "a,b", "-1,3", "99,99", "1,1,1", "0,1", "", "1.5,2", ",", "1e9,1"]:
        add(f"strategy-{v.replace(',', '_') or 'empty'}", "--integrator", "bdpt", "--strategy", v)
    add("strategy-on-mis", "--integrator", "mis", "--strategy", "1,2")
    add("unweighted-alone", "--integrator", "bdpt", "--unweighted")
    add("mis-heuristic-bogus", "--integrator", "bdpt", "--mis-heuristic", "bogus")
    add("mis-heuristic-on-path", "--integrator", "path", "--mis-heuristic", "balance")
    add("no-roulette-on-nee", "--integrator", "nee", "--no-roulette")
    add("bdpt-strategy-ok", "--integrator", "bdpt", "--strategy", "1,2", "--unweighted", "--no-roulette",
        "--spp", "2", expect="ok")
    for name, integ in {
        "batches-str": {"type": "mis", "sampler": "sobol", "batches": "4"},
        "batches-float": {"type": "mis", "sampler": "sobol", "batches": 4.5},
        "batches-bool": {"type": "mis", "sampler": "sobol", "batches": True},
        "batches-1": {"type": "mis", "sampler": "sobol", "batches": 1},
        "batches-neg": {"type": "mis", "sampler": "sobol", "batches": -4},
        "batches-null": {"type": "mis", "sampler": "sobol", "batches": None},
        "batches-list": {"type": "mis", "sampler": "sobol", "batches": [4]},
        "batches-huge": {"type": "mis", "sampler": "sobol", "batches": 1e30},
        "batches-nan": {"type": "mis", "sampler": "sobol", "batches": float("nan")},
        "batches-independent": {"type": "mis", "sampler": "independent", "batches": 4},
        "batches-lt": {"type": "lt", "sampler": "sobol", "batches": 4},
        "sampler-bogus": {"type": "mis", "sampler": "halton"},
        "sampler-num": {"type": "mis", "sampler": 3},
        "light-sampler-bogus": {"type": "mis", "light_sampler": "magic"},
        "light-sampler-list": {"type": "mis", "light_sampler": ["bvh"]},
    }.items():
        c.append(Case(f"render-scene-{name}", "render", ["render", "{in}/s.json", "--out", "x.exr", "--quiet"],
                      files={"s.json": scene_with(integrator={**integ, "spp": 2})}, limit=60))
    c.append(Case("render-scene-batches-bdpt", "render", ["render", "{in}/s.json", "--out", "x.exr", "--quiet"],
                  files={"s.json": scene_with(integrator={"type": "bdpt", "sampler": "sobol", "batches": 2, "spp": 4})},
                  expect="ok", outputs=("x.exr",), checks=(exr_has_samples("x.exr"),)))
    c.append(Case("render-scene-batches-ok", "render", ["render", "{in}/s.json", "--out", "x.exr", "--quiet"],
                  files={"s.json": scene_with(integrator={"type": "mis", "sampler": "sobol", "batches": 2, "spp": 4})},
                  expect="ok", outputs=("x.exr",), checks=(exr_has_samples("x.exr"),)))
    for ls in ("uniform", "bvh", "power"):
        c.append(Case(f"render-scene-light-sampler-{ls}", "render", ["render", "{in}/s.json", "--out", "x.exr",
                                                                     "--quiet"],
                      files={"s.json": scene_with(integrator={"type": "mis", "light_sampler": ls, "spp": 2})},
                      expect="ok", outputs=("x.exr",), checks=(exr_has_samples("x.exr"),)))
    api = {
        "batches-1": "mcocl.render(SCENE, spp=4, sampler='sobol', batches=1)",
        "batches-word": "mcocl.render(SCENE, spp=4, sampler='sobol', batches='four')",
        "batches-float": "mcocl.render(SCENE, spp=4, sampler='sobol', batches=4.5)",
        "batches-nan": "mcocl.render(SCENE, spp=4, sampler='sobol', batches=float('nan'))",
        "batches-bool": "mcocl.render(SCENE, spp=4, sampler='sobol', batches=True)",
        "batches-independent": "mcocl.render(SCENE, spp=4, sampler='independent', batches=4)",
        "batches-and-block": "mcocl.render(SCENE, spp=4, sampler='sobol', batches=2, spp_per_block=2)",
        "sampler-bogus": "mcocl.render(SCENE, spp=1, sampler='halton')",
        "sampler-int": "mcocl.render(SCENE, spp=1, sampler=3)",
        "strategy-str": "mcocl.render(SCENE, spp=1, integrator='bdpt', strategy='ab')",
        "strategy-one": "mcocl.render(SCENE, spp=1, integrator='bdpt', strategy=(1,))",
        "strategy-float": "mcocl.render(SCENE, spp=1, integrator='bdpt', strategy=(1.5, 2))",
        "strategy-nan": "mcocl.render(SCENE, spp=1, integrator='bdpt', strategy=(float('nan'), 2))",
        "strategy-huge": "mcocl.render(SCENE, spp=1, integrator='bdpt', strategy=(10**30, 1))",
        "strategy-huge-unbounded": "mcocl.render(SCENE, spp=1, integrator='bdpt', max_depth=-1, strategy=(10**30, 1))",
        "strategy-past-subpaths": "mcocl.render(SCENE, spp=1, integrator='bdpt', max_depth=-1, strategy=(30, 1))",
        "mis-bogus": "mcocl.render(SCENE, spp=1, integrator='bdpt', mis='bogus')",
        "mis-none": "mcocl.render(SCENE, spp=1, integrator='bdpt', mis=None)",
        "roulette-str": "mcocl.render(SCENE, spp=1, integrator='bdpt', roulette='no')",
        "unweighted-str": "mcocl.render(SCENE, spp=1, integrator='bdpt', unweighted='no')",
    }
    for name, code in api.items():
        c.append(Case(f"render-api-{name}", "render", api=code, limit=60))
    # a numeric string is a number throughout the API (mcocl/validate.py, whole_number: spp='4' too)
    c.append(Case("render-api-batches-numeric-str", "render", expect="any",
                  api="mcocl.render(SCENE, spp=4, sampler='sobol', batches='4')"))
    return c


def api_cases() -> list[Case]:
    """Bad values through the Python API: each must raise an MCOCLError (exit 2 here), never anything else."""
    c: list[Case] = []
    calls = {
        "dim-float": "mcocl.integrate('x[0]', dim=1.5, samples=100)",
        "dim-str": "mcocl.integrate('x[0]', dim='two', samples=100)",
        "samples-nan": "mcocl.integrate('x[0]', samples=float('nan'))",
        "samples-neg": "mcocl.integrate('x[0]', samples=-1)",
        "samples-str": "mcocl.integrate('x[0]', samples='many')",
        "seed-neg": "mcocl.integrate('x[0]', samples=100, seed=-1)",
        "seed-float": "mcocl.integrate('x[0]', samples=100, seed=1.5)",
        "sampler-none": "mcocl.integrate('x[0]', samples=100, sampler=None)",
        "time-neg": "mcocl.integrate('x[0]', samples=None, time_budget=-1)",
        "target-nan": "mcocl.integrate('x[0]', samples=None, target_error=float('nan'))",
        "lanes-3": "mcocl.integrate('x[0]', samples=100, lanes=3)",
        "device-99": "mcocl.integrate('x[0]', samples=100, device=99)",
        "split-0": "mcocl.integrate('x[0]', samples=100, split=0)",
        "proposal-object": "mcocl.integrate('x[0]', samples=100, proposal=object())",
        "proposal-str": "mcocl.integrate('x[0]', samples=100, proposal='nonsense')",
        "integrand-bytes": "mcocl.integrate(b'x[0]', samples=100)",
        "integrand-none": "mcocl.integrate(None, samples=100)",
        "checkpoint-int": "mcocl.integrate('x[0]', samples=100, checkpoint=123)",
        "resume-folder": "mcocl.integrate('x[0]', samples=100, resume='.')",
        "exponential-0": "mcocl.exponential(rate=0)",
        "power-nan": "mcocl.power(a=float('nan'))",
        "truncnorm-0": "mcocl.truncnorm(mu=0.5, sigma=0)",
        "tabulated-empty": "mcocl.tabulated([])",
        "tabulated-ragged": "mcocl.tabulated([[1], [1, 2]])",
        "tabulated2d-1d": "mcocl.tabulated2d([1, 2])",
        "analytic-neg": "mcocl.integrate('x[0]', samples=1000, proposal=mcocl.analytic('-1.0f', 'u'))",
        "solve-at-nan": "mcocl.solve_fredholm('0.5f', '1.0f', at=[[float('nan')]], walks=100)",
        "solve-at-empty": "mcocl.solve_fredholm('0.5f', '1.0f', at=[], walks=100)",
        "solve-dim-0": "mcocl.solve_fredholm('0.5f', '1.0f', dim=0, walks=100)",
        "solve-walks-0": "mcocl.solve_fredholm('0.5f', '1.0f', walks=0)",
        "solve-survival-neg": "mcocl.solve_fredholm('0.5f', '1.0f', estimator='roulette', survival=-1, walks=100)",
        "render-spp-nan": "mcocl.render(SCENE, spp=float('nan'))",
        "render-spp-huge": "mcocl.render(SCENE, spp=1e30)",
        "render-seed-neg": "mcocl.render(SCENE, spp=1, seed=-1)",
        "render-missing": "mcocl.render('nothere.json', spp=1)",
        "render-int-scene": "mcocl.render(42, spp=1)",
        "srgb-exposure-1e30": "from mcocl.render.image_io import srgb_encode\n"
                              "import numpy as np\nsrgb_encode(np.ones((2, 2, 3)), exposure=1e30)",
        "srgb-exposure-nan": "from mcocl.render.image_io import srgb_encode\n"
                             "import numpy as np\nsrgb_encode(np.ones((2, 2, 3)), exposure=float('nan'))",
        "save-png-exposure": "r = mcocl.render(SCENE, spp=1)\nr.save_png('p.png', exposure=1e30)",
        "write-exr-nan-shape": "from mcocl.render.image_io import write_exr\nimport numpy as np\n"
                               "write_exr('a.exr', np.ones((2, 2)))",
        "load-scene-dev-null": "from mcocl.render.scene_file import load_scene\nload_scene('/dev/null')",
        "checkpoint-passwd": "from mcocl.accumulate import Accumulator\nAccumulator.load('/etc/passwd')",
    }
    for name, code in calls.items():
        c.append(Case(f"api-{name}", "api", api=code))
    c.append(Case("api-render-scene-ok", "api", api="r = mcocl.render(SCENE, spp=1)", expect="ok"))
    return c


def scene_cases() -> list[Case]:
    """Scene JSON files, malformed or holding hostile values."""
    c: list[Case] = []
    bad: dict[str, bytes | str] = {
        "malformed": "{\"camera\": ",
        "empty": "",
        "list": "[]",
        "nan-origin": scene_with(camera={**TINY_SCENE["camera"], "origin": [float("nan"), 0, 3.9]}),
        "inf-fov": scene_with(camera={**TINY_SCENE["camera"], "fov": float("inf")}),
        "fov-0": scene_with(camera={**TINY_SCENE["camera"], "fov": 0}),
        "fov-180": scene_with(camera={**TINY_SCENE["camera"], "fov": 180}),
        "width-0": scene_with(camera={**TINY_SCENE["camera"], "width": 0}),
        "width-str": scene_with(camera={**TINY_SCENE["camera"], "width": "16"}),
        "width-huge": scene_with(camera={**TINY_SCENE["camera"], "width": 100000, "height": 100000}),
        "camera-degenerate": scene_with(camera={**TINY_SCENE["camera"], "target": [0, 0, 3.9]}),
        "camera-up-parallel": scene_with(camera={**TINY_SCENE["camera"], "up": [0, 0, 1]}),
        "material-unknown-type": scene_with(materials={"white": {"type": "glitter"}}),
        "material-missing-ref": scene_with(shapes=[{"type": "rectangle", "material": "nope"}]),
        "reflectance-nan": scene_with(materials={**TINY_SCENE["materials"],
                                                 "white": {"type": "diffuse", "reflectance": float("nan")}}),
        "reflectance-2": scene_with(materials={**TINY_SCENE["materials"],
                                               "white": {"type": "diffuse", "reflectance": 2.0}}),
        "radiance-neg": scene_with(shapes=[{"type": "rectangle", "material": "white",
                                            "emitter": {"type": "area", "radiance": -1}}]),
        "radiance-1e300": scene_with(shapes=[{"type": "rectangle", "material": "white",
                                              "emitter": {"type": "area", "radiance": 1e300}}]),
        "scale-0": scene_with(shapes=[{"type": "rectangle", "material": "white", "transform": [{"scale": 0}]}]),
        "rotate-axis-0": scene_with(shapes=[{"type": "rectangle", "material": "white",
                                             "transform": [{"rotate": {"axis": [0, 0, 0], "angle": 3}}]}]),
        "translate-huge": scene_with(shapes=[{"type": "rectangle", "material": "white",
                                              "transform": [{"translate": [-3.4e38, 0, 0]}]}]),
        "shapes-not-list": scene_with(shapes={"a": 1}),
        "shape-type-unknown": scene_with(shapes=[{"type": "teapot", "material": "white"}]),
        "integrator-bogus": scene_with(integrator={"type": "bogus"}),
        "spp-1e30": scene_with(integrator={"type": "mis", "spp": 1e30}),
        "max-depth-1e12": scene_with(integrator={"type": "mis", "max_depth": 10**12}),
        "max-depth-bool": scene_with(integrator={"type": "mis", "max_depth": True}),
        "deep": "[" * 100000 + "]" * 100000,
        "not-utf8": b"\xff\xfe{\x00}",
        "duplicate-keys": '{"camera": 1, "camera": ' + json.dumps(TINY_SCENE["camera"]) + "}",
        "sphere-radius-neg": scene_with(shapes=[{"type": "sphere", "material": "white", "radius": -1}]),
        "sphere-radius-nan": scene_with(shapes=[{"type": "sphere", "material": "white", "radius": float("nan")}]),
        "mesh-faces-huge-index": scene_with(shapes=[{"type": "mesh", "material": "white",
                                                     "vertices": [[0, 0, 0]] * 3, "faces": [[0, 1, 10**23]]}]),
        "mesh-faces-negative": scene_with(shapes=[{"type": "mesh", "material": "white",
                                                   "vertices": [[0, 0, 0]] * 3, "faces": [[0, 1, -1]]}]),
        "mesh-vertex-nan": scene_with(shapes=[{"type": "mesh", "material": "white",
                                               "vertices": [[0, 0, float("nan")], [1, 0, 0], [0, 1, 0]],
                                               "faces": [[0, 1, 2]]}]),
        "obj-absolute": mesh_scene("/etc/passwd"),
        "obj-dotdot": mesh_scene("../../../../../../etc/passwd"),
        "obj-folder": mesh_scene("."),
        "obj-dev-zero": mesh_scene("/dev/zero"),
        "big-string": scene_with(comment="x" * 5_000_000),
    }
    # valid if odd: a black image, an albedo above 1 (energy is added, as asked), a long comment
    ok = {"empty-shapes": scene_with(shapes=[]),
          "reflectance-2": bad.pop("reflectance-2"), "big-string": bad.pop("big-string")}
    for name, text in bad.items():
        c.append(Case(f"scene-{name}", "scene", ["render", "{in}/s.json", "--out", "x.exr", "--quiet"],
                      files={"s.json": text}, limit=60))
    for name, text in ok.items():
        c.append(Case(f"scene-{name}", "scene", ["render", "{in}/s.json", "--out", "x.exr", "--quiet"],
                      files={"s.json": text}, expect="any", outputs=("x.exr",)))
    c.append(Case("scene-furnace-exact", "scene", ["render", str(SCENES / "furnace.json"), "--spp", "4",
                                                    "--out", "f.exr", "--quiet"],
                  expect="ok", outputs=("f.exr",), checks=(furnace_is_one("f.exr"),)))
    return c


def xml_cases() -> list[Case]:
    """Mitsuba XML: malformed, entities, includes outside, wrong types."""
    head = '<?xml version="1.0"?>\n'
    base = (SCENES / "xml" / "cornell.xml").read_text().replace('value="256"', 'value="16"').replace(
        'value="64"', 'value="2"')
    bad = {
        "malformed": "<scene version='3.0.0'><bsdf",
        "empty": "",
        "doctype-entity": head + '<!DOCTYPE s [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;">]>'
                                 '<scene version="3.0.0">&b;</scene>',
        "external-entity": head + '<!DOCTYPE s [<!ENTITY x SYSTEM "file:///etc/passwd">]><scene version="3.0.0">'
                                  '&x;</scene>',
        "include-outside": head + '<scene version="3.0.0"><include filename="/etc/passwd"/></scene>',
        "include-dotdot": head + '<scene version="3.0.0"><include filename="../../../etc/hosts"/></scene>',
        "include-self": head + '<scene version="3.0.0"><include filename="s.xml"/></scene>',
        "obj-outside": head + '<scene version="3.0.0"><shape type="obj"><string name="filename" '
                              'value="/etc/passwd"/></shape></scene>',
        "integer-abc": base.replace('value="$max_depth"', 'value="abc"'),
        "float-nan": base.replace('value="39.3077"', 'value="nan"'),
        "float-huge": base.replace('value="39.3077"', 'value="1e400"'),
        "resx-huge": base.replace('<default name="resx" value="16"/>', '<default name="resx" value="100000"/>')
        .replace('<default name="resy" value="16"/>', '<default name="resy" value="100000"/>'),
        "ref-missing": base.replace('<bsdf type="diffuse" id="white">', '<bsdf type="diffuse" id="whyte">'),
        "unknown-plugin": base.replace('<bsdf type="diffuse" id="white">', '<bsdf type="glitter" id="white">'),
        "deep": head + "<scene version='3.0.0'>" + "<a>" * 100000 + "</a>" * 100000 + "</scene>",
        "not-utf8": b'<?xml version="1.0" encoding="utf-8"?><scene version="3.0.0">\xff\xfe</scene>',
        "rgb-wrong-arity": base.replace('value="0.885809, 0.698859, 0.666422"', 'value="0.8, 0.7"'),
        "version-bogus": base.replace('version="3.0.0"', 'version="banana"'),
        "translate-huge": base.replace('<lookat origin="0, 0, 3.9"', '<lookat origin="0, 0, 1e39"'),
        "sample-border-word": base.replace('<rfilter type="box"/>',
                                           '<rfilter type="box"/><boolean name="sample_border" value="maybe"/>'),
        "sample-border-int": base.replace('<rfilter type="box"/>',
                                          '<rfilter type="box"/><integer name="sample_border" value="1"/>'),
        "focus-word": base.replace('<float name="fov"', '<float name="focus_distance" value="far"/><float name="fov"'),
        "focus-nan": base.replace('<sensor type="perspective">', '<sensor type="thinlens">').replace(
            '<float name="fov"', '<float name="aperture_radius" value="0.1"/><float name="focus_distance" '
                                 'value="nan"/><float name="fov"'),
        "focus-neg": base.replace('<sensor type="perspective">', '<sensor type="thinlens">').replace(
            '<float name="fov"', '<float name="aperture_radius" value="0.1"/><float name="focus_distance" '
                                 'value="-2"/><float name="fov"'),
        "aperture-neg": base.replace('<sensor type="perspective">', '<sensor type="thinlens">').replace(
            '<float name="fov"', '<float name="aperture_radius" value="-0.1"/><float name="fov"'),
        "aperture-missing": base.replace('<sensor type="perspective">', '<sensor type="thinlens">'),
        "aperture-word": base.replace('<sensor type="perspective">', '<sensor type="thinlens">').replace(
            '<float name="fov"', '<float name="aperture_radius" value="wide"/><float name="fov"'),
        "aperture-inf": base.replace('<sensor type="perspective">', '<sensor type="thinlens">').replace(
            '<float name="fov"', '<float name="aperture_radius" value="inf"/><float name="fov"'),
        "shutter-word": base.replace('<float name="fov"', '<float name="shutter_open" value="soon"/><float name="fov"'),
    }
    c = []
    for name, text in bad.items():
        c.append(Case(f"xml-render-{name}", "xml", ["render", "{in}/s.xml", "--out", "x.exr", "--quiet"],
                      files={"s.xml": text}, limit=60))
    for name in ("doctype-entity", "include-outside", "malformed", "not-utf8", "obj-outside"):
        c.append(Case(f"xml-convert-{name}", "xml", ["convert", "{in}/s.xml", "-o", "o.json"],
                      files={"s.xml": bad[name]}))
    ok = {  # valid: aperture 0 is a pinhole (mcocl/render/scene.py), sample_border and the shutter are read
        "thinlens-aperture-0": base.replace('<sensor type="perspective">', '<sensor type="thinlens">').replace(
            '<float name="fov"', '<float name="aperture_radius" value="0"/><float name="fov"'),
        "thinlens-ok": base.replace('<sensor type="perspective">', '<sensor type="thinlens">').replace(
            '<float name="fov"', '<float name="aperture_radius" value="0.05"/><float name="focus_distance" '
                                 'value="3.9"/><float name="fov"'),
        "sample-border-false": base.replace('<rfilter type="box"/>',
                                            '<rfilter type="box"/><boolean name="sample_border" value="false"/>'),
        "shutter-ok": base.replace('<float name="fov"', '<float name="shutter_open" value="0"/>'
                                                        '<float name="shutter_close" value="0.5"/><float name="fov"'),
    }
    for name, text in ok.items():
        c.append(Case(f"xml-render-{name}", "xml", ["render", "{in}/s.xml", "--out", "x.exr", "--quiet"],
                      files={"s.xml": text}, expect="ok", outputs=("x.exr",), checks=(exr_has_samples("x.exr"),),
                      limit=90))
    c.append(Case("xml-convert-ok", "xml", ["convert", "{in}/tiny.xml", "-o", "o.json"], expect="ok",
                  outputs=("o.json",)))
    c.append(Case("xml-define-injection", "xml", ["render", "{in}/tiny.xml", "--out", "x.exr", "-D",
                                                  'resx=16"/><include filename="/etc/passwd"/><x a="']))
    return c


def problem_cases() -> list[Case]:
    """Bench problem files: code in 'numpy', forwarded options, wrong types."""
    p = PROBLEM["problems"][0]
    bad = {
        "eval-escape": {**p, "numpy": "().__class__.__base__.__subclasses__()"},
        "eval-import": {**p, "numpy": "__import__('os').system('touch pwned')"},
        "estimators-checkpoint": {**p, "estimators": {"m": {"checkpoint": "pwned.ckpt"}}},
        "estimators-client": {**p, "estimators": {"m": {"client": "tcp://1.2.3.4:1"}}},
        "dim-str": {**p, "dim": "1"},
        "dim-0": {**p, "dim": 0},
        "dim-huge": {**p, "dim": 10**9},
        "exact-nan": {**p, "exact": float("nan")},
        "exact-str": {**p, "exact": "0.7"},
        "expression-num": {**p, "expression": 5},
        "name-path": {**p, "name": "../../pwned"},
        "name-huge": {**p, "name": "n" * 10000},
        "proposals-bogus": {**p, "proposals": ["bogus"]},
        "control-no-integral": {**p, "control": {"expression": "x[0]"}},
    }
    c = []
    for name, prob in bad.items():
        c.append(Case(f"problem-{name}", "problem", ["bench", "--no-plot", "--no-numpy", "--budget", "0.05",
                                                      "--out", "b", "integrate", "--problem", "{in}/p.json"],
                      files={"p.json": json.dumps({"problems": [prob]})}, outputs=("b",), limit=90,
                      expect="any" if name.startswith("name") else "error"))
    for name, text in {"malformed": "{", "not-utf8": b"\xff\xfe", "deep": "[" * 100000,
                       "no-problems": "{}", "problems-str": '{"problems": "x"}'}.items():
        c.append(Case(f"problem-{name}", "problem", ["bench", "--no-plot", "--budget", "0.05", "--out", "b",
                                                      "integrate", "--problem", "{in}/p.json"],
                      files={"p.json": text}, outputs=("b",)))
    return c


def mesh_cases() -> list[Case]:
    """OBJ and PLY files: truncated, huge indices, NaN vertices."""
    objs = {
        "truncated-face": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2",
        "index-0": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
        "index-neg-out": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -9\n",
        "index-1e23": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 100000000000000000000000\n",
        "index-past-end": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
        "vertex-nan": "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        "vertex-inf": "v inf 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        "vertex-1e39": "v 1e39 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        "vertex-word": "v a b c\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        "not-utf8": b"v 0 0 0\nv 1 0 0\n\xff\xfe\nf 1 2 3\n",
        "empty": "",
        "mtllib-outside": "mtllib /etc/passwd\n" + QUAD_OBJ,
        "texture-indices": "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1/1 2/1/1 3/1/1\n",
        "vertex-2-coords": "v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    }
    c = []
    for name, text in objs.items():
        expect = "any" if name in ("mtllib-outside", "texture-indices") else "error"
        c.append(Case(f"mesh-obj-{name}", "mesh", ["render", "{in}/s.json", "--out", "x.exr", "--quiet"],
                      files={"s.json": mesh_scene("m.obj"), "m.obj": text}, expect=expect,
                      outputs=("x.exr",) if expect == "any" else ()))
    plys = {
        "truncated-binary": (b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
                             b"property float y\nproperty float z\nelement face 1\n"
                             b"property list uchar int vertex_indices\nend_header\n") + b"\x00" * 10,
        "count-huge": GOOD_PLY.replace("element vertex 3", "element vertex 1000000000000"),
        "count-negative": GOOD_PLY.replace("element vertex 3", "element vertex -3"),
        "vertex-nan": PLY_HEAD + "nan 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        "index-huge": PLY_HEAD + "0 0 0\n1 0 0\n0 1 0\n3 0 1 99999999999\n",
        "index-neg": PLY_HEAD + "0 0 0\n1 0 0\n0 1 0\n3 0 1 -5\n",
        "format-bogus": GOOD_PLY.replace("format ascii 1.0", "format chaos 9"),
        "no-end-header": PLY_HEAD.replace("end_header\n", ""),
        "list-count-255": PLY_HEAD + "0 0 0\n1 0 0\n0 1 0\n255 0 1 2\n",
        "not-ply": "hello",
        "type-bogus": GOOD_PLY.replace("property float x", "property quaternion x"),
    }
    for name, text in plys.items():
        c.append(Case(f"mesh-ply-{name}", "mesh", ["render", "{in}/s.json", "--out", "x.exr", "--quiet"],
                      files={"s.json": mesh_scene("m.ply"), "m.ply": text}, limit=60))
    c.append(Case("mesh-obj-good", "mesh", ["render", "{in}/s.json", "--out", "x.exr", "--quiet"],
                  files={"s.json": mesh_scene("quad.obj")}, expect="ok", outputs=("x.exr",)))
    return c


def checkpoint_cases() -> list[Case]:
    """Checkpoints: truncated, bit-flipped, edited, of the wrong kind, not checkpoints at all."""
    c = []
    integ = ["integrate", "exp(-x[0]*x[0])", "--samples", "131072", "--json", "--quiet"]
    for name, prep in [("empty", truncated("int.ckpt", 0)), ("half", truncated("int.ckpt", 0.5)),
                       ("header", truncated("int.ckpt", 0.02)), ("flip-10", flipped("int.ckpt", 0.1)),
                       ("flip-50", flipped("int.ckpt", 0.5)), ("flip-90", flipped("int.ckpt", 0.9)),
                       ("flip-99", flipped("int.ckpt", 0.99)),
                       ("edit-shift", edited_meta("int.ckpt", "shift", 1e300)),
                       ("edit-unit-limit", edited_meta("int.ckpt", "unit_limit", -5)),
                       ("edit-dim", edited_meta("int.ckpt", "dim", 0)),
                       ("edit-design", edited_meta("int.ckpt", "design", {"sampler": "independent"})),
                       ("edit-kind", edited_meta("int.ckpt", "kind", "render")),
                       ("edit-seed", edited_meta("int.ckpt", "seed", "abc"))]:
        # a flipped bit may land in a byte that carries nothing (a zip timestamp): then the resumed
        # run must still give the right answer; anywhere else it must be refused
        flip = name.startswith("flip") or name == "edit-unit-limit"  # unit_limit is read only after a partial block
        c.append(Case(f"ckpt-int-{name}", "checkpoint", [*integ, "--resume", "{in}/int.ckpt"], prepare=prep,
                      expect="any" if flip else "error", checks=(estimate_near(BUMP),) if flip else ()))
    for name, argv in [
        ("render-into-integrate", [*integ, "--resume", "{in}/render.ckpt"]),
        ("solve-into-integrate", [*integ, "--resume", "{in}/solve.ckpt"]),
        ("integrate-into-render", ["render", "{in}/tiny.json", "--out", "x.exr", "--resume", "{in}/int.ckpt"]),
        ("integrate-into-solve", ["solve", "--kernel", "0.5f", "--source", "1.0f", "--at", "0.5",
                                  "--resume", "{in}/int.ckpt"]),
        ("other-integrand", ["integrate", "x[0]", "--samples", "131072", "--resume", "{in}/int.ckpt"]),
        ("other-seed", [*integ, "--seed", "9", "--resume", "{in}/int.ckpt"]),
        ("other-dim", ["integrate", "exp(-x[0]*x[0])", "--dim", "2", "--samples", "131072",
                       "--resume", "{in}/int.ckpt"]),
        ("other-sampler", [*integ, "--sampler", "stratified", "--resume", "{in}/int.ckpt"]),
        ("other-scene", ["render", str(SCENES / "furnace.json"), "--spp", "4", "--out", "x.exr",
                         "--resume", "{in}/render.ckpt"]),
        ("other-solve-kernel", ["solve", "--kernel", "0.25f", "--source", "1.0f", "--at", "0.5", "--walks", "8192",
                                "--resume", "{in}/solve.ckpt"]),
        ("image", [*integ, "--resume", "{in}/img.exr"]),
        ("dev-null", [*integ, "--resume", "/dev/null"]),
        ("folder", [*integ, "--resume", "{in}"]),
        ("passwd", [*integ, "--resume", "/etc/passwd"]),
        ("scene-file", [*integ, "--resume", "{in}/tiny.json"]),
    ]:
        c.append(Case(f"ckpt-{name}", "checkpoint", argv))

    sob = ["render", "{in}/tiny.json", "--sampler", "sobol", "--spp", "1024", "--out", "x.exr", "--quiet"]
    for name, prep, expect in [
        ("bp-negative", edited_meta("sobol.ckpt", "block_pixels", -64), "error"),
        ("bp-zero", edited_meta("sobol.ckpt", "block_pixels", 0), "error"),
        ("bp-huge", edited_meta("sobol.ckpt", "block_pixels", 10**18), "error"),
        ("bp-film", edited_meta("sobol.ckpt", "block_pixels", 256), "error"),  # a "range" of the whole film
        ("bp-not-tile", edited_meta("sobol.ckpt", "block_pixels", 96), "error"),
        ("bp-float", edited_meta("sobol.ckpt", "block_pixels", 64.5), "error"),
        ("bp-str", edited_meta("sobol.ckpt", "block_pixels", "64"), "error"),
        ("bp-bool", edited_meta("sobol.ckpt", "block_pixels", True), "error"),
        ("bp-list", edited_meta("sobol.ckpt", "block_pixels", [64]), "error"),
        # another valid cut: a different job's blocks, whose image is as valid (the digest is no signature)
        ("bp-128", edited_meta("sobol.ckpt", "block_pixels", 128), "any"),
        ("bp-missing", edited_meta("sobol.ckpt", "block_pixels", DELETE), "any"),
        ("spb-missing", edited_meta("sobol.ckpt", "spp_per_block", DELETE), "error"),
        ("spb-zero", edited_meta("sobol.ckpt", "spp_per_block", 0), "error"),
        ("spb-huge", edited_meta("sobol.ckpt", "spp_per_block", 2**40), "error"),
        ("spb-max", edited_meta("sobol.ckpt", "spp_per_block", 2**32 - 2), "any"),
        ("spb-str", edited_meta("sobol.ckpt", "spp_per_block", "256"), "error"),
        ("limit-missing", edited_meta("sobol.ckpt", "spp_limit", DELETE), "error"),
        ("limit-neg", edited_meta("sobol.ckpt", "spp_limit", -1), "error"),
        ("sampler-missing", edited_meta("sobol.ckpt", "sampler", DELETE), "error"),
        ("sampler-int", edited_meta("sobol.ckpt", "sampler", 7), "error"),
        ("width-str", edited_meta("sobol.ckpt", "width", "16"), "error"),
        ("blocks-huge", edited_blocks("sobol.ckpt", 10**15), "any"),
        ("blocks-mid-batch", edited_blocks("sobol.ckpt", 6), "any"),
        ("half", truncated("sobol.ckpt", 0.5), "error"),
        ("flip-50", flipped("sobol.ckpt", 0.5), "any"),
    ]:
        c.append(Case(f"ckpt-sobol-{name}", "checkpoint", [*sob, "--resume", "{in}/sobol.ckpt"], prepare=prep,
                      expect=expect, outputs=("x.exr",) if expect == "any" else (),
                      checks=(exr_has_samples("x.exr"),) if expect == "any" else (), limit=90))
    for name, extra in [("batches-other", ["--batches", "8"]), ("spp-other", ["--spp", "2048"]),
                        ("spp-fewer", ["--spp", "512"]), ("sampler-other", ["--sampler", "independent"]),
                        ("integrator-other", ["--integrator", "path"]), ("seed-other", ["--seed", "3"]),
                        ("time", ["--time", "1", "--spp", "4096"])]:
        argv = [*sob, *extra, "--resume", "{in}/sobol.ckpt"]
        expect = "any" if name in ("spp-other", "spp-fewer", "time") else "error"
        c.append(Case(f"ckpt-sobol-resume-{name}", "checkpoint", argv, expect=expect,
                      outputs=("x.exr",) if expect == "any" else (),
                      checks=(exr_has_samples("x.exr"),) if expect == "any" else (), limit=90))
    c.append(Case("ckpt-sobol-resume-good", "checkpoint", [*sob, "--resume", "{in}/sobol.ckpt"], expect="ok",
                  outputs=("x.exr",), checks=(exr_has_samples("x.exr"),)))
    c.append(Case("ckpt-sobol-into-independent", "checkpoint",
                  ["render", "{in}/tiny.json", "--spp", "1024", "--sampler", "independent", "--out", "x.exr",
                   "--resume", "{in}/sobol.ckpt"]))
    c.append(Case("ckpt-independent-into-sobol", "checkpoint",
                  [*sob, "--resume", "{in}/render.ckpt"]))

    def pickle_npz(case_dir: Path) -> None:
        code = (f"import numpy as np; np.savez({str(case_dir / 'in' / 'p.npz')!r}, "
                "meta=np.array([{'a': 1}], dtype=object))")
        subprocess.run([PY, "-c", code], check=True)

    c.append(Case("ckpt-pickled-npz", "checkpoint", [*integ, "--resume", "{in}/p.npz"], prepare=pickle_npz))

    def symlink(case_dir: Path) -> None:
        (case_dir / "in" / "link.ckpt").symlink_to("/etc/shadow")

    c.append(Case("ckpt-symlink-shadow", "checkpoint", [*integ, "--resume", "{in}/link.ckpt"], prepare=symlink))
    c.append(Case("ckpt-resume-good", "checkpoint", [*integ, "--resume", "{in}/int.ckpt"], expect="ok",
                  checks=(estimate_near(BUMP),)))
    c.append(Case("ckpt-resume-render-good", "checkpoint", ["render", "{in}/tiny.json", "--spp", "4", "--out", "x.exr",
                                                            "--resume", "{in}/render.ckpt", "--quiet"],
                  expect="ok", outputs=("x.exr",)))
    return c


def output_cases() -> list[Case]:
    """Outputs: missing folders, folders, read-only, equal to inputs or to each other."""
    tiny = "{in}/tiny.json"
    r = ["render", tiny, "--spp", "100000", "--quiet"]
    cases = {
        "out-missing-folder": [*r, "--out", "nope/x.exr"],
        "out-folder": [*r, "--out", "."],
        "out-readonly": [*r, "--out", "../ro/x.exr"],
        "out-is-scene": [*r, "--out", tiny],
        "png-is-out": [*r, "--out", "a.exr", "--png", "a.exr"],
        "ckpt-is-out": [*r, "--out", "a.exr", "--checkpoint", "a.exr"],
        "png-is-scene": [*r, "--out", "a.exr", "--png", tiny],
        "png-missing-folder": [*r, "--out", "a.exr", "--png", "nope/p.png"],
        "ckpt-missing-folder": [*r, "--out", "a.exr", "--checkpoint", "nope/c.ckpt"],
        "out-dev-full": [*r, "--out", "/dev/full"],
        "out-empty": [*r, "--out", ""],
        "out-is-mesh": ["render", "{in}/s.json", "--spp", "100000", "--out", "{in}/quad.obj"],
        "integrate-ckpt-missing": ["integrate", "x[0]", "--samples", "1e13", "--checkpoint", "nope/c.ckpt"],
        "integrate-ckpt-folder": ["integrate", "x[0]", "--samples", "1e13", "--checkpoint", "."],
        "integrate-ckpt-readonly": ["integrate", "x[0]", "--samples", "1e13", "--checkpoint", "../ro/c.ckpt"],
        "solve-ckpt-missing": ["solve", "--kernel", "0.5f", "--source", "1.0f", "--at", "0.5", "--walks", "1e12",
                               "--checkpoint", "nope/c.ckpt"],
        "bench-out-file": ["bench", "--out", "{in}/tiny.json", "integrate"],
        "bench-out-readonly": ["bench", "--out", "../ro/b", "integrate"],
        "convert-out-folder": ["convert", "{in}/tiny.xml", "-o", "."],
        "convert-out-readonly": ["convert", "{in}/tiny.xml", "-o", "../ro/o.json"],
    }
    if AS_ROOT:  # root writes into a read-only folder: those cases cannot be refused, and are left out
        cases = {k: v for k, v in cases.items() if "readonly" not in k}
    c = [Case(f"out-{k}", "output", v, files={"s.json": mesh_scene("quad.obj")}, prepare=readonly_out, limit=30,
              checks=(lambda o: f"hang: took {o.wall:.1f} s; work ran before the output check" if o.wall > 15
                      else None,)) for k, v in cases.items()]
    c.append(Case("out-resume-equals-checkpoint", "output",
                  ["integrate", "exp(-x[0]*x[0])", "--samples", "131072", "--resume", "{in}/int.ckpt", "--checkpoint",
                   "{in}/int.ckpt", "--json", "--quiet"], expect="any", checks=(estimate_near(BUMP),),
                  mutable=("int.ckpt",)))
    c.append(Case("out-png-is-mesh", "output", ["render", "{in}/s.json", "--out", "a.exr", "--png", "{in}/quad.obj"],
                  files={"s.json": mesh_scene("quad.obj")}))
    c.append(Case("out-ckpt-is-user-file", "output", ["integrate", "x[0]", "--checkpoint", "{in}/problem.json"]))
    c.append(Case("out-default-name", "output", ["render", tiny, "--quiet"], expect="ok", outputs=("tiny.exr",)))
    return c


def signal_cases() -> list[Case]:
    """SIGINT, two SIGINTs and SIGTERM during work: the result and the checkpoint survive."""
    c = []
    int_run = ["integrate", "exp(-x[0]*x[0])", "--samples", "1e14", "--checkpoint", "c.ckpt"]
    rnd_run = ["render", "{in}/tiny.json", "--spp", "1000000", "--out", "x.exr", "--checkpoint", "c.ckpt", "--quiet"]
    sol_run = ["solve", "--kernel", "0.5f", "--source", "1.0f", "--at", "0.5", "--walks", "1e13",
               "--checkpoint", "c.ckpt"]
    for what, argv, extra in [("integrate", int_run, (file_kept("c.ckpt", "ckpt"), printed_estimate)),
                              ("render", rnd_run, (file_kept("x.exr", "exr"), file_kept("c.ckpt", "ckpt"))),
                              ("solve", sol_run, (file_kept("c.ckpt", "ckpt"), printed_estimate))]:
        outs = ("c.ckpt", "x.exr") if what == "render" else ("c.ckpt",)
        for sname, sigs in [("sigint", (("c.ckpt", signal.SIGINT),)),
                            ("2sigint", (("c.ckpt", signal.SIGINT), (0.05, signal.SIGINT))),
                            ("sigterm", (("c.ckpt", signal.SIGTERM),)),
                            ("sigint-sigterm", (("c.ckpt", signal.SIGINT), (0.05, signal.SIGTERM))),
                            # the second request lands while the stopped run reports and saves its result
                            ("sigint-late-sigint", (("c.ckpt", signal.SIGINT), (0.4, signal.SIGINT))),
                            ("sigint-late-sigterm", (("c.ckpt", signal.SIGINT), (1.0, signal.SIGTERM)))]:
            c.append(Case(f"sig-{what}-{sname}", "signal", argv, expect="signal", signals=sigs, outputs=outs,
                          checks=extra, limit=90))
    sob_run = ["render", "{in}/tiny.json", "--sampler", "sobol", "--batches", "2", "--spp", "1000000", "--out", "x.exr",
               "--checkpoint", "c.ckpt", "--quiet"]
    for sname, sigs in [("sigint", (("c.ckpt", signal.SIGINT),)), ("sigterm", (("c.ckpt", signal.SIGTERM),)),
                        ("2sigint", (("c.ckpt", signal.SIGINT), (0.5, signal.SIGINT)))]:
        c.append(Case(f"sig-sobol-batch-{sname}", "signal", sob_run, expect="signal", signals=sigs,
                      outputs=("c.ckpt", "x.exr"), checks=(file_kept("x.exr", "exr"), file_kept("c.ckpt", "ckpt")),
                      limit=120))
    # batches of 25,000 spp: blocks of 64 pixels x 25,000 paths, each done in a moment
    c.append(Case("sig-sobol-small-batches-sigint", "signal",
                  ["render", "{in}/tiny.json", "--sampler", "sobol", "--spp", "100000", "--out", "x.exr",
                   "--checkpoint", "c.ckpt", "--quiet"], expect="signal", signals=(("c.ckpt", signal.SIGINT),),
                  outputs=("c.ckpt", "x.exr"), checks=(file_kept("x.exr", "exr"),), limit=90))
    c.append(Case("sig-loop-sigint", "signal", ["integrate", LOOP, "--samples", "1e6"], expect="signal",
                  signals=((3.0, signal.SIGINT),), limit=30))
    c.append(Case("sig-loop-2sigint", "signal", ["integrate", LOOP, "--samples", "1e6"], expect="signal",
                  signals=((3.0, signal.SIGINT), (0.5, signal.SIGINT)), limit=30))
    c.append(Case("sig-loop-sigterm", "signal", ["integrate", LOOP, "--samples", "1e6"], expect="signal",
                  signals=((3.0, signal.SIGTERM),), limit=30))
    c.append(Case("sig-during-startup", "signal", ["integrate", "x[0]*x[1]", "--dim", "2", "--samples", "1e12"],
                  expect="any", signals=((0.3, signal.SIGINT),), limit=30))
    c.append(Case("sig-bench", "signal", ["bench", "--no-plot", "--no-numpy", "--budget", "30", "--out", "b",
                                          "integrate", "--problem", "{in}/problem.json"],
                  expect="signal", signals=((6.0, signal.SIGINT),), outputs=("b",), limit=60))
    c.append(Case("sig-resume-after-sigint", "signal", ["integrate", "exp(-x[0]*x[0])", "--samples", "1e14",
                                                        "--checkpoint", "{in}/int.ckpt", "--resume", "{in}/int.ckpt"],
                  # late enough that sampling has begun on a busy machine (an interrupt while the child
                  # still imports ends it with "nothing was computed", the checkpoint unchanged)
                  expect="signal", signals=((8.0, signal.SIGINT),), checks=(printed_estimate,), limit=60,
                  mutable=("int.ckpt",)))
    return c


def env_cases() -> list[Case]:
    """Environment variables holding nonsense."""
    c = []
    run = ["integrate", "exp(-x[0]*x[0])", "--samples", "65536", "--json", "--quiet"]

    def env_case(name: str, env: dict[str, str | None], expect: str = "error", prep=None) -> None:
        c.append(Case(f"env-{name}", "env", run, env=env, expect=expect, prepare=prep,
                      checks=(estimate_near(BUMP),) if expect != "error" else ()))

    for v in ["abc", "0", "3", "1e9", "-1", ""]:  # 3 is rounded down to a lane width (runtime.default_lanes)
        env_case(f"lanes-{v or 'empty'}", {"MCOCL_LANES": v}, expect="any" if v in ("", "3") else "error")
    env_case("pocl-cache-under-file", {"POCL_CACHE_DIR": "{in}/tiny.json/cache"}, expect="any")
    env_case("pocl-cache-readonly", {"POCL_CACHE_DIR": "{case}/ro/cache"}, expect="any", prep=readonly_out)
    env_case("pyopencl-ctx-nonsense", {"PYOPENCL_CTX": "nonsense"}, expect="any")
    env_case("pyopencl-ctx-99", {"PYOPENCL_CTX": "99"}, expect="any")
    env_case("pyopencl-ctx-colon", {"PYOPENCL_CTX": ":"}, expect="any")
    env_case("ocl-icd-vendors-none", {"OCL_ICD_VENDORS": "{in}/novendors"})
    env_case("supervise-banana", {"MCOCL_SUPERVISE": "banana"}, expect="any")
    env_case("heartbeat-fd-99", {"MCOCL_HEARTBEAT_FD": "99"}, expect="any")
    env_case("heartbeat-fd-abc", {"MCOCL_HEARTBEAT_FD": "abc"}, expect="any")
    env_case("build-log-on", {"MCOCL_BUILD_LOG": "1"}, expect="any")
    env_case("home-unset", {"HOME": None}, expect="any")
    env_case("tmpdir-missing", {"TMPDIR": "{in}/nothere"}, expect="any")
    c.append(Case("env-devices-no-icd", "env", ["devices"], env={"OCL_ICD_VENDORS": "{in}/novendors"}))
    return c


def snippet_cases() -> list[Case]:
    """User code that loops, writes out of bounds, overflows or is huge."""
    c = []

    def add(name: str, code: str, *extra: str, expect: str = "any", checks: tuple = (loud_if_nonfinite,),
            **kw: Any) -> None:
        c.append(Case(f"snippet-{name}", "snippet", ["integrate", code, "--json", "--quiet", *extra],
                      expect=expect, checks=checks, **kw))

    for t in (1, 3):
        c.append(Case(f"snippet-loop-time-{t}", "snippet", ["integrate", LOOP, "--time", str(t)], time=float(t),
                      limit=60))
    c.append(Case("snippet-loop-render-time", "snippet", ["solve", "--kernel", "float s=0; for(;;){s+=1;} return s;",
                                                          "--source", "1.0f", "--at", "0.5", "--time", "2"],
                  time=2.0, limit=60))
    add("oob-write", "float a[4]; a[(int)(x[0]*1e9f)] = 1.0f; return a[0];", "--samples", "1e5", expect="error")
    add("null-write", "__global float* p = 0; *p = 1.0f; return 0.0f;", "--samples", "1e4", expect="error")
    add("int-div-zero", "int z = (int)(x[0]*0.0f); return (float)(7 / z);", "--samples", "1e4")
    add("huge-private", "float a[50000000]; a[(int)(x[0]*49999999.0f)] = x[0]; return a[1];", "--samples", "1e4")
    add("nan-samples", "sqrt(-1.0f - x[0])", "--samples", "1e4")
    add("inf-samples", "1.0f/0.0f", "--samples", "1e4")
    add("some-nan", "x[0] < 0.5f ? x[0] : sqrt(-1.0f)", "--samples", "1e4")
    add("overflow-sums", "x[0] < 0.5f ? 3e38f : -3e38f", "--samples", "1e5", expect="ok",
        checks=(estimate_near(0.0),))
    add("big-constant", "3e38f", "--samples", "1e5", expect="ok", checks=(estimate_near(3e38),))
    add("big-constant-stratified", "3e38f", "--samples", "1e5", "--sampler", "stratified", expect="ok",
        checks=(estimate_near(3e38),))
    add("index-beyond-dim", "x[5]", "--dim", "2", expect="error")
    add("index-beyond-dim-walk", "x[0]", expect="ok", checks=(estimate_near(0.5),))
    # past mcocl's 8,000-operator limit (mcocl/snippet_size.py): refused before compiling; below it: compiled
    add("expression-5000", "+".join(["x[0]"] * 5000), "--samples", "1e3", expect="ok",
        checks=(estimate_near(2500.0),), limit=240)
    for n in (12000, 18000):
        add(f"expression-{n}", "+".join(["x[0]"] * n), "--samples", "1e3", expect="error", checks=(says("8,000"),),
            limit=30)
    add("nested-not-9000", "!" * 9000 + "(x[0] > 0.5f)", expect="error", checks=(says("8,000"),), limit=30)
    # 120,000 characters: past mcocl's snippet limit, inside the kernel's 128 KiB limit on one argument
    add("expression-120k-chars", "+".join(["x[0]"] * 24000), "--samples", "1e3", expect="error", limit=240)
    add("printf-flood", 'printf("x"); return 1.0f;', "--samples", "1e3", expect="any", checks=())
    add("time-1e-9", "exp(-x[0]*x[0])", "--samples", "1e12", "--time", "1e-9", expect="ok",
        checks=(estimate_near(BUMP),))
    for sampler in ("independent", "stratified", "nrooks", "sobol", "vegas"):
        add(f"exact-{sampler}", "exp(-x[0]*x[0])", "--samples", "65536", "--sampler", sampler, expect="ok",
            checks=(estimate_near(BUMP),))
    add("exact-proposal", "1.0f/sqrt(x[0])", "--samples", "65536", "--proposal", "power:a=-0.5", expect="ok",
        checks=(estimate_near(2.0),))
    add("exact-control", "exp(x[0])", "--samples", "65536", "--control", "1 + x[0]", "--control-integral", "1.5",
        expect="ok", checks=(estimate_near(math.e - 1),))
    add("exact-roulette", "exp(x[0])", "--samples", "65536", "--roulette", "0.3", expect="ok",
        checks=(estimate_near(math.e - 1),))
    add("exact-lanes-1", "exp(-x[0]*x[0])", "--samples", "65536", "--lanes", "1", expect="ok",
        checks=(estimate_near(BUMP),))
    add("exact-split-2", "exp(-x[0]*x[0])", "--samples", "65536", "--split", "2", expect="ok",
        checks=(estimate_near(BUMP),))
    add("exact-2d", "x[0]*x[1]", "--dim", "2", "--samples", "65536", expect="ok", checks=(estimate_near(0.25),))
    return c


def walk_cases() -> list[Case]:
    """Walks with user-given densities and samplers that do not match their kernels."""
    c = []
    base = ["solve", "--kernel", "0.5f*y[0]", "--source", "1.0f", "--at", "0.5", "--walks", "20000", "--json",
            "--quiet"]
    # f = 1 + 0.5 * int y f(y) dy, f constant c: c = 1 + c/4 -> c = 4/3
    exact = 4.0 / 3.0

    def add(name: str, *extra: str, expect: str = "error", checks: tuple = ()) -> None:
        c.append(Case(f"walk-{name}", "walk", [*base, *extra], expect=expect, checks=checks, limit=60))

    add("exact-nee", expect="ok", checks=(estimate_near(exact),))
    add("exact-roulette", "--estimator", "roulette", expect="ok", checks=(estimate_near(exact),))
    add("exact-subcritical", "--estimator", "subcritical", expect="ok", checks=(estimate_near(exact),))
    add("exact-truncated-40", "--estimator", "truncated", "--depth", "40", expect="ok",
        checks=(estimate_near(exact),))
    add("exact-given-sampler", "--estimator", "subcritical", "--row-integral", "0.25f", "--transition-sampler",
        "sqrt(u[0])", expect="ok", checks=(estimate_near(exact),))
    add("row-integral-wrong", "--estimator", "subcritical", "--row-integral", "2.5f", "--transition-sampler",
        "sqrt(u[0])")
    add("transition-sampler-wrong", "--estimator", "subcritical", "--row-integral", "0.25f", "--transition-sampler",
        "u[0]")
    add("transition-sampler-outside", "--estimator", "subcritical", "--row-integral", "0.25f",
        "--transition-sampler", "2.0f*u[0]")
    add("transition-sampler-nan", "--estimator", "subcritical", "--row-integral", "0.25f",
        "--transition-sampler", "sqrt(-u[0])")
    add("transition-sampler-count", "--estimator", "subcritical", "--row-integral", "0.25f",
        "--transition-sampler", "u[0]", "u[0]")
    add("source-integral-wrong", "--estimator", "nee", "--source-integral", "3.0", "--source-sampler", "u[0]")
    add("source-integral-nan", "--estimator", "nee", "--source-integral", "nan", "--source-sampler", "u[0]")
    add("source-sampler-wrong", "--estimator", "nee", "--source-integral", "1.0", "--source-sampler", "u[0]*u[0]")
    add("source-sampler-given-ok", "--estimator", "nee", "--source-integral", "1.0", "--source-sampler", "u[0]",
        expect="ok", checks=(estimate_near(exact),))
    add("row-integral-without-sampler", "--estimator", "subcritical", "--row-integral", "0.25f", expect="any",
        checks=(estimate_near(exact),))
    c.append(Case("walk-api-transition-wrong", "walk", api=(
        "r = mcocl.solve_fredholm('0.5f*y[0]', '1.0f', estimator='subcritical', row_integral='0.25f', "
        "transition_sampler='1.0f - u[0]', walks=20000)\nprint(r.values)")))
    c.append(Case("walk-api-source-wrong", "walk", api=(
        "r = mcocl.solve_fredholm('0.5f*y[0]', 'x[0]', estimator='nee', source_integral=0.5, "
        "source_sampler='u[0]', walks=20000)\nprint(r.values)")))
    return c


ALL = [cli_cases, render_option_cases, api_cases, scene_cases, xml_cases, problem_cases, mesh_cases, checkpoint_cases, output_cases,
       signal_cases, env_cases, snippet_cases, walk_cases]


# ---------------------------------------------------------------- running

API_WRAPPER = """
import sys
import mcocl
from mcocl.errors import MCOCLError
SCENE = {scene!r}
try:
{body}
except MCOCLError as e:
    print(f"mcocl: error: {{e}}", file=sys.stderr)
    sys.exit(2)
"""


def snapshot(folder: Path) -> dict[str, str]:
    """Relative path -> SHA-256 of every file under ``folder`` (symlinks by target)."""
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_symlink():
            out[str(p.relative_to(folder))] = "link:" + os.readlink(p)
        elif p.is_file():
            try:
                out[str(p.relative_to(folder))] = hashlib.sha256(p.read_bytes()).hexdigest()
            except OSError:
                out[str(p.relative_to(folder))] = "unreadable"
    return out


def _as_in_a_terminal() -> None:
    """Ctrl-C as a terminal delivers it: a suite started in the background (``&``) inherits SIGINT
    ignored, and so would every case, which would then never see its interrupt before it sets its
    own handler."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def run_case(case: Case, base: Path, work: Path) -> tuple[Case, Outcome, list[str]]:
    """Run one case in a fresh folder and classify what happened."""
    d = work / case.name
    shutil.copytree(base, d / "in", symlinks=True)
    (d / "out").mkdir()
    for name, data in case.files.items():
        p = d / "in" / name
        p.write_bytes(data) if isinstance(data, bytes) else p.write_text(data)
    if case.prepare:
        case.prepare(d)
    before = snapshot(d / "in")

    def sub(s: str) -> str:
        return s.replace("{in}", str(d / "in")).replace("{out}", str(d / "out")).replace("{case}", str(d))

    env = {k: v for k, v in os.environ.items() if k not in ("MCOCL_SUPERVISE", "MCOCL_HEARTBEAT_FD")}
    env["PYTHONPATH"] = str(ROOT)
    for k, v in case.env.items():
        if v is None:
            env.pop(k, None)
        else:
            env[k] = sub(v)
    if case.api is not None:
        code = API_WRAPPER.format(scene=str(d / "in" / "tiny.json"), body=textwrap.indent(case.api, "    "))
        cmd = [PY, "-c", code]
    else:
        cmd = [PY, "-m", "mcocl", *[sub(a) for a in (case.argv or [])]]
    t0 = time.monotonic()
    try:
        proc = subprocess.Popen(cmd, cwd=d / "out", env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True, errors="replace", start_new_session=True, preexec_fn=_as_in_a_terminal)
    except OSError as e:  # the case itself cannot be run (an argument past the kernel's limit): the suite's fault
        return case, Outcome(-1, "", str(e), 0.0, d), [f"suite: cannot start the case: {e}"]
    fails: list[str] = []
    try:
        for when, sig in case.signals:
            if isinstance(when, str):  # wait for the file to appear (work has begun)
                target = d / "out" / when
                while not target.exists() and proc.poll() is None and time.monotonic() - t0 < case.limit:
                    time.sleep(0.05)
                time.sleep(0.3)
            else:
                time.sleep(when)
            if proc.poll() is None:
                os.killpg(proc.pid, sig) if sig == signal.SIGINT else proc.send_signal(sig)
        out, err = proc.communicate(timeout=max(1.0, case.limit - (time.monotonic() - t0)))
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)  # the supervised child dies with it (PR_SET_PDEATHSIG)
        out, err = proc.communicate()
        fails.append(f"hang: still running after {case.limit:g} s")
    o = Outcome(proc.returncode, out, err, time.monotonic() - t0, d)

    # classification
    if "Traceback" in err:
        fails.append("traceback: " + (err.strip().splitlines() or ["?"])[-1][:160])
    if o.rc is not None and (o.rc < 0 or o.rc not in OK_CODES) and not any(f.startswith("hang") for f in fails):
        fails.append(f"crash: exit status {o.rc}")
    messages = [ln for ln in err.splitlines() if "error" in ln.lower() or "mcocl" in ln.lower()
                or "interrupt" in ln.lower() or "stopp" in ln.lower()]
    if o.rc not in (0, None) and not messages and not err.strip() and not out.strip():
        fails.append(f"crash: exit {o.rc} without a message")
    if case.expect == "error" and o.rc == 0:
        fails.append("silent: accepted (exit 0) where a refusal was due")
    if case.expect == "ok" and o.rc not in (0,) and not fails:
        fails.append(f"crash: a valid run failed (exit {o.rc}): {err.strip()[-160:]}")
    if case.expect == "signal" and o.rc not in (130, 143) and not fails:
        fails.append(f"lost: exit {o.rc} after a signal (expected 130/143)")
    if case.time is not None and (msg := ended_in_time(o, case.time)):
        fails.append(msg)
    for chk in case.checks:
        try:
            if msg := chk(o):
                fails.append(msg)
        except Exception as e:  # noqa: BLE001 - a check that cannot read the output is a finding
            fails.append(f"lost: check failed ({type(e).__name__}: {e})")
    # files: inputs unchanged, nothing beside in/ and out/, only declared outputs in out/
    after = snapshot(d / "in")
    changed = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k) and k not in case.mutable)
    if changed:
        fails.append(f"escape: inputs changed or added: {changed[:4]}")
    extra = sorted(p.name for p in d.iterdir() if p.name not in ("in", "out", "ro"))
    if extra:
        fails.append(f"escape: files beside the output folder: {extra}")
    if (d / "ro").exists():
        (d / "ro").chmod(0o755)
        stray_ro = [p.name for p in (d / "ro").iterdir()]
        if stray_ro and not case.env:
            fails.append(f"escape: wrote into a read-only folder: {stray_ro}")
    declared = set(case.outputs) | {"c.ckpt"} if case.expect == "signal" else set(case.outputs)
    if case.expect == "signal" and any(w in "".join(case.argv or []) for w in ("x.exr",)):
        declared.add("x.exr")
    if case.api is not None:
        declared |= {"p.png", "a.exr"}
    stray = sorted(p.name for p in (d / "out").iterdir() if p.name not in declared)
    if stray:
        fails.append(f"escape: undeclared files in the output folder: {stray[:4]}")
    if any((p.name == "pwned" or p.name.startswith("pwned")) for p in d.rglob("*")):
        fails.append("escape: a canary file was created (code ran from data)")
    return case, o, fails


def main(argv: list[str] | None = None) -> int:
    """Run the cases and print the table."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--class", dest="classes", default="", help="comma-separated classes to run (default all)")
    ap.add_argument("--case", default="", help="run only cases whose name contains this text")
    ap.add_argument("--jobs", type=int, default=2, help="cases run at once (default 2)")
    ap.add_argument("--every", type=int, default=1, metavar="K",
                    help="run every K-th case of each class only (a quicker, still varied check)")
    ap.add_argument("--list", action="store_true", help="list the cases and exit")
    ap.add_argument("--keep", action="store_true", help="keep the temporary folders")
    ap.add_argument("-v", "--verbose", action="store_true", help="print each case's stderr tail")
    args = ap.parse_args(argv)
    cases = [c for make in ALL for c in make()]
    assert len({c.name for c in cases}) == len(cases), "duplicate case names"
    if args.classes:
        wanted = set(args.classes.split(","))
        cases = [c for c in cases if c.cls in wanted]
    if args.case:
        cases = [c for c in cases if args.case in c.name]
    if args.every > 1:
        cases = [c for cls in dict.fromkeys(c.cls for c in cases)
                 for c in [x for x in cases if x.cls == cls][::args.every]]
    if args.list:
        for c in cases:
            print(f"{c.cls:10} {c.name}")
        print(f"{len(cases)} cases")
        return 0
    guarded = {str(p): snapshot(p) for p in (SCENES, ROOT / "docs" / "bench")}
    work = Path(tempfile.mkdtemp(prefix="mcocl-hostile-"))
    t0 = time.monotonic()
    make_base(work / "_base")
    results: list[tuple[Case, Outcome, list[str]]] = []
    # the timing-sensitive classes run alone, after the rest, so a busy neighbour does not blur --time
    solo = [c for c in cases if c.signals or c.time is not None]
    pooled = [c for c in cases if c not in solo]
    with concurrent.futures.ThreadPoolExecutor(max(1, args.jobs)) as pool:
        for fut in concurrent.futures.as_completed([pool.submit(run_case, c, work / "_base", work) for c in pooled]):
            results.append(fut.result())
            _progress(results[-1], args.verbose)
    for c in solo:
        results.append(run_case(c, work / "_base", work))
        _progress(results[-1], args.verbose)
    for folder, snap in guarded.items():
        if snapshot(Path(folder)) != snap:
            results.append((Case(f"repo-{Path(folder).name}", "escape"), Outcome(0, "", "", 0.0, work),
                            [f"escape: the repository's {folder} changed"]))
    total = time.monotonic() - t0
    _table(results, total)
    if not args.keep:
        for p in work.rglob("*"):
            if p.is_dir() and not p.is_symlink():
                p.chmod(0o755)
        shutil.rmtree(work, ignore_errors=True)
    else:
        print(f"kept {work}")
    return 1 if any(f for _, _, f in results) else 0


def _progress(res: tuple[Case, Outcome, list[str]], verbose: bool) -> None:
    case, o, fails = res
    mark = "FAIL" if fails else "ok  "
    print(f"{mark} {case.name:45} rc={o.rc!s:4} {o.wall:5.1f}s {'; '.join(fails)[:150]}", flush=True)
    if verbose:
        print(textwrap.indent(o.err.strip()[-800:], "      | "), flush=True)


def _table(results: list[tuple[Case, Outcome, list[str]]], total: float) -> None:
    classes = sorted({c.cls for c, _, _ in results})
    print()
    print(f"{'class':12}{'cases':>6}{'pass':>6}" + "".join(f"{k:>10}" for k in FAILURES))
    sums = dict.fromkeys(FAILURES, 0)
    for cls in classes:
        rows = [(c, f) for c, _, f in results if c.cls == cls]
        counts = {k: sum(1 for _, f in rows if any(x.startswith(k) for x in f)) for k in FAILURES}
        for k in FAILURES:
            sums[k] += counts[k]
        print(f"{cls:12}{len(rows):>6}{sum(1 for _, f in rows if not f):>6}"
              + "".join(f"{counts[k]:>10}" for k in FAILURES))
    print(f"{'all':12}{len(results):>6}{sum(1 for _, _, f in results if not f):>6}"
          + "".join(f"{sums[k]:>10}" for k in FAILURES))
    print(f"\n{len(results)} cases in {total:.0f} s")
    failing = [(c, f) for c, _, f in results if f]
    if failing:
        print("\nfailing cases:")
        for c, f in sorted(failing, key=lambda x: (x[0].cls, x[0].name)):
            print(f"  {c.name}: {'; '.join(f)[:300]}")


if __name__ == "__main__":
    sys.exit(main())
