"""Device selection, the build cache and the user-snippet error messages of the runtime."""

from __future__ import annotations

import pytest

from mcocl import runtime
from mcocl.errors import DeviceError


def test_select_by_index_name_and_pyopencl_ctx(monkeypatch) -> None:
    devs = runtime.list_devices()
    assert devs and devs[0].index == 0
    first = runtime.select_device(0)
    assert runtime.select_device("0") == first
    assert runtime.select_device(devs[0].name[:6].lower()) == first
    monkeypatch.setenv("PYOPENCL_CTX", "0:0")
    assert runtime.select_device() == first
    monkeypatch.setenv("PYOPENCL_CTX", "no-such-platform")
    with pytest.raises(DeviceError, match="PYOPENCL_CTX"):
        runtime.select_device()


def test_unknown_device_lists_what_exists() -> None:
    with pytest.raises(DeviceError, match=r"(?s)no device matches .quantum.*\[0\]"):
        runtime.select_device("quantum")
    with pytest.raises(DeviceError):
        runtime.select_device(999)


def test_build_cache_returns_the_same_program() -> None:
    ctx = runtime.device_context()
    src = runtime.compose(["rng/uniform.cl"], "kernel void k(global float *o) { o[0] = u01(7u); }")
    a = runtime.build(ctx, src, ["-DLANES=1"])
    b = runtime.build(ctx, src, ["-DLANES=1"])
    assert a is b
    assert runtime.build(ctx, src, ["-DLANES=1", "-DUNUSED=1"]) is not a


def test_include_markers_point_at_the_engine_file() -> None:
    src = runtime.kernel_source("rng/uniform.cl")
    assert '#line 1 "rng/philox.cl"' in src and '#line 1 "rng/uniform.cl"' in src


def test_default_device_skips_devices_that_cannot_build(monkeypatch) -> None:
    """A listed device whose builds all fail (the PoCL wheel on a CPU its LLVM
    does not know) is passed over by the default choice, and a machine with no
    usable device gets an error that says why and what to install."""
    monkeypatch.delenv("PYOPENCL_CTX", raising=False)
    devs = [d for _, _, d in runtime._all_devices()]
    assert runtime.select_device() == next(d for d in devs if runtime.device_problem(d) is None)
    monkeypatch.setattr(runtime, "_problems", {d.int_ptr: "error: unknown target CPU 'generic'" for d in devs})
    with pytest.raises(DeviceError, match=r"(?s)no OpenCL device can build.*unknown target CPU.*pocl-opencl-icd"):
        runtime.select_device()
    if len(devs) > 1:
        monkeypatch.setitem(runtime._problems, devs[1].int_ptr, None)
        assert runtime.select_device() == devs[1]
    assert "unusable" in runtime.list_devices()[0].describe()
