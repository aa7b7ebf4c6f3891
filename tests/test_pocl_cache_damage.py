"""A damaged or swapped entry of PoCL's kernel cache never gives a silent wrong result.

Each test runs the command line (supervised, as a user would) against a
temporary ``POCL_CACHE_DIR``, damages the cache entry of the integration
kernel, and runs again: the run must give the same estimate as before, or
exit 2, and stderr must name PoCL's kernel cache (mcocl/pocl_cache_record.py,
mcocl/cli/supervise.py).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _integrate(cache: Path, integrand: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, POCL_CACHE_DIR=str(cache), PYTHONPATH=str(ROOT), MCOCL_SUPERVISE="1")
    env.pop("MCOCL_HEARTBEAT_FD", None)
    return subprocess.run(
        [sys.executable, "-m", "mcocl", "integrate", integrand, "--samples", "1e5", "--seed", "3", "--quiet"],
        env=env, capture_output=True, text=True, timeout=300,
    )


def _estimate(run: subprocess.CompletedProcess) -> str:
    assert run.returncode == 0, run.stderr
    return next(line.split()[1] for line in run.stdout.splitlines() if line.startswith("estimate"))


def _entry(cache: Path, integrand: str) -> Path:
    """The cache entry of the integration kernel built for ``integrand`` (run twice: kernels recorded)."""
    before = {p.parent for p in cache.glob("*/*/integrate_blocks")}
    _integrate(cache, integrand)
    (entry,) = {p.parent for p in cache.glob("*/*/integrate_blocks")} - before
    return entry


def _check_damaged_run(cache: Path, integrand: str, expected: str) -> None:
    run = _integrate(cache, integrand)
    assert "kernel cache" in run.stderr, run.stderr
    assert "Traceback" not in run.stderr, run.stderr
    if run.returncode != 0:
        assert run.returncode == 2, run.stderr
    else:
        assert _estimate(run) == expected, "a damaged cache entry gave a different result"


@pytest.fixture()
def cache(tmp_path: Path) -> Path:
    """A fresh PoCL kernel cache folder."""
    return tmp_path / "kcache"


def test_swapped_entry_is_detected(cache: Path) -> None:
    """The integration kernel of x^2 replaced by that of x: same x^2 estimate (rebuilt) or exit 2."""
    square = _estimate(_integrate(cache, "x[0]*x[0]"))
    a = next(p.parent for p in cache.glob("*/*/integrate_blocks"))
    assert _estimate(_integrate(cache, "x[0]*x[0]")) == square  # second run: kernel libraries recorded
    b = _entry(cache, "x[0]")
    _integrate(cache, "x[0]")
    for item in a.iterdir():
        if item.name != "last_accessed":
            shutil.rmtree(item) if item.is_dir() else item.unlink()
    for item in b.iterdir():
        if item.name != "last_accessed":
            (shutil.copytree if item.is_dir() else shutil.copy2)(item, a / item.name)
    _check_damaged_run(cache, "x[0]*x[0]", square)


def test_swapped_kernel_library_is_detected(cache: Path) -> None:
    """Only the compiled kernel (.so) swapped, the bitcode intact: still detected."""
    square = _estimate(_integrate(cache, "x[0]*x[0]"))
    a = next(p.parent for p in cache.glob("*/*/integrate_blocks"))
    _integrate(cache, "x[0]*x[0]")
    b = _entry(cache, "x[0]")
    _integrate(cache, "x[0]")
    for so in b.glob("integrate_blocks/*/*.so"):
        shutil.copy2(so, a / so.relative_to(b))
    _check_damaged_run(cache, "x[0]*x[0]", square)


@pytest.mark.parametrize("target", ["program.bc", "integrate_blocks/*/*.so"])
def test_corrupt_entry_is_bypassed(cache: Path, target: str) -> None:
    """Garbage in the bitcode or the kernel library makes PoCL abort: rerun with a fresh cache, told."""
    square = _estimate(_integrate(cache, "x[0]*x[0]"))
    entry = next(p.parent for p in cache.glob("*/*/integrate_blocks"))
    for f in entry.glob(target):
        data = bytearray(f.read_bytes())
        data[len(data) // 3: len(data) // 3 + 256] = b"\xff" * 256
        f.write_bytes(bytes(data[: len(data) // 2]))
    _check_damaged_run(cache, "x[0]*x[0]", square)
    assert "corrupt" in _integrate(cache, "x[0]*x[0]").stderr  # the damaged entry stays until deleted, and is named
