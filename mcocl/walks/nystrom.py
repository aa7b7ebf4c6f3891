"""A deterministic reference solver: the Nyström method (Gauss–Legendre).

f(x) = g(x) + integral_D K(x, y) f(y) dy on D = [0, 1]^dim is discretised
at the nodes y_j of a tensor-product Gauss–Legendre rule with weights w_j:

    f_i - sum_j w_j K(y_i, y_j) f_j = g(y_i)          (a dense linear system)

and the solution is extended to any x by Nyström interpolation, the equation
itself with the integral replaced by the rule:

    f(x) = g(x) + sum_j w_j K(x, y_j) f_j.

For smooth K and g the error falls exponentially with the order (Atkinson,
"The Numerical Solution of Integral Equations of the Second Kind", §4.1).  It
is the independent reference of the random-walk estimators: it shares nothing
with them but the parsing of the user's expressions.

How the expressions are evaluated.  K and g are OpenCL C snippets (any
expression or function body the walks accept).  Rather than translating C to
NumPy — which would support a subset and could silently differ in
semantics (integer division, float literals, ternaries, built-ins) — they
are evaluated by a small separate OpenCL program (``kernels/walks/evaluate.cl``,
scalar build, float) at the quadrature and query points; the linear algebra
is NumPy in float64.  The values are therefore those of the same compiler
and math library as the walks, accurate to float rounding (~1e-7 relative).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pyopencl as cl

from .. import runtime
from ..errors import InputError
from .codegen import kernel_user, source_user


def default_order(dim: int) -> int:
    """Nodes per axis used unless given: about 4096 nodes at most in all."""
    return {1: 64, 2: 24, 3: 12}.get(dim, max(2, int(4096 ** (1.0 / dim))))


def gauss_legendre(order: int, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """Tensor-product Gauss–Legendre nodes ``(order^dim, dim)`` and weights on [0, 1]^dim."""
    t, w = np.polynomial.legendre.leggauss(order)
    t = 0.5 * (t + 1.0)
    w = 0.5 * w
    grids = np.meshgrid(*([t] * dim), indexing="ij")
    wgrids = np.meshgrid(*([w] * dim), indexing="ij")
    nodes = np.stack([g.ravel() for g in grids], axis=1)
    weights = np.prod(np.stack([g.ravel() for g in wgrids], axis=1), axis=1)
    return nodes, weights


class ExpressionEvaluator:
    """The user's K(x, y) and g(x) evaluated at given points by a small OpenCL program."""

    def __init__(self, kernel: str, source: str, dim: int, device: Any = None) -> None:
        self.dim = int(dim)
        self.ctx = runtime.device_context(device)
        users = (kernel_user(kernel, self.dim), source_user(source, self.dim))
        src = runtime.compose([], "", users, vector_users=False, tail=["walks/evaluate.cl"])
        self.program = runtime.build(self.ctx, src, ["-DLANES=1", f"-DDIM={self.dim}"], users,
                                     what="integral equation")

    def _points(self, p: np.ndarray) -> np.ndarray:
        a = np.ascontiguousarray(np.asarray(p, dtype=np.float32).reshape(-1, self.dim))
        return a

    def kernel_grid(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """``K(xs[i], ys[j])`` as an ``(len(xs), len(ys))`` float64 array."""
        px, py = self._points(xs), self._points(ys)
        out = np.empty((len(px), len(py)), np.float32)
        mf = cl.mem_flags
        c = self.ctx.context
        bx = cl.Buffer(c, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=px)
        by = cl.Buffer(c, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=py)
        bo = cl.Buffer(c, mf.WRITE_ONLY, max(out.nbytes, 4))
        g, lsz = self.ctx.work_size(out.size)
        runtime.kernel(self.program, "eval_kernel_grid")(self.ctx.queue, g, lsz, np.uint32(len(px)), np.uint32(len(py)),
                                                         bx, by, bo)
        cl.enqueue_copy(self.ctx.queue, out, bo)
        return out.astype(np.float64)

    def source(self, xs: np.ndarray) -> np.ndarray:
        """``g(xs[i])`` as a float64 array."""
        px = self._points(xs)
        out = np.empty(len(px), np.float32)
        mf = cl.mem_flags
        bx = cl.Buffer(self.ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=px)
        bo = cl.Buffer(self.ctx.context, mf.WRITE_ONLY, max(out.nbytes, 4))
        g, lsz = self.ctx.work_size(len(px))
        runtime.kernel(self.program, "eval_source")(self.ctx.queue, g, lsz, np.uint32(len(px)), bx, bo)
        cl.enqueue_copy(self.ctx.queue, out, bo)
        return out.astype(np.float64)


@dataclass
class NystromSolution:
    """The Nyström solution; call it with points ``(n, dim)`` to interpolate f there."""

    nodes: np.ndarray
    weights: np.ndarray
    values: np.ndarray  # f at the nodes
    order: int
    evaluator: ExpressionEvaluator

    def __call__(self, points: Any) -> np.ndarray:
        """f at ``points`` by Nyström interpolation: g(x) + sum_j w_j K(x, y_j) f_j."""
        p = np.asarray(points, dtype=np.float64)
        if p.ndim == 1:  # a list of 1-D points, or one point
            p = p[:, None] if self.evaluator.dim == 1 else p[None, :]
        if p.ndim != 2 or p.shape[1] != self.evaluator.dim:
            raise InputError(f"points must have {self.evaluator.dim} coordinates each, got shape {np.shape(points)}")
        k = self.evaluator.kernel_grid(p, self.nodes)
        g = self.evaluator.source(p)
        f = g + k @ (self.weights * self.values)
        if not np.all(np.isfinite(f)):
            raise InputError("the kernel or source is not finite at some query point; the Nyström value is undefined")
        return f


def _order(order: int | None, dim: int) -> int:
    if order is None:
        return default_order(dim)
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or order < 1:
        raise InputError(f"order must be a positive integer (nodes per axis), got {order!r}")
    if int(order) ** dim > 20000:
        raise InputError(f"order {order} in {dim}-D gives {int(order) ** dim} nodes; at most 20000 are supported")
    return int(order)


def nystrom(kernel: str, source: str, dim: int = 1, order: int | None = None, device: Any = None) -> NystromSolution:
    """Solve f = g + ∫ K f on [0, 1]^dim by the Nyström method (the tests' reference).

    Args:
        kernel: OpenCL C over ``float x[dim], y[dim]`` (as for :func:`mcocl.solve_fredholm`).
        source: OpenCL C over ``float x[dim]``.
        dim: dimension of the domain.
        order: Gauss–Legendre nodes per axis (default :func:`default_order`).
        device: the OpenCL device evaluating the expressions.

    Returns:
        a :class:`NystromSolution`; ``sol(points)`` gives f at the points.

    Raises:
        InputError: K or g is not finite at a node, or I - KW is singular.
        KernelBuildError: the expressions do not compile.
    """
    if isinstance(dim, bool) or not isinstance(dim, (int, np.integer)) or dim < 1:
        raise InputError(f"dim must be a positive integer, got {dim!r}")
    n = _order(order, int(dim))
    ev = ExpressionEvaluator(kernel, source, int(dim), device)
    nodes, w = gauss_legendre(n, int(dim))
    k = ev.kernel_grid(nodes, nodes)
    g = ev.source(nodes)
    if not np.all(np.isfinite(k)):
        i, j = np.argwhere(~np.isfinite(k))[0]
        raise InputError(f"kernel is not finite at x={nodes[i].tolist()}, y={nodes[j].tolist()}")
    if not np.all(np.isfinite(g)):
        i = int(np.argwhere(~np.isfinite(g))[0][0])
        raise InputError(f"source is not finite at x={nodes[i].tolist()}")
    a = np.eye(len(nodes)) - k * w[None, :]
    try:
        f = np.linalg.solve(a, g)
    except np.linalg.LinAlgError:
        raise InputError("the discretised equation is singular: 1 is an eigenvalue of the kernel operator") from None
    return NystromSolution(nodes, w, f, n, ev)


def spectral_radius(kernel: str, dim: int, order: int | None = None, device: Any = None,
                    absolute: bool = True) -> float:
    """Spectral radius of the discretised kernel operator (of |K| when ``absolute``).

    The random walks' Neumann series converges in mean when the operator of
    |K| has spectral radius < 1; this Gauss–Legendre estimate is what the
    fixed-length estimators check before they run (they cannot see
    divergence in their walks).
    """
    n = _order(order, int(dim)) if order is not None else {1: 48, 2: 16}.get(int(dim), max(2, int(2048 ** (1.0 / dim))))
    ev = ExpressionEvaluator(kernel, "0.0f", int(dim), device)
    nodes, w = gauss_legendre(n, int(dim))
    k = ev.kernel_grid(nodes, nodes)
    if absolute:
        k = np.abs(k)
    if not np.all(np.isfinite(k)):
        return math.nan
    # sqrt(w) K sqrt(w) is similar to K W and better conditioned
    sw = np.sqrt(w)
    return float(np.max(np.abs(np.linalg.eigvals(sw[:, None] * k * sw[None, :]))))
