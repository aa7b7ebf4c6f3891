"""The power table's light choice (light_find, kernels/render/lights.cl) is the largest k with cdf[k] <= u.

light_find counts its first halvings with comparisons against fixed table entries and gathers only the
rest; the result must be the one a plain search gives, bit for bit, or the light chosen for a sample (and
so the image) would change: compared with NumPy's searchsorted on CDFs made as mcocl/render/emitter_choice.py
makes them (cumulative powers, zero-power lights and ties included) for 1 to 1500 lights (powers of two,
their neighbours and others), at u on the 2^-23 grid, at every table entry and just below it, in the
scalar and the 16-lane build.
"""

from __future__ import annotations

import numpy as np
import pyopencl as cl
import pytest

from mcocl import runtime
from mcocl.render.emitter_choice import light_choice

COUNTS = [1, 2, 3, 4, 5, 31, 32, 33, 63, 64, 65, 100, 511, 512, 513, 1024, 1500]


def _find(prg, ctx, cdf: np.ndarray, n: int, u: np.ndarray, lanes: int) -> np.ndarray:
    top = 1 << (n.bit_length() - 1)
    pad = (-len(u)) % lanes
    u = np.concatenate([u, np.full(pad, 0.5, np.float32)]).astype(np.float32)
    out = np.empty(len(u), np.uint32)
    mf = cl.mem_flags
    cb = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=cdf)
    ub = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=u)
    ob = cl.Buffer(ctx.context, mf.WRITE_ONLY, out.nbytes)
    g, lsz = ctx.work_size(len(u) // lanes)
    runtime.kernel(prg, "find_lights")(ctx.queue, g, lsz, np.uint32(n), np.uint32(top), cb, np.uint32(len(u)), ub, ob)
    cl.enqueue_copy(ctx.queue, out, ob)
    return out[:len(u) - pad]


@pytest.mark.parametrize("lanes", [1, 16])
def test_light_find_is_the_last_entry_at_most_u(lanes: int) -> None:
    ctx = runtime.device_context()
    prg = runtime.build(ctx, runtime.compose(["render/light_find_test.cl"]), [f"-DLANES={lanes}"],
                        what="light_find test kernel")
    rng = np.random.default_rng(17)
    for n in COUNTS:
        power = rng.random(n) ** 4 * (rng.random(n) > 0.2)
        power[rng.integers(0, n)] = 1.0
        cdf, _ = light_choice(power)
        grid = (rng.integers(0, 2**23, 3000) + 0.5) / 2**23
        u = np.concatenate([grid, cdf[:n], np.nextafter(cdf[:n], np.float32(0))]).astype(np.float32)
        got = _find(prg, ctx, cdf, n, u, lanes)
        want = np.minimum(np.searchsorted(cdf, u, side="right") - 1, n - 1)
        bad = np.flatnonzero(got != want)
        assert len(bad) == 0, f"{n} lights: u={u[bad[:5]]} gave {got[bad[:5]]}, want {want[bad[:5]]}"
