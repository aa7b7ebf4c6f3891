"""Refuse a user's transition or source sampler that does not sample the density it claims.

With ``transition_sampler`` the subcritical and nee walks move to
``y = T(x, u)`` and weigh the move by ``K(x, y) / p(y)`` with
``p = |K(x, .)| / A(x)``; with ``source_sampler`` next-event estimation draws
``z = Z(u)`` and weighs it by ``g(z) G / |g(z)|``.  Both weights are right only
when ``T(x, u)`` has the density ``|K(x, .)| / A(x)`` and ``Z(u)`` the density
``|g| / G`` for uniform ``u``; a sampler that draws from any other density
gives a wrong answer with nothing to show it (issue 10; :mod:`.integral_check`
already checks that A and G are the integrals they claim).  The integration
counterpart is :mod:`mcocl.integration.density_check`.

Before any walk, the walk program's own samplers (``walk_sample_check`` in
``kernels/walks/sample_check.cl``, the very functions the walks call) draw
``SAMPLES`` points at each of ``X_PROBES`` fixed vertices x, and:

1. every point must lie in [0, 1]^dim and be finite (the walk turns a point
   outside into NaN, :mod:`.codegen`'s ``walk_unit_or_nan``; here it is refused
   before it costs a run);
2. their histogram over ``b^dim`` equal cells must match the cell masses of
   the claimed density, found by the midpoint rule on a finer grid of
   ``GRID_POINTS`` points (``kernels/walks/evaluate.cl``).  The two are
   compared by the total variation distance ``(1/2) sum |O_c/n - P_c|``, refused
   above ``TV_TOLERANCE``.  Sampling noise alone gives about
   ``0.4 sqrt(cells / n)`` (0.013 for 16 cells and 16,384 points) and the
   midpoint rule's error near an integrable singularity a few thousandths, so a
   refusal means a sampler that puts at least 8% of its mass in the wrong place
   (``u[0]`` for the density ``2y`` misplaces 25%).

The seed is fixed, so the verdict is reproducible.  Above ``MAX_DIM``
dimensions the grid is too coarse to judge the shape and only check 1 runs;
vertices where the kernel or source is not finite on the grid skip check 2.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import InputError
from .codegen import SRC_GIVEN, TRANS_GIVEN
from .integral_check import probe_points

X_PROBES = 4  # vertices x at which the transition sampler is checked
SAMPLES = 16384  # points drawn per vertex
GRID_POINTS = 4096  # about (b * s)^dim quadrature points for the cell masses
CELLS_PER_AXIS = {1: 16, 2: 6, 3: 4}  # b: histogram cells per axis
MAX_DIM = 3
TV_TOLERANCE = 0.08
SEED = 0x5A3C_0FF1

_checked: dict[tuple[Any, ...], None] = {}  # what passed, per process


def _grid(dim: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Midpoints ``(m^dim, dim)`` of the fine grid, the histogram cell of each, and ``b``."""
    b = CELLS_PER_AXIS[dim]
    s = max(1, int(round(GRID_POINTS ** (1.0 / dim))) // b)
    m = b * s
    axes = np.meshgrid(*[(np.arange(m) + 0.5) / m] * dim, indexing="ij")
    pts = np.stack([a.ravel() for a in axes], axis=1)
    return pts, _cell_of(pts, b), b


def _cell_of(points: np.ndarray, b: int) -> np.ndarray:
    idx = np.clip((points * b).astype(np.int64), 0, b - 1)
    cell = np.zeros(len(points), np.int64)
    for k in range(points.shape[1]):
        cell = cell * b + idx[:, k]
    return cell


def _tv(samples: np.ndarray, weights: np.ndarray, cells: np.ndarray, b: int) -> tuple[float, int, float, float]:
    """Total variation distance between the samples' histogram and the normalised weights per cell,
    with the cell where they differ most (its index, observed share, claimed share)."""
    ncell = b ** samples.shape[1]
    mass = np.bincount(cells, weights=weights, minlength=ncell)
    mass = mass / mass.sum()
    obs = np.bincount(_cell_of(samples, b), minlength=ncell) / len(samples)
    i = int(np.argmax(np.abs(obs - mass)))
    return 0.5 * float(np.abs(obs - mass).sum()), i, float(obs[i]), float(mass[i])


def _cell_text(i: int, b: int, dim: int) -> str:
    idx = []
    for _ in range(dim):
        idx.append(i % b)
        i //= b
    return " x ".join(f"[{k / b:.3g}, {(k + 1) / b:.3g})" for k in reversed(idx))


def _outside(name: str, pts: np.ndarray, where: str) -> None:
    bad = ~np.all(np.isfinite(pts), axis=1)
    if bad.any():
        raise InputError(f"{name}: {int(bad.sum())} of {len(pts)} sampled points{where} lie outside [0, 1]^"
                         f"{pts.shape[1]} or are not finite; an inverse CDF must map (0, 1) into [0, 1]")


def check_user_samplers(req: Any, runner: Any, device: Any = None) -> None:
    """Run the checks of the module docstring on the request's user samplers, if any.

    ``req`` is the validated :class:`~mcocl.walks.request.WalkRequest`,
    ``runner`` its built :class:`~mcocl.walks.job.WalkRunner` (tables made).

    Raises:
        InputError: a sampler leaves [0, 1]^dim or draws from another density
            than the one its kernel or source and integral describe.
    """
    code = runner.job.code
    given_t = code.transition == TRANS_GIVEN
    given_z = code.source_mode == SRC_GIVEN
    if not (given_t or given_z):
        return
    key = (runner.ctx.device.int_ptr, req.kernel, req.source, req.dim, tuple(req.transition_sampler or ()),
           tuple(req.source_sampler or ()), req.row_integral, req.source_integral, req.estimator)
    if key in _checked:
        return
    dim = req.dim
    xs = probe_points(dim)[:X_PROBES] if given_t else probe_points(dim)[:1]
    draws = [runner.sample_check(x, SAMPLES, seed=SEED + i) for i, x in enumerate(xs)]
    if given_t:
        for x, d in zip(xs, draws):
            _outside("transition_sampler", d["y"].astype(np.float64), f" at x = {_fmt(x)}")
    if given_z:
        _outside("source_sampler", draws[0]["z"].astype(np.float64), "")
    if dim <= MAX_DIM:
        from .nystrom import ExpressionEvaluator

        pts, cells, b = _grid(dim)
        ev = ExpressionEvaluator(req.kernel, req.source, dim, device)
        if given_t:
            k = np.abs(ev.kernel_grid(xs, pts))
            for i, (x, d) in enumerate(zip(xs, draws)):
                if not np.all(np.isfinite(k[i])) or k[i].sum() <= 0:
                    continue
                tv, c, got, want = _tv(d["y"].astype(np.float64), k[i], cells, b)
                if tv > TV_TOLERANCE:
                    raise InputError(
                        f"transition_sampler does not sample |K(x, y)| / A(x): at x = {_fmt(x)}, {SAMPLES} moves "
                        f"differ from that density by {tv:.3f} in total variation (at most {TV_TOLERANCE:g} "
                        f"allowed); cell {_cell_text(c, b, dim)} got {got:.3f} of the moves where the density has "
                        f"{want:.3f}. Give the inverse CDF of |K(x, .)| / A(x), or leave the sampler out to "
                        "sample a tabulated |K|")
        if given_z:
            g = np.abs(ev.source(pts))
            if np.all(np.isfinite(g)) and g.sum() > 0:
                tv, c, got, want = _tv(draws[0]["z"].astype(np.float64), g, cells, b)
                if tv > TV_TOLERANCE:
                    raise InputError(
                        f"source_sampler does not sample |g| / G: {SAMPLES} points differ from that density by "
                        f"{tv:.3f} in total variation (at most {TV_TOLERANCE:g} allowed); cell "
                        f"{_cell_text(c, b, dim)} got {got:.3f} of the points where the density has {want:.3f}. "
                        "Give the inverse CDF of |g| / G, or leave the sampler out to sample a tabulated |g|")
    _checked[key] = None


def _fmt(x: np.ndarray) -> str:
    return "(" + ", ".join(f"{v:.4g}" for v in np.ravel(x)) + ")"
