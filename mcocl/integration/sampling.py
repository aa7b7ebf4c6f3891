"""Draw points from a proposal on the device, exactly as the estimators do."""

from __future__ import annotations

from typing import Any

import numpy as np
import pyopencl as cl

from .. import runtime
from ..errors import InputError
from ..usercode import UserFunction
from .codegen import generate
from .proposals import Proposal
from .samplers import sampler_spec


def sample_proposal(proposal: Any, dim: int, n: int, seed: int = 0, device: Any = None,
                    lanes: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Warp ``n`` engine uniforms through ``proposal``.

    Returns:
        ``(x, pdf_warp, pdf_eval)``: points ``(n, dim)``, the density the warp
        reported for each, and the density re-evaluated at the point (what a
        combined estimator uses).  The two agree up to float rounding; the
        points follow the proposal's density (tested by chi-square).
    """
    if n < 1:
        raise InputError(f"n must be >= 1, got {n}")
    prop = Proposal.parse(proposal, dim)
    dummy = UserFunction("integrand", "1.0f", "integrand", (("x", dim),))
    code = generate(dummy, dim, [prop], [1], "balance", 2.0, None, None)
    ctx = runtime.device_context(device)
    up = runtime.build_user_program(ctx, code.includes, code.generated, code.users,
                                    tail=["integrate/proposal_samples.cl"], options=[f"-DDIM={dim}"],
                                    what="proposal", lanes=lanes)
    mf = cl.mem_flags
    tables = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=code.tables)
    xs = np.empty((n, dim), np.float32)
    pw = np.empty(n, np.float32)
    pe = np.empty(n, np.float32)
    bx, bw, be = (cl.Buffer(ctx.context, mf.WRITE_ONLY, a.nbytes) for a in (xs, pw, pe))
    items = -(-n // up.lanes)
    gsize, lsize = ctx.work_size(items)
    runtime.kernel(up.program, "proposal_samples")(ctx.queue, gsize, lsize, np.uint64(n), np.uint64(seed), tables, bx, bw, be)
    for host, buf in ((xs, bx), (pw, bw), (pe, be)):
        cl.enqueue_copy(ctx.queue, host, buf)
    return xs, pw, pe


def design_points(sampler: str, dim: int, size: int, design: int = 0, seed: int = 0, device: Any = None) -> np.ndarray:
    """The points of one design, placed exactly as the integration kernel places them.

    Args:
        sampler: ``nrooks`` (``size`` = points n) or ``stratified`` (``size`` =
            strata per axis m; the design has 2 m^dim points, two per stratum,
            stratum h's pair at rows 2h and 2h + 1).
        design: which design (designs differ in permutations and jitter).

    Returns:
        ``(points, dim)`` float32 array.
    """
    name, points, items, counts = sampler_spec(sampler).design_point_launch(size, dim)
    ctx = runtime.device_context(device)
    src = runtime.compose(["sampling/design_points.cl"])
    prg = runtime.build(ctx, src, ["-DLANES=1", f"-DDIM={dim}"], what="design points")
    out = np.empty((points, dim), np.float32)
    buf = cl.Buffer(ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    runtime.kernel(prg, name)(ctx.queue, (items,), None, *(np.uint32(c) for c in counts), np.uint64(design),
                              np.uint64(seed), buf)
    cl.enqueue_copy(ctx.queue, out, buf)
    return out
