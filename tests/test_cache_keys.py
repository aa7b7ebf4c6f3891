"""Caches are keyed by everything they depend on: the full flattened source and every build option.

An edit to a file the render kernel only includes (the RNG, the MIS weights)
must make the bench's cached reference image stale, and the program cache
must not hand out a program built with other options.
"""

from __future__ import annotations

import pytest

from mcocl import runtime
from mcocl.bench import render_suite
from mcocl.bench.suite import BenchOptions


def _edited(rel: str):
    """A ``_read_kernel`` that appends a comment to the kernel file ``rel``."""
    real = runtime._read_kernel

    def read(name: str) -> str:
        text = real(name)
        return text + "\n/* edited */\n" if name == rel else text

    return read


@pytest.mark.parametrize("rel", ["rng/philox.cl", "sampling/mis.cl", "lanes.cl", "render/bsdf_diffuse.cl"])
def test_reference_key_follows_every_included_file(rel: str, monkeypatch) -> None:
    before = render_suite._kernel_digest(BenchOptions())
    assert f'#line 1 "{rel}"' in runtime.compose([render_suite.KERNEL_FILE]), "the file is not an include any more"
    monkeypatch.setattr(runtime, "_read_kernel", _edited(rel))
    assert render_suite._kernel_digest(BenchOptions()) != before


def test_reference_key_follows_the_build_options() -> None:
    assert render_suite._kernel_digest(BenchOptions(lanes=1)) != render_suite._kernel_digest(BenchOptions(lanes=8))
    assert render_suite._kernel_digest(BenchOptions(lanes=8)) == render_suite._kernel_digest(BenchOptions(lanes=8))


def test_build_digest_covers_source_and_options() -> None:
    src = runtime.compose(["rng/philox.cl"])
    d = runtime.build_digest(src, ["-DLANES=1"])
    assert runtime.build_digest(src, ["-DLANES=8"]) != d
    assert runtime.build_digest(src + " ", ["-DLANES=1"]) != d
    # option boundaries count: ("-DA", "B") is not ("-DAB",)
    assert runtime.build_digest(src, ["-DA", "B"]) != runtime.build_digest(src, ["-DAB"])


def test_program_cache_is_keyed_by_options() -> None:
    ctx = runtime.device_context()
    src = runtime.compose(["rng/philox.cl"]) + "kernel void k(global uint *o) { o[0] = LANES; }\n"
    a = runtime.build(ctx, src, ["-DLANES=1"], what="cache test")
    assert runtime.build(ctx, src, ["-DLANES=1"], what="cache test") is a
    assert runtime.build(ctx, src, ["-DLANES=8"], what="cache test") is not a
