"""``mcocl.solve_fredholm``: integral equations of the second kind by random walks.

Solves f(x) = g(x) + integral_D K(x, y) f(y) dy on D = [0, 1]^dim at query
points; each walk is one sample of f at one point (lecture, "Řešení
integrálních rovnic" to "Odhad příští události"; kernels in
``kernels/walks``).  The Neumann series f = g + Tg + T^2 g + ... is what the
walks sum; it converges in mean when the operator of |K| has spectral radius
below 1.  A problem where it does not is stopped, never left to hang:

- estimators with random walk lengths (roulette with the weight-driven
  survival, subcritical, nee) stop a walk that makes ``max_walk_length``
  moves and raise :class:`~mcocl.errors.ConvergenceError`;
- estimators whose walks end regardless (truncated, roulette with a constant
  survival probability) cannot see divergence in their walks, so the spectral
  radius of the discretised |K| is checked before they run.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import runtime
from ..accumulate import Accumulator
from ..engine.contract import Progress
from ..engine.dispatch import execute
from ..errors import ConvergenceError, InputError, NonFiniteWarning
from ..run_options import RunOptions, renamed_keyword
from ..validate import whole_number
from .codegen import generate
from .integral_check import check_given_integrals
from .job import STATS, WALKS_PER_BLOCK, WalkJob, WalkRunner, estimates
from .nystrom import spectral_radius
from .request import WalkRequest, validate
from .sampler_check import check_user_samplers
from .sobol_walks import WALK_SAMPLERS, sobol_walks_per_block


@dataclass
class FredholmResult:
    """The outcome of :func:`solve_fredholm`.

    Attributes:
        values: the estimate of f at every query point.
        stderr: its standard error (sample standard deviation of the walks / sqrt(n)).
        at: the query points, ``(nq, dim)``.
        walks: walks run per query point (``nonfinite`` of them left out).
        mean_walk_length: moves per walk, averaged over every walk of every point.
        seconds: wall time of the walks (build, tabulation and pilot excluded).
        estimator, seed, dim: as requested.
        description: the estimator and its options in words.
        variance: per-walk variance at every point, ``stderr**2 * finite walks``.
        nonfinite: walks per point whose value was NaN/Inf (counted, left out).
        device, lanes: where it ran, walks per vector instruction.
        stopped_by: ``walks``, ``time``, ``stderr`` or ``interrupt``.
        build_seconds, setup_seconds: kernel build; tabulation and pilot.
        notes: anything the user should know.
        walks_this_run: walks per point run by this call (fewer than ``walks``
            when it resumed a checkpoint); ``walks_per_second`` counts these.
    """

    values: np.ndarray
    stderr: np.ndarray
    at: np.ndarray
    walks: int
    mean_walk_length: float
    seconds: float
    estimator: str
    seed: int
    dim: int
    description: str = ""
    variance: np.ndarray = field(default_factory=lambda: np.zeros(0))
    nonfinite: list[int] = field(default_factory=list)
    device: str = ""
    lanes: int = 1
    stopped_by: str = "walks"
    build_seconds: float = 0.0
    setup_seconds: float = 0.0
    notes: list[str] = field(default_factory=list)
    walks_this_run: int = -1

    @property
    def walks_per_second(self) -> float:
        """Walks (all query points together) per second of the walking done by this call."""
        n = self.walks if self.walks_this_run < 0 else self.walks_this_run
        return n * len(self.values) / self.seconds if self.seconds > 0 else math.nan

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict of every field plus ``walks_per_second``."""
        return {
            "values": [float(v) for v in self.values],
            "stderr": [float(v) for v in self.stderr],
            "at": np.asarray(self.at).tolist(),
            "walks": int(self.walks),
            "mean_walk_length": float(self.mean_walk_length),
            "seconds": float(self.seconds),
            "estimator": self.estimator,
            "seed": int(self.seed),
            "dim": int(self.dim),
            "description": self.description,
            "variance": [float(v) for v in self.variance],
            "nonfinite": [int(v) for v in self.nonfinite],
            "device": self.device,
            "lanes": int(self.lanes),
            "stopped_by": self.stopped_by,
            "build_seconds": float(self.build_seconds),
            "setup_seconds": float(self.setup_seconds),
            "walks_per_second": float(self.walks_per_second),
            "walks_this_run": int(self.walks_this_run),
            "notes": list(self.notes),
        }

    def __str__(self) -> str:
        rows = [f"f({', '.join(f'{c:g}' for c in p)}) = {v:.8g} ± {e:.3g}"
                for p, v, e in zip(np.asarray(self.at), self.values, self.stderr)]
        return "\n".join(rows) + f"\n({self.walks} walks per point, {self.estimator}, {self.seconds:.3g} s)"


