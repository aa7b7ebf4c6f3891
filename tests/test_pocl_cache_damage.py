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


def _integration_entry(cache: Path, before: set[Path]) -> Path:
    (entry,) = {p.parent for p in cache.glob("*/*/integrate_blocks")} - before
    return entry


@pytest.fixture(scope="module")
def pristine(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str, str, str]:
    """A PoCL cache holding the integration kernels of x^2 and of x, each run twice (so that
    mcocl's record lists their kernel libraries too); with the x^2 estimate and the two entries."""
    cache = tmp_path_factory.mktemp("pristine") / "kcache"
    square = _estimate(_integrate(cache, "x[0]*x[0]"))
    a = _integration_entry(cache, set())
    assert _estimate(_integrate(cache, "x[0]*x[0]")) == square
    _integrate(cache, "x[0]")
    b = _integration_entry(cache, {a})
    _integrate(cache, "x[0]")
    return cache, square, a.relative_to(cache).as_posix(), b.relative_to(cache).as_posix()


def _check_damaged_run(cache: Path, integrand: str, expected: str) -> None:
    run = _integrate(cache, integrand)
    assert "kernel cache" in run.stderr and "corrupt" in run.stderr, run.stderr
    assert "Traceback" not in run.stderr, run.stderr
    if run.returncode != 0:
        assert run.returncode == 2, run.stderr
    else:
        assert _estimate(run) == expected, "a damaged cache entry gave a different result"


@pytest.fixture()
def cache(pristine: tuple[Path, str, str, str], tmp_path: Path) -> tuple[Path, str, Path, Path]:
    """A copy of the pristine cache to damage: (folder, x^2 estimate, entry of x^2, entry of x)."""
    source, square, a, b = pristine
    copy = tmp_path / "kcache"
    shutil.copytree(source, copy)
    return copy, square, copy / a, copy / b


def test_swapped_entry_is_detected(cache: tuple[Path, str, Path, Path]) -> None:
    """The integration kernel of x^2 replaced by that of x: same x^2 estimate (rebuilt) or exit 2."""
    folder, square, a, b = cache
    for item in a.iterdir():
        if item.name != "last_accessed":
            shutil.rmtree(item) if item.is_dir() else item.unlink()
    for item in b.iterdir():
        if item.name != "last_accessed":
            (shutil.copytree if item.is_dir() else shutil.copy2)(item, a / item.name)
    _check_damaged_run(folder, "x[0]*x[0]", square)


def test_swapped_kernel_library_is_detected(cache: tuple[Path, str, Path, Path]) -> None:
    """Only the compiled kernel (.so) swapped, the bitcode intact: still detected."""
    folder, square, a, b = cache
    swapped = 0
    for so in b.glob("integrate_blocks/*/*.so"):
        if (a / so.relative_to(b)).exists():
            shutil.copy2(so, a / so.relative_to(b))
            swapped += 1
    assert swapped
    _check_damaged_run(folder, "x[0]*x[0]", square)


@pytest.mark.parametrize("target", ["program.bc", "integrate_blocks/*/*.so"])
def test_corrupt_entry_is_bypassed(cache: tuple[Path, str, Path, Path], target: str) -> None:
    """Garbage in the bitcode or the kernel library makes PoCL abort or crash: rerun with a fresh cache, told."""
    folder, square, a, _ = cache
    # Forget mcocl's record, so that the damage reaches PoCL (with the record the build check
    # would refuse the damaged library before PoCL loads it).
    shutil.rmtree(folder / "mcocl-records")
    for f in a.glob(target):
        data = bytearray(f.read_bytes())
        data[len(data) // 3: len(data) // 3 + 256] = b"\xff" * 256
        f.write_bytes(bytes(data[: len(data) // 2]))
    _check_damaged_run(folder, "x[0]*x[0]", square)


def _bitcode(cache: Path, body: str) -> bytes:
    """The program.bc PoCL writes for a small kernel, built in a fresh process with its own cache."""
    code = ("import pyopencl as cl\nfrom mcocl import runtime\nctx = runtime.device_context(None)\n"
            f"cl.Program(ctx.context, 'kernel void rebuild_check(global float *a) {{ float x = a[0]; a[0] = {body}; }}').build()\n")
    env = dict(os.environ, POCL_CACHE_DIR=str(cache), PYTHONPATH=str(ROOT))
    subprocess.run([sys.executable, "-c", code], env=env, check=True, timeout=300)
    (bc,) = (p for p in cache.glob("*/*/program.bc") if b"rebuild_check" in p.read_bytes())  # not the probe's
    return bc.read_bytes()


def test_a_concurrent_rebuild_is_not_taken_for_a_swap(tmp_path: Path) -> None:
    """PoCL's bitcode names its temporary source file, so two builds of one program differ in a few
    bytes (two processes building at the same instant leave either's); another program differs more."""
    from mcocl.pocl_cache_record import bitcode_fingerprint, rebuilt_alike

    one = bitcode_fingerprint(_bitcode(tmp_path / "c1", "sin(x) * x"))
    two = bitcode_fingerprint(_bitcode(tmp_path / "c2", "sin(x) * x"))
    other = bitcode_fingerprint(_bitcode(tmp_path / "c3", "cos(x) + x"))
    assert rebuilt_alike(one, two)
    assert not rebuilt_alike(one, other)
