"""The default lane width on CPU devices: the driver's preferred width, or the host's SIMD width."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import pyopencl as cl
import pytest

from mcocl import runtime
from mcocl.host_simd import cpuinfo_value, host_simd_width, simd_width_from_flags


@pytest.mark.parametrize(("flags", "width"), [
    ("fpu sse sse2 avx avx2 avx512f avx512vl", 16),
    ("fpu sse sse2 avx avx2 fma", 8),
    ("fpu sse sse2 avx", 8),
    ("fpu sse sse2", 4),
    ("fp asimd evtstrm aes", 4),
    ("fpu", 1),
])
def test_width_from_flags(flags: str, width: int) -> None:
    assert simd_width_from_flags(set(flags.split())) == width


def test_width_from_a_cpuinfo_file(tmp_path: Path) -> None:
    info = tmp_path / "cpuinfo"
    info.write_text("processor\t: 0\nmodel name\t: Some CPU\nflags\t\t: fpu sse2 avx2\n\nprocessor\t: 1\n")
    assert host_simd_width(str(info)) == 8
    assert cpuinfo_value(("model name",), str(info)) == "Some CPU"
    assert host_simd_width(str(tmp_path / "missing")) == 1


def _cpu(preferred: int, native: int) -> SimpleNamespace:
    return SimpleNamespace(type=cl.device_type.CPU, preferred_vector_width_float=preferred,
                           native_vector_width_float=native)


def test_a_cpu_reporting_width_one_gets_the_host_width(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("MCOCL_LANES", raising=False)
    monkeypatch.setattr(runtime, "host_simd_width", lambda: 16)
    assert runtime.default_lanes(_cpu(1, 1)) == 16
    assert runtime.default_lanes(_cpu(8, 8)) == 8  # a width the driver reports is kept
    monkeypatch.setattr(runtime, "host_simd_width", lambda: 1)
    assert runtime.default_lanes(_cpu(1, 1)) == 1
    monkeypatch.setenv("MCOCL_LANES", "2")
    assert runtime.default_lanes(_cpu(1, 1)) == 2