def _divergence_message(guards: float, walks: float, max_len: int) -> str:
    return (f"the Neumann series appears not to converge: {int(guards)} of {int(walks)} walks were still going "
            f"after max_walk_length={max_len} moves or their weight grew beyond 1e30 (the spectral radius of |K| "
            "seems to be >= 1). If the series converges slowly, raise max_walk_length.")


def _check_spectral_radius(req: WalkRequest, device: Any) -> list[str]:
    # truncated: the cut series approximates f only when the series of K
    # converges (spectral radius of K < 1); roulette with a constant P: the
    # walk's expectation exists only when the series of |K| converges.
    absolute = req.estimator != "truncated"
    rho = spectral_radius(req.kernel, req.dim, device=device, absolute=absolute)
    if not math.isfinite(rho):
        return ["the kernel is not finite at some Gauss-Legendre node; the convergence check was skipped"]
    if rho >= 1.0:
        what = "|K|" if absolute else "K"
        raise ConvergenceError(
            f"the Neumann series appears not to converge: the discretised {what} has spectral radius about "
            f"{rho:.4g} >= 1, so the {req.estimator} estimator would return a meaningless finite number"
        )
    return []


def _tabulate(req: WalkRequest, job: WalkJob, runner: WalkRunner) -> list[str]:
    code = job.code
    if not (code.needs_transition_table or code.needs_source_table):
        return []
    tabs = runner.tables(req.grid, code.needs_transition_table, code.needs_source_table)
    job.tables = tabs
    notes = []
    g = req.grid
    if tabs.nonfinite_kernel:
        notes.append(f"the kernel was NaN/Inf at {tabs.nonfinite_kernel} of {g.ncells * g.nbins} tabulation weights; "
                     "those bins are sampled by the defensive mixture only")
    if tabs.nonfinite_source:
        notes.append(f"the source was NaN/Inf at {tabs.nonfinite_source} of {g.nbins} tabulation weights; "
                     "those bins are sampled by the defensive mixture only")
    return notes


