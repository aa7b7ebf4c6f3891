"""Refuse a user's analytic proposal that is not the density its inverse CDF samples.

An analytic factor (:class:`mcocl.integration.proposals.Analytic`) is two
OpenCL snippets the engine cannot read: a pdf ``p`` and an inverse CDF ``Q``.
The estimator divides by ``p`` at ``x = Q(u)``; when ``p`` is negative, not
normalised, or not the density of ``Q(u)`` for uniform ``u``, the estimate is
wrong with nothing to show it (issue 10: ``"pdf": "-1.0f"`` gave -0.5 for the
integral of x).  Before any sampling, both snippets run on the device on
``PROBES`` grid points and must pass:

1. ``p`` is finite and >= 0 at the midpoints ``t_i = (i + 1/2) / PROBES`` of
   [0, 1] (a combined estimator evaluates every proposal's ``p`` everywhere);
2. ``Q`` is finite and inside [0, 1] at the same midpoints, read as uniforms;
3. ``p`` is the density of ``Q(u)``: ``x = Q(u)`` has density ``p`` exactly
   when ``p(Q(u)) Q'(u) = 1`` (the change of variables of the inverse-CDF
   method).  With central differences on the probe grid the ratio
   ``r_i = p(Q(t_i)) (Q(t_{i+1}) - Q(t_{i-1})) / (2 / PROBES)`` must lie
   within ``RATIO_TOLERANCE`` of 1 at all but ``OUTLIER_SHARE`` of the
   points.  The outliers allow for what a finite difference cannot resolve:
   a jump of ``Q`` over a gap where ``p`` = 0, the curvature of ``Q`` near an
   integrable singularity of ``p`` at an end.  The check needs no quadrature of
   ``p``, so singular densities pass as easily as smooth ones;
4. ``p`` integrates to 1: the midpoint rule over the probes must be within
   ``NORM_TOLERANCE`` of 1, judged only when no probe cell carries more than
   ``NORM_TOLERANCE`` of the mass by itself (the midpoint rule is no
   quadrature near an integrable singularity; check 3 has covered that case
   where ``Q`` goes, and this check only adds mass that ``Q`` never reaches).

A failure is an :class:`InputError` that names the proposal and the probe.
"""

from __future__ import annotations

import numpy as np
import pyopencl as cl

from .. import runtime
from ..errors import InputError
from ..usercode import UserFunction
from .proposals import Analytic, Proposal

PROBES = 4096  # grid points of [0, 1]: a few thousand, one launch of each snippet
RATIO_TOLERANCE = 0.05  # |p(Q(u)) Q'(u) - 1| allowed at a probe (float differences of Q, curvature)
OUTLIER_SHARE = 0.05  # probes whose ratio may miss (jumps of Q, the ends of a singular density)
NORM_TOLERANCE = 0.05  # |integral of p - 1| allowed by the midpoint rule
RANGE_SLACK = 1e-6  # how far outside [0, 1] an inverse CDF may round

_checked: dict[tuple[int, str, str], None] = {}  # (device, pdf, inverse) that passed, per process


def check_user_densities(proposals: list[Proposal], includes: list[str], device: object = None) -> None:
    """Run the checks of the module docstring on every analytic factor of ``proposals``.

    Raises:
        InputError: a factor's pdf is negative or not finite, its inverse CDF
            leaves [0, 1], or the two do not describe the same density.
        KernelBuildError: a snippet does not compile.
    """
    ctx = None
    for t, prop in enumerate(proposals):
        where = "proposal" if len(proposals) == 1 else f"proposals[{t}]"
        for fi, f in enumerate(prop.factors):
            if not isinstance(f, Analytic):
                continue
            name = where if len(prop.factors) == 1 else f"{where}[{fi}]"
            ctx = ctx or runtime.device_context(device)
            key = (ctx.device.int_ptr, f.pdf, f.inverse)
            if key in _checked:
                continue
            pdf_at, inv_at, pdf_inv = _probe(ctx, f, name, includes)
            _judge(name, pdf_at, inv_at, pdf_inv)
            _checked[key] = None


