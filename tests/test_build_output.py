"""A cold first run prints no compiler output; --verbose and MCOCL_BUILD_LOG=1 show the build logs.

Each run is a fresh process with empty PoCL and pyopencl caches, so every
kernel is compiled from source as on a fresh install.  The integrand
``x[0] < 0.5 ? 1 : 0`` does not compile on vector lanes (a comparison of a
vector is not a float), so its run also goes through the lane build that fails
and the scalar fallback: PoCL's clang writes ``1 error generated.`` to the
process's stderr there unless the runtime captures it.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from vector_lanes import needs_vector_lanes

from mcocl.cli import build_parser

ROOT = Path(__file__).resolve().parent.parent
NOISE = re.compile(r"warning|generated", re.IGNORECASE)
FALLBACK = ["integrate", "x[0] < 0.5 ? 1 : 0", "--dim", "1", "--samples", "1e5", "--seed", "3"]


def _run_cold(args: list[str], tmp_path: Path, extra_env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    caches = tmp_path / f"caches-{len(list(tmp_path.iterdir()))}"
    env = dict(os.environ)
    env.pop("MCOCL_BUILD_LOG", None)
    env.update({"PYTHONPATH": str(ROOT), "POCL_CACHE_DIR": str(caches / "pocl"),
                "XDG_CACHE_HOME": str(caches / "xdg"), **(extra_env or {})})
    return subprocess.run([sys.executable, "-m", "mcocl", *args], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=300)


def _noise(stderr: str) -> list[str]:
    return [line for line in re.split(r"[\r\n]+", stderr) if NOISE.search(line)]


@pytest.mark.parametrize("args", [FALLBACK, ["render", str(ROOT / "scenes" / "cornell.json"), "--spp", "1",
                                             "--out", "x.exr"]], ids=["integrate-fallback", "render"])
def test_a_cold_run_prints_no_compiler_output(args: list[str], tmp_path: Path) -> None:
    r = _run_cold(args, tmp_path)
    assert r.returncode == 0, r.stderr
    assert _noise(r.stderr) == [], r.stderr


@needs_vector_lanes
@pytest.mark.parametrize("how", ["flag", "env"])
def test_build_logs_are_shown_on_request(how: str, tmp_path: Path) -> None:
    args = [*FALLBACK, "--verbose"] if how == "flag" else FALLBACK
    r = _run_cold(args, tmp_path, {"MCOCL_BUILD_LOG": "1"} if how == "env" else None)
    assert r.returncode == 0, r.stderr
    assert "build of the integrand" in r.stderr and "failed" in r.stderr, r.stderr
    # the compiler's complaint about the user's line is in the log shown
    assert "integrand:1:" in r.stderr, r.stderr


@pytest.mark.parametrize("argv", [["--verbose", *FALLBACK], [*FALLBACK, "--verbose"], FALLBACK])
def test_verbose_flag_before_or_after_the_command(argv: list[str]) -> None:
    args = build_parser().parse_args(argv)
    assert args.verbose is ("--verbose" in argv)
    assert args.command == "integrate"