def solve_fredholm(
    kernel: str,
    source: str,
    dim: int = 1,
    at: Any = (0.5,),
    walks: int | float | None = 1_000_000,
    *,
    estimator: str = "nee",
    seed: int = 0,
    depth: int = 8,
    survival: float | str = "weight",
    row_integral: str | None = None,
    transition_sampler: str | Sequence[str] | None = None,
    source_integral: float | None = None,
    source_sampler: str | Sequence[str] | None = None,
    max_walk_length: int = 10_000,
    table_cells: int | None = None,
    table_bins: int | None = None,
    time_budget: float | None = None,
    target_error: float | None = None,
    device: Any = None,
    devices: Any = None,
    split: int | None = None,
    client: Any = None,
    lanes: int | None = None,
    checkpoint: str | None = None,
    resume: str | None = None,
    progress: bool | Callable[[Progress], None] = False,
    target_stderr: float | None = None,
    sampler: str = "independent",
    replicates: int | None = None,
) -> FredholmResult:
    """Solve f(x) = g(x) + ∫_D K(x, y) f(y) dy, D = [0, 1]^dim, at query points by random walks.

    Args:
        kernel: K as OpenCL C over ``float x[dim], y[dim]`` (e.g. ``"0.5f*(x[0] + y[0])"``).
        source: g as OpenCL C over ``float x[dim]``.
        dim: dimension of the domain.
        at: query points: ``[[x0, x1, ...], ...]`` (a flat list for dim 1).
        walks: walks per query point (at most); ``None``: until ``time_budget``
            or ``target_error``.
        estimator: ``truncated`` (fixed ``depth``, biased), ``roulette``
            (uniform moves, Russian roulette), ``subcritical`` (moves ~ |K|,
            survival min(1, ∫|K|)) or ``nee`` (subcritical plus next-event
            estimation of the g term, sampled ~ |g|).
        seed: 64-bit seed; the result depends on nothing else.
        depth: moves of the truncated estimator.
        survival: roulette's survival probability: a number in (0, 1], or
            ``"weight"`` for min(1, |walk weight|).
        row_integral, transition_sampler: subcritical/nee: A(x) = ∫|K(x, y)| dy
            and the inverse CDF of |K(x, .)| / A(x), one expression per
            coordinate over ``float x[dim], u[dim]``; without them |K(x, .)|
            is tabulated.
        source_integral, source_sampler: nee: G = ∫|g| and the inverse CDF of
            |g| / G, one expression per coordinate over ``float u[dim]``;
            without them |g| is tabulated.
        max_walk_length: the walk-length guard (moves); a walk that reaches it
            stops the run with :class:`ConvergenceError`.
        table_cells, table_bins: tabulation grid per axis (see ``tabulate.py``).
        time_budget: stop after this many seconds.
        target_error: stop once every point's standard error is at most this.
        device, devices, split, client: where to run (see :class:`mcocl.engine.contract.Placement`).
        lanes: walks per vector instruction (1 forces the scalar kernel).
        checkpoint: save the sums to this file periodically and at the end.
        resume: continue from a checkpoint of the same problem.
        progress: True for a progress bar on stderr, or a callback.
        target_stderr: deprecated name of ``target_error``.
        sampler: ``independent`` (Philox) or ``sobol`` (randomised quasi-Monte
            Carlo walks: each block of 2^m walks is one Owen-scrambled Sobol'
            replicate; the stderr is the spread of the replicate means;
            :mod:`mcocl.walks.sobol_walks`).
        replicates: ``sampler="sobol"``: the number of replicates R; ``walks``
            is split into R blocks of the largest power of two (default 16, or
            more blocks of 4096 walks for large runs).

    The shared options (seed, time_budget, target_error, placement, lanes,
    checkpoint, resume, progress) are checked by :class:`mcocl.run_options.RunOptions`.

    Returns:
        a :class:`FredholmResult`.

    Raises:
        InputError: invalid arguments (the message names the argument).
        KernelBuildError: the kernel, source or a sampler does not compile.
        ConvergenceError: the Neumann series appears not to converge.
    """
    target_error = renamed_keyword("solve_fredholm", "target_error", target_error, "target_stderr", target_stderr)
    opts = RunOptions(seed=seed, time_budget=time_budget, target_error=target_error, device=device, devices=devices,
                      split=split, client=client, lanes=lanes, checkpoint=checkpoint, resume=resume, progress=progress)
    req = validate(kernel, source, dim, at, estimator, opts.seed, depth, survival, row_integral, transition_sampler,
                   source_integral, source_sampler, max_walk_length, table_cells, table_bins)
    if walks is not None:
        walks = whole_number("walks", walks, 1, 1 << 62)
    opts.require_stop("walks", walks)
    if sampler not in WALK_SAMPLERS:
        raise InputError(f"sampler: unknown walk sampler {sampler!r}; choose one of {', '.join(WALK_SAMPLERS)}")
    if replicates is not None and (sampler != "sobol" or not 2 <= whole_number("replicates", replicates) <= 1 << 20):
        raise InputError(f"replicates: {replicates!r} needs sampler='sobol' and a value between 2 and {1 << 20}")
    walks_per_block = WALKS_PER_BLOCK
    if sampler == "sobol":
        walks_per_block = sobol_walks_per_block(walks, replicates, WALKS_PER_BLOCK)

    code = generate(req.kernel, req.source, req.dim, req.estimator, req.row_integral, req.transition_sampler,
                    req.source_integral, req.source_sampler)
    # a wrong A(x) or G is refused, not used (issue 10)
    check_given_integrals(req.kernel, req.source, req.dim, req.row_integral, req.source_integral, opts.device)
    meta = {**req.meta(), "sampler": sampler if sampler != "independent" else None}
    acc: Accumulator | None = None
    resume = opts.resume
    if resume is not None:
        acc = Accumulator.load(resume, expect_meta=meta)
        acc.check_shape((len(np.atleast_2d(req.at)), STATS), resume)
        if acc.totals[:, 5].sum() > 0:
            raise ConvergenceError(_divergence_message(acc.totals[:, 5].sum(), acc.totals[:, 0].sum(),
                                                       req.max_walk_length))

    notes: list[str] = []
    ctx = runtime.device_context(opts.device)
    limit = walks if walks is not None else (1 << 62)
    holds_more = False  # a resumed checkpoint holds more walks than asked for
    job = WalkJob(code, req.at, req.seed, limit, survival=req.survival, depth=req.depth,
                  max_len=req.max_walk_length, lanes=opts.lanes, walks_per_block=walks_per_block, sampler=sampler)
    runner = job.runner(ctx)
    if runner.program.note:
        notes.append(runner.program.note)
    if req.estimator == "truncated" or (req.estimator == "roulette" and req.survival > 0):
        notes += _check_spectral_radius(req, opts.device)

    t0 = time.perf_counter()
    notes += _tabulate(req, job, runner)
    check_user_samplers(req, runner, opts.device)  # a sampler of another density is refused, not used (issue 10)
    if acc is not None:
        if acc.meta.get("tables") != (job.tables.digest() if job.tables is not None else None):
            raise InputError(f"checkpoint {resume} was made with different tabulated densities "
                             "(another device or version); it cannot be resumed here")
        if acc.meta.get("walks_per_block") != job.walks_per_block:
            raise InputError(f"checkpoint {resume} has blocks of {acc.meta.get('walks_per_block')} walks, this "
                             f"version uses {job.walks_per_block}; it cannot be resumed here")
        saved = acc.meta.get("walk_limit")
        if (isinstance(saved, int) and not isinstance(saved, bool) and limit < saved <= (1 << 62)
                and min(acc.blocks_done * job.walks_per_block, saved) > limit):
            # The checkpoint already holds more walks than asked for: they stay in the estimate (nothing
            # computed is thrown away), so the counts are its own, and nothing is added.
            notes.append(f"the checkpoint already holds {min(acc.blocks_done * job.walks_per_block, saved)} walks "
                         f"per point, more than the {walks} asked for: nothing was added")
            limit = job.walk_limit = saved
            holds_more = True
        elif acc.meta.get("partial_tail") and acc.meta.get("walk_limit") != limit:
            raise InputError(f"checkpoint {resume} ends in a partial block of {job.walks_per_block} walks; "
                             f"resume it with the same walks ({acc.meta.get('walk_limit')}) or start runs with a "
                             "multiple of the block size")
        shifts = acc.meta.get("shifts")
        if (not isinstance(shifts, list) or len(shifts) != job.nq
                or any(isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) for v in shifts)):
            raise InputError(f"checkpoint {resume}: its field 'shifts' is damaged ({shifts!r})")
        job.shifts = np.asarray(shifts, dtype=np.float64)
    else:
        pilot = runner.pilot()
        if pilot[:, 5].sum() > 0:
            raise ConvergenceError(_divergence_message(pilot[:, 5].sum(), pilot[:, 0].sum() + pilot[:, 5].sum(),
                                                       req.max_walk_length))
        with np.errstate(invalid="ignore", divide="ignore"):
            m = np.where(pilot[:, 0] > 0, pilot[:, 2] / np.maximum(pilot[:, 0], 1), 0.0)
        job.shifts = np.where(np.isfinite(m), m, 0.0).astype(np.float32).astype(np.float64)
        acc = Accumulator((job.nq, STATS), {
            **meta,
            "shifts": job.shifts.tolist(),
            "tables": job.tables.digest() if job.tables is not None else None,
            "walks_per_block": job.walks_per_block,
        })
    setup_seconds = time.perf_counter() - t0

    def target(a: Accumulator) -> bool:
        if a.totals[:, 5].sum() > 0:
            return True  # a guard hit: stop now, the run will raise
        if opts.target_error is None:
            return False
        if a.totals[:, 0].min() < (8 if sampler == "sobol" else 1000):  # sobol: count = replicates
            return False
        _, errs = estimates(a.totals, job.shifts)
        return bool(np.all(np.isfinite(errs)) and np.max(errs) <= opts.target_error)

    callback, bar = opts.progress_reporter(f"solve [{req.estimator}]", "walks", job.walks_per_block * job.nq)
    acc.meta["walk_limit"] = limit
    max_blocks = job.max_blocks if walks is not None else None
    if holds_more:
        max_blocks = acc.blocks_done
    blocks_before = acc.blocks_done  # a resumed checkpoint's blocks: not this run's throughput
    report = execute(job, acc, opts.halting(max_blocks, target), opts.placement, progress=callback, runner=runner,
                     ctx=ctx)
    if bar is not None:
        bar.close()
    acc.meta["partial_tail"] = bool(acc.blocks_done * job.walks_per_block > limit)
    if opts.checkpoint:
        acc.save(opts.checkpoint)

    t = acc.totals
    walks_run = min(acc.blocks_done * job.walks_per_block, limit)
    if t[:, 5].sum() > 0:
        raise ConvergenceError(_divergence_message(t[:, 5].sum(), t[:, 0].sum() + t[:, 1].sum() + t[:, 5].sum(),
                                                   req.max_walk_length))
    values, errs = estimates(t, job.shifts)
    if sampler == "sobol":
        notes.append(f"sobol: stderr from the spread of {acc.blocks_done} independent Owen-scrambled Sobol' "
                     f"replicates of {job.walks_per_block} walks")
    nonfinite = [int(v) for v in t[:, 1]]
    stopped = "walks" if report.stopped_by == "blocks" else report.stopped_by
    if report.stopped_by == "target":
        stopped = "stderr"
    result = FredholmResult(
        values=values,
        stderr=errs,
        at=req.at,
        walks=int(walks_run),
        mean_walk_length=float(t[:, 4].sum() / max(walks_run * job.nq, 1)),
        seconds=report.seconds,
        estimator=req.estimator,
        seed=req.seed,
        dim=req.dim,
        description=req.describe(),
        variance=errs**2 * (t[:, 0] if sampler != "sobol" else walks_run),
        nonfinite=nonfinite,
        device=", ".join(report.devices) if report.devices else ctx.name,
        lanes=runner.lanes,
        stopped_by=stopped,
        build_seconds=runner.build_seconds,
        setup_seconds=setup_seconds,
        notes=notes,
        walks_this_run=int(walks_run - min(blocks_before * job.walks_per_block, limit)),
    )
    if sum(nonfinite):
        warnings.warn(
            f"{sum(nonfinite)} of {walks_run * job.nq} walks had a NaN or infinite value and were left out "
            f"(per query point: {nonfinite})",
            NonFiniteWarning,
            stacklevel=2,
        )
    return result
