"""Refuse a ``row_integral`` that is not the integral of |K(x, .)|.

With a user transition sampler, the subcritical and nee walks take the
survival probability and the weight of a move from the user's
``A(x) = integral of |K(x, y)| dy`` (``kernels/walks/transition.cl``); a wrong
A gives a wrong answer with nothing to show it (issue 10: 10.0 where the
answer is 2).  Before any walk, A is compared on ``PROBES`` fixed points x
with a midpoint quadrature of |K(x, .)| on the device
(``kernels/walks/row_integral_probe.cl``): ``n`` points per axis and, for the
quadrature's error bar, ``n / 2``.  A probe fails when

    |A(x) - Q_n(x)| > REL_TOLERANCE * Q_n(x) + ERROR_FACTOR * |Q_n(x) - Q_n/2(x)| + ABS_FLOOR * max_x Q_n

i.e. when A is off by more than 1e-3 relative plus a generous multiple of the
quadrature's own uncertainty (a midpoint rule's error shrinks at least as the
grid is refined, so ``|Q_n - Q_n/2|`` is an upper estimate of ``|Q_n - A|``
for a smooth K, and ERROR_FACTOR covers integrable singularities, whose
midpoint error falls only as a power below 2).  A probe where K or the
quadrature is not finite is skipped; A itself must be finite and >= 0
everywhere.  With more than ``MAX_DIM`` dimensions the grid would be too
coarse to judge anything, and the check is skipped.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyopencl as cl

from .. import runtime
from ..errors import InputError
from ..usercode import UserFunction
from .codegen import kernel_user

PROBES = 16  # points x at which A is checked
GRID_POINTS = 4096  # about n^dim quadrature points per probe
MAX_DIM = 6  # n >= 4 per axis (the halved grid keeps 2)
REL_TOLERANCE = 1e-3
ERROR_FACTOR = 8.0
ABS_FLOOR = 1e-6

_checked: dict[tuple[int, str, str, int], None] = {}  # (device, K, A, dim) that passed, per process


def _points_per_axis(dim: int) -> int:
    """The even n with n^dim closest below GRID_POINTS (at least 4)."""
    n = int(round(GRID_POINTS ** (1.0 / dim)))
    while n**dim > GRID_POINTS and n > 4:
        n -= 1
    return max(n - n % 2, 4)


def probe_points(dim: int) -> np.ndarray:
    """The fixed probe points ``(PROBES, dim)`` inside (0, 1)^dim."""
    return np.random.default_rng(20261201).uniform(0.03, 0.97, size=(PROBES, dim)).astype(np.float32)


def check_row_integral(kernel: str, row_integral: str, dim: int, device: Any = None) -> None:
    """Compare the user's A(x) with a quadrature of |K(x, .)| (module docstring).

    Raises:
        InputError: A is negative or not finite at a probe, or differs from the
            quadrature by more than the tolerance.
        KernelBuildError: K or A does not compile.
    """
    if dim > MAX_DIM:
        return
    ctx = runtime.device_context(device)
    key = (ctx.device.int_ptr, kernel, row_integral, dim)
    if key in _checked:
        return
    users = (kernel_user(kernel, dim), UserFunction("row_integral", row_integral, "walk_A", (("x", dim),)))
    src = runtime.compose([], "", users, vector_users=False, tail=["walks/row_integral_probe.cl"])
    prg = runtime.build(ctx, src, ["-DLANES=1", f"-DDIM={dim}"], users, what="integral equation")
    xs = probe_points(dim)
    n = _points_per_axis(dim)
    out = np.empty((PROBES, 3), np.float32)
    mf = cl.mem_flags
    bx = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(xs))
    bo = cl.Buffer(ctx.context, mf.WRITE_ONLY, out.nbytes)
    runtime.kernel(prg, "row_integral_probe")(ctx.queue, (PROBES,), None, np.uint32(PROBES), np.uint32(n), bx, bo)
    cl.enqueue_copy(ctx.queue, out, bo)
    _judge(xs, out.astype(np.float64), n, dim)
    _checked[key] = None


def _where(x: np.ndarray) -> str:
    return "(" + ", ".join(f"{v:.4g}" for v in x) + ")"


def _judge(xs: np.ndarray, out: np.ndarray, n: int, dim: int) -> None:
    """Raise on the first probe whose A fails (module docstring)."""
    a, fine, coarse = out[:, 0], out[:, 1], out[:, 2]
    bad = np.flatnonzero(~np.isfinite(a) | (a < 0))
    if len(bad):
        i = int(bad[0])
        raise InputError(f"row_integral: A(x) = {a[i]:g} at x = {_where(xs[i])}; the integral of |K(x, y)| dy "
                         "must be finite and >= 0")
    usable = np.isfinite(fine) & np.isfinite(coarse)
    if not usable.any():
        return
    scale = float(np.max(fine[usable]))
    tol = REL_TOLERANCE * fine + ERROR_FACTOR * np.abs(fine - coarse) + ABS_FLOOR * scale
    off = usable & ~(np.abs(a - fine) <= tol)
    if off.any():
        i = int(np.flatnonzero(off)[0])
        raise InputError(
            f"row_integral: A(x) = {a[i]:.6g} at x = {_where(xs[i])}, but the integral of |K(x, y)| dy is "
            f"{fine[i]:.6g} (midpoint rule, {n} points per axis, error about {abs(fine[i] - coarse[i]):.2g}); "
            f"A is wrong at {int(off.sum())} of {int(usable.sum())} probe points. The walks weigh every move by A: "
            "give the integral of |K| over y for every x")