def _probe(ctx: runtime.DeviceContext, f: Analytic, name: str,
           includes: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Both snippets on the probe midpoints (kernels/integrate/density_probe.cl)."""
    users = (UserFunction(f"{name}.pdf", f.pdf, "probe_pdf", (("x", 0),)),
             UserFunction(f"{name}.inverse", f.inverse, "probe_inv", (("u", 0),)))
    src = runtime.compose(includes, "", users, vector_users=False,
                          tail=["integrate/density_probe.cl"])
    prg = runtime.build(ctx, src, ["-DLANES=1"], users, f"{name} (analytic proposal)")
    t = ((np.arange(PROBES) + 0.5) / PROBES).astype(np.float32)
    mf = cl.mem_flags
    bt = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=t)
    outs = [np.empty(PROBES, np.float32) for _ in range(3)]
    bufs = [cl.Buffer(ctx.context, mf.WRITE_ONLY, o.nbytes) for o in outs]
    runtime.kernel(prg, "density_probe")(ctx.queue, (PROBES,), None, np.uint32(PROBES), bt, *bufs)
    for host, buf in zip(outs, bufs):
        cl.enqueue_copy(ctx.queue, host, buf)
    return outs[0].astype(np.float64), outs[1].astype(np.float64), outs[2].astype(np.float64)


def _at(i: int) -> str:
    return f"{(i + 0.5) / PROBES:.6g}"


def _judge(name: str, pdf_at: np.ndarray, inv_at: np.ndarray, pdf_inv: np.ndarray) -> None:
    """Checks 1-4 of the module docstring on the probe values; raise on the first failure."""
    head = f"{name}: the analytic proposal"
    bad = np.flatnonzero(~np.isfinite(pdf_at) | (pdf_at < 0))
    if len(bad):
        i = int(bad[0])
        raise InputError(f"{head}'s pdf is {pdf_at[i]:g} at x = {_at(i)} ({len(bad)} of {PROBES} probe points); "
                         "a density must be finite and >= 0 on [0, 1]")
    bad = np.flatnonzero(~np.isfinite(inv_at) | (inv_at < -RANGE_SLACK) | (inv_at > 1 + RANGE_SLACK))
    if len(bad):
        i = int(bad[0])
        raise InputError(f"{head}'s inverse CDF is {inv_at[i]:g} at u = {_at(i)} ({len(bad)} of {PROBES} probe "
                         "points); it must map (0, 1) into [0, 1]")
    with np.errstate(invalid="ignore", over="ignore"):
        ratio = pdf_inv[1:-1] * (inv_at[2:] - inv_at[:-2]) * (PROBES / 2.0)
    miss = ~(np.abs(ratio - 1.0) <= RATIO_TOLERANCE)
    if miss.mean() > OUTLIER_SHARE:
        i = int(np.flatnonzero(miss)[len(np.flatnonzero(miss)) // 2]) + 1
        raise InputError(
            f"{head}'s pdf is not the density of its inverse CDF: pdf(Q(u)) Q'(u) should be 1, but it is "
            f"{ratio[i - 1]:.4g} at u = {_at(i)} (Q(u) = {inv_at[i]:.6g}, pdf there {pdf_inv[i]:.6g}), off by more "
            f"than {RATIO_TOLERANCE:g} at {miss.sum()} of {PROBES - 2} probe points; check that the pdf is "
            "normalised and that the inverse is the inverse of its CDF")
    total = float(pdf_at.mean())
    if pdf_at.max() / PROBES <= NORM_TOLERANCE and abs(total - 1.0) > NORM_TOLERANCE:
        raise InputError(f"{head}'s pdf integrates to {total:.4g} over [0, 1] (midpoint rule on {PROBES} points), "
                         "not 1; a density must be normalised")
