"""lane_div (kernels/lane_ops.cl): x / d by a multiply-high with a magic number, exactly the integer quotient.

The path tracer finds a fresh path's sample and pixel with it (render/integrator.cl), so an off-by-one
would move samples between pixels: every quotient is compared with NumPy's, for divisors from 1 to
2^32 - 1 (powers of two and their neighbours, the film sizes of the shipped scenes, random ones) and
numerators at the multiples of d and their neighbours, 0, 2^32 - 1 and random ones, in the scalar and
the 16-lane build.
"""

from __future__ import annotations

import numpy as np
import pyopencl as cl
import pytest

from mcocl import runtime

DIVISORS = sorted({1, 2, 3, 5, 6, 7, 255, 256, 257, 640, 49152, 98304, 65535, 65536, 65537, 2**31 - 1, 2**31,
                   2**31 + 1, 2**32 - 2, 2**32 - 1,
                   *(int(d) for d in np.random.default_rng(5).integers(1, 2**32, 40, dtype=np.uint64))})


def _numerators(d: int, rng: np.random.Generator) -> np.ndarray:
    q = (2**32 - 1) // d
    mult = np.unique(np.concatenate([rng.integers(0, q + 1, 200, dtype=np.uint64), [0, 1, q]])) * d
    near = np.concatenate([mult, mult + 1, mult + d - 1, mult - 1, [0, 1, 2**32 - 1, 2**32 - 2],
                           rng.integers(0, 2**32, 1000, dtype=np.uint64)])
    near = near[(near >= 0) & (near < 2**32)]
    return near.astype(np.uint32)


@pytest.mark.parametrize("lanes", [1, 16])
def test_lane_div_is_the_integer_quotient(lanes: int) -> None:
    ctx = runtime.device_context()
    prg = runtime.build(ctx, runtime.compose(["lane_div_test.cl"]), [f"-DLANES={lanes}"], what="lane_div test kernel")
    rng = np.random.default_rng(11)
    for d in DIVISORS:
        x = _numerators(d, rng)
        x = np.concatenate([x, np.zeros((-len(x)) % lanes, np.uint32)])
        out = np.empty_like(x)
        xb = cl.Buffer(ctx.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=x)
        ob = cl.Buffer(ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
        g, lsz = ctx.work_size(len(x) // lanes)
        runtime.kernel(prg, "divide")(ctx.queue, g, lsz, np.uint32(d), np.uint32(len(x)), xb, ob)
        cl.enqueue_copy(ctx.queue, out, ob)
        want = x // np.uint32(d)
        bad = np.flatnonzero(out != want)
        assert len(bad) == 0, f"d={d}: x={x[bad[:5]]} gave {out[bad[:5]]}, want {want[bad[:5]]}"
