"""Refuse a ``row_integral`` or ``source_integral`` that is not the integral it claims to be.

With a user transition sampler, the subcritical and nee walks take the
survival probability and the weight of a move from the user's
``A(x) = integral of |K(x, y)| dy`` (``kernels/walks/transition.cl``); with a
user source sampler, next-event estimation weighs every sample by the user's
``G = integral of |g|``.  A wrong A or G gives a wrong answer with nothing to
show it (issue 10: 10.0 where the answer is 2).  Before any walk, both are
compared with a midpoint quadrature on the device
(``kernels/walks/integral_probe.cl``): A at ``PROBES`` fixed points x against
the quadrature of |K(x, .)|, G against that of |g|, each on ``n`` points per
axis and, for the quadrature's error bar, ``n / 2``.  A value Q fails when

    |given - Q_n| > REL_TOLERANCE * Q_n + ERROR_FACTOR * |Q_n - Q_n/2| + ABS_FLOOR * scale

i.e. when it is off by more than 1e-3 relative plus a generous multiple of the
quadrature's own uncertainty (a midpoint rule's error shrinks at least as the
grid is refined, so ``|Q_n - Q_n/2|`` is an upper estimate of the error of
``Q_n`` for a smooth integrand, and ERROR_FACTOR covers integrable
singularities, whose midpoint error falls only as a power below 2).  A probe
where the integrand or the quadrature is not finite is skipped; A itself must
be finite and >= 0 everywhere.  With more than ``MAX_DIM`` dimensions the grid
would be too coarse to judge anything, and the check is skipped.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyopencl as cl

from .. import runtime
from ..errors import InputError
from ..usercode import UserFunction
from .codegen import kernel_user, source_user

PROBES = 16  # points x at which A is checked
GRID_POINTS = 4096  # about n^dim quadrature points per integral
MAX_DIM = 6  # n >= 4 per axis (the halved grid keeps 2)
REL_TOLERANCE = 1e-3
ERROR_FACTOR = 8.0
ABS_FLOOR = 1e-6

_checked: dict[tuple[Any, ...], None] = {}  # what passed, per process


def _points_per_axis(dim: int) -> int:
    """The even n with n^dim closest below GRID_POINTS (at least 4)."""
    n = int(round(GRID_POINTS ** (1.0 / dim)))
    while n**dim > GRID_POINTS and n > 4:
        n -= 1
    return max(n - n % 2, 4)


def probe_points(dim: int) -> np.ndarray:
    """The fixed probe points ``(PROBES, dim)`` inside (0, 1)^dim."""
    return np.random.default_rng(20261201).uniform(0.03, 0.97, size=(PROBES, dim)).astype(np.float32)


def check_given_integrals(kernel: str, source: str, dim: int, row_integral: str | None,
                          source_integral: float | None, device: Any = None) -> None:
    """Compare the user's A(x) and G with quadratures of |K(x, .)| and |g| (module docstring).

    Raises:
        InputError: A is negative or not finite at a probe, or A or G differs
            from its quadrature by more than the tolerance.
        KernelBuildError: K, g or A does not compile.
    """
    if dim > MAX_DIM or (row_integral is None and source_integral is None):
        return
    ctx = runtime.device_context(device)
    key = (ctx.device.int_ptr, kernel, source, dim, row_integral, source_integral)
    if key in _checked:
        return
    users = [kernel_user(kernel, dim), source_user(source, dim)]
    if row_integral is not None:
        users.append(UserFunction("row_integral", row_integral, "walk_A", (("x", dim),)))
    src = runtime.compose([], "", tuple(users), vector_users=False, tail=["walks/integral_probe.cl"])
    prg = runtime.build(ctx, src, ["-DLANES=1", f"-DDIM={dim}"], tuple(users), what="integral equation")
    n = _points_per_axis(dim)
    mf = cl.mem_flags
    if row_integral is not None:
        xs = probe_points(dim)
        out = np.empty((PROBES, 3), np.float32)
        bx = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(xs))
        bo = cl.Buffer(ctx.context, mf.WRITE_ONLY, out.nbytes)
        runtime.kernel(prg, "row_integral_probe")(ctx.queue, (PROBES,), None, np.uint32(PROBES), np.uint32(n),
                                                  bx, bo)
        cl.enqueue_copy(ctx.queue, out, bo)
        _judge_row(xs, out.astype(np.float64), n)
    if source_integral is not None:
        out = np.empty(2, np.float32)
        bo = cl.Buffer(ctx.context, mf.WRITE_ONLY, out.nbytes)
        runtime.kernel(prg, "source_integral_probe")(ctx.queue, (1,), None, np.uint32(n), bo)
        cl.enqueue_copy(ctx.queue, out, bo)
        _judge_source(float(source_integral), float(out[0]), float(out[1]), n)
    _checked[key] = None


def _where(x: np.ndarray) -> str:
    return "(" + ", ".join(f"{v:.4g}" for v in x) + ")"


def _tolerance(fine: np.ndarray, coarse: np.ndarray, scale: float) -> np.ndarray:
    return REL_TOLERANCE * np.abs(fine) + ERROR_FACTOR * np.abs(fine - coarse) + ABS_FLOOR * scale


def _judge_row(xs: np.ndarray, out: np.ndarray, n: int) -> None:
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
    off = usable & ~(np.abs(a - fine) <= _tolerance(fine, coarse, float(np.max(fine[usable]))))
    if off.any():
        i = int(np.flatnonzero(off)[0])
        raise InputError(
            f"row_integral: A(x) = {a[i]:.6g} at x = {_where(xs[i])}, but the integral of |K(x, y)| dy is "
            f"{fine[i]:.6g} (midpoint rule, {n} points per axis, error about {abs(fine[i] - coarse[i]):.2g}); "
            f"A is wrong at {int(off.sum())} of {int(usable.sum())} probe points. The walks weigh every move by A: "
            "give the integral of |K| over y for every x")


def _judge_source(given: float, fine: float, coarse: float, n: int) -> None:
    """Raise when G is not the quadrature of |g| (module docstring)."""
    if not (np.isfinite(fine) and np.isfinite(coarse)):
        return
    if not abs(given - fine) <= _tolerance(np.array(fine), np.array(coarse), fine):
        raise InputError(
            f"source_integral: G = {given:.6g}, but the integral of |g| is {fine:.6g} (midpoint rule, {n} points "
            f"per axis, error about {abs(fine - coarse):.2g}). Next-event estimation weighs every sample by G: "
            "give the integral of |g| over [0, 1]^dim")
