"""Host↔kernel contracts (mcocl/layouts.py): the generated header and the device's view of every struct.

The records are declared once in Python; ``kernels/layouts.cl`` is generated
from them and committed.  These tests fail when the committed header is not
what the generator writes, when the OpenCL compiler lays out a struct
differently from the NumPy dtype (``sizeof`` and ``offsetof`` of every field,
measured on the device), when a code differs between the two sides, or when a
by-value ``render_params`` does not arrive in the kernel byte for byte.
"""

from __future__ import annotations

import numpy as np
import pyopencl as cl
import pytest

from mcocl import layouts, runtime


def test_committed_header_is_the_generated_one():
    assert layouts.header_file().read_text() == layouts.c_header(), "run `python -m mcocl.layouts`"


def _layout_probe_source(records=layouts.RECORDS) -> tuple[str, list[tuple[str, int]]]:
    """A kernel writing sizeof/offsetof of every record field and every enum code; the expected values."""
    lines, expected = [], []
    for rec in records:
        dt = rec.dtype()
        lines.append(f"out[{len(expected)}] = (uint)sizeof({rec.name});")
        expected.append((f"sizeof({rec.name})", dt.itemsize))
        for name in dt.names:
            lines.append(f"out[{len(expected)}] = (uint)__builtin_offsetof({rec.name}, {name});")
            expected.append((f"offsetof({rec.name}, {name})", dt.fields[name][1]))
    for enum, prefix in layouts.ENUM_PREFIXES.items():
        for member in enum:
            lines.append(f"out[{len(expected)}] = (uint)({prefix}{member.name});")
            expected.append((f"{prefix}{member.name}", int(member)))
    lines.append(f"out[{len(expected)}] = (uint)FILM_STATS;")
    expected.append(("FILM_STATS", len(layouts.FilmStat)))
    body = "\n    ".join(lines)
    src = f"kernel void layout_probe(global uint *out) {{\n    if (get_global_id(0) != 0) return;\n    {body}\n}}\n"
    return src, expected


def _probe(records=layouts.RECORDS, extra_c: str = "") -> list[str]:
    """Mismatches between the device's sizeof/offsetof/codes and NumPy's (empty when they agree)."""
    ctx = runtime.device_context()
    src, expected = _layout_probe_source(records)
    prg = runtime.build(ctx, runtime.compose(["layouts.cl"], generated=extra_c + src), ["-DLANES=1"],
                        what="layout probe")
    out = np.zeros(len(expected), np.uint32)
    buf = cl.Buffer(ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    runtime.kernel(prg, "layout_probe")(ctx.queue, (1,), None, buf)
    cl.enqueue_copy(ctx.queue, out, buf)
    return [f"{what}: device {int(got)}, numpy {want}" for (what, want), got in zip(expected, out) if got != want]


def test_device_sizes_offsets_and_codes_match_numpy():
    wrong = _probe()
    assert not wrong, "\n".join(wrong)


class _PackedRecord(layouts.Record):
    """A record whose NumPy side ignores C alignment (the mistake the probe is there to catch)."""

    def offsets(self) -> list[int]:
        return [0, 4]


def test_the_probe_reports_a_dtype_that_ignores_c_alignment():
    rec = _PackedRecord("packed_probe", (("a", "uint", 1), ("b", "ulong", 1)), "x")
    c_side = layouts.Record.c_text(rec) + "\n"
    wrong = _probe((rec,), c_side)
    assert any("offsetof(packed_probe, b): device 8, numpy 4" in w for w in wrong), wrong


@pytest.mark.parametrize("record", [layouts.RENDER_PARAMS, layouts.WALK_PARAMS, layouts.WALK_TABLE_GEOMETRY],
                         ids=lambda r: r.name)
def test_kernel_params_arrive_by_value_byte_for_byte(record):
    ctx = runtime.device_context()
    src = (f"kernel void echo(const {record.name} p, global {record.name} *out) "
           "{ if (get_global_id(0) == 0) *out = p; }\n")
    prg = runtime.build(ctx, runtime.compose(["layouts.cl"], generated=src), ["-DLANES=1"], what="params echo")
    dt = record.dtype()
    p = np.zeros((), dt)
    rng = np.random.default_rng(5)
    for name in dt.names:
        base = dt.fields[name][0]
        p[name] = rng.integers(1, 2**31, size=base.shape) if base.base.kind in "ui" else rng.random(base.shape)
    if "seed" in dt.names:
        p["first_block"], p["seed"] = 2**40 + 3, 2**63 + 12345
    if "max_depth" in dt.names:
        p["max_depth"] = -1
    out = np.zeros((), dt)
    buf = cl.Buffer(ctx.context, cl.mem_flags.WRITE_ONLY, dt.itemsize)
    runtime.kernel(prg, "echo")(ctx.queue, (1,), None, p, buf)
    cl.enqueue_copy(ctx.queue, out, buf)
    for name in dt.names:
        np.testing.assert_array_equal(out[name], p[name], err_msg=name)


def test_quad_positions_follow_the_offsets():
    quads = layouts.PRIM_RECORD.field_quads()
    assert quads["normal"] == (0, "x") and quads["area"] == (0, "w") and quads["pmf"] == (1, "z")
    assert layouts.LIGHT_RECORD.field_quads()["prim"] == (3, "w")
    assert layouts.MATERIAL_RECORD.field_quads()["rgb"] == (0, "y")
    assert "#define MATERIAL_RECORD_RGB_COMP2 w" in layouts.c_header()
    for rec in layouts.RECORDS:
        if rec.quads:
            assert rec.itemsize % 16 == 0


def test_a_field_straddling_two_float4_is_refused():
    bad = layouts.Record("bad", (("a", "float", 3), ("b", "float", 3), ("c", "float", 2)), "x", quads=True)
    with pytest.raises(ValueError, match="bad.b"):
        bad.check()


def test_c_alignment_rules():
    rec = layouts.Record("r", (("a", "uint", 1), ("b", "ulong", 1), ("c", "float", 1), ("d", "float4", 1)), "x")
    assert rec.offsets() == [0, 8, 16, 32] and rec.itemsize == 48
    assert layouts.RENDER_PARAMS.dtype().fields["env_radiance"][1] % 16 == 0


def test_film_columns_are_the_film_stats():
    from mcocl.render.film import STAT_NAMES, STATS

    assert STAT_NAMES == ("sum_r", "sum_g", "sum_b", "sumsq_r", "sumsq_g", "sumsq_b", "samples", "nonfinite")
    assert STATS == len(layouts.FilmStat) == 8
