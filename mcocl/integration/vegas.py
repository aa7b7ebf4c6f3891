"""``sampler="vegas"``: the iterations of VEGAS (Lepage 1978) around the integration kernel.

Each iteration is one ordinary run of the integration job (the engine's
blocks, placements, halting and block-order folding) with the current grid
uploaded as a buffer; its accumulator rows carry, after the usual columns,
the per-dimension, per-bin training sums of (f J)^2
(kernels/sampling/vegas_grid.cl), folded in block order like every other
statistic, so the next grid does not depend on the launch split or the lane
width.  Between iterations the host refines the grid
(:meth:`mcocl.integration.vegas_grid.VegasGrid.refine`).

Iteration k draws the sample indices that follow those of iteration k-1 in
the one sample stream of the seed.  The schedule (how many iterations, their
sizes, the warm-up) is the :class:`mcocl.integration.samplers.Vegas`
docstring's.  The result combines the iterations after the warm-up by inverse
variance weights (Lepage 1978):

    I = sum_k I_k / s_k^2 / sum_k 1 / s_k^2,   s^2 = 1 / sum_k 1 / s_k^2,
    chi^2 = sum_k (I_k - I)^2 / s_k^2 on (iterations - 1) degrees of freedom.

A chi^2 whose upper-tail probability Q is below ``CHI2_Q_WARN`` says the
iterations disagree beyond their errors (too few samples per iteration for
the integrand, or a grid still moving): the result carries a note.

Checkpoints hold the whole state in the metadata of the current iteration's
accumulator: the grid, the finished iterations, the schedule and where the
current iteration's samples start.  A resumed run continues the same
adaptation; with the same arguments it ends with the same numbers.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pyopencl as cl

from .. import runtime
from ..accumulate import Accumulator
from ..engine.dispatch import execute
from ..errors import InputError
from ..run_options import RunOptions
from .codegen import EstimatorCode
from .design import MAX_AXIS_CELLS, UNBOUNDED_UNITS, Design, design_from_checkpoint
from .job import ROW, IntegrationJob, IntegrationRunner, estimate_from_totals, reduce_blocks, rounding_floor
from .vegas_grid import VegasGrid, check_bins

DEFAULT_ITERATIONS = 10
DEFAULT_BINS = 256
DEFAULT_ALPHA = 1.5  # measured: 0.5 (the vegas package's) adapts too slowly for 10 iterations (stderr 2.5x-10x larger on peaks, chi2/dof 3)
CHI2_Q_WARN = 0.01
BLOCK_UNITS = 4096  # units_per_block of the Vegas spec
MAX_STRATA = 1 << 31
# Independent stratified designs per iteration: the spread of their means is
# a second variance estimate, kept when larger than the stratum pairs' one
# (which misses the variance of a jump that both samples of its stratum see
# on the same side; mcocl.integration.samplers.Vegas.statistics).
STRATIFIED_DESIGNS = 8


@dataclass(frozen=True)
class VegasSettings:
    """The user's VEGAS options, checked."""

    iterations: int = DEFAULT_ITERATIONS
    bins: int = DEFAULT_BINS
    alpha: float = DEFAULT_ALPHA

    @classmethod
    def parse(cls, iterations: Any, bins: Any, alpha: Any) -> VegasSettings:
        """Validate ``vegas_iterations``, ``vegas_bins`` and ``alpha`` (``None``: the default)."""
        it = DEFAULT_ITERATIONS if iterations is None else iterations
        if isinstance(it, bool) or not isinstance(it, (int, np.integer)) or not 1 <= int(it) <= 10_000:
            raise InputError(f"vegas_iterations must be a whole number from 1 to 10000, got {iterations!r}")
        b = check_bins(DEFAULT_BINS if bins is None else bins)
        a = DEFAULT_ALPHA if alpha is None else alpha
        try:
            a = float(a)
        except (TypeError, ValueError):
            raise InputError(f"alpha (VEGAS damping) must be a number in [0, 4], got {alpha!r}") from None
        if not 0.0 <= a <= 4.0:
            raise InputError(f"alpha (VEGAS damping) must be a number in [0, 4], got {alpha!r}")
        return cls(int(it), b, a)

    @property
    def warmup(self) -> int:
        """Iterations that only adapt the grid (not combined): iterations // 4."""
        return self.iterations // 4

    def plan(self, dim: int, samples: int | None) -> tuple[Design, list[int] | None]:
        """The design of every iteration and its scheduler blocks per iteration (``None``: sized by time).

        With a sample budget, each iteration gets samples // iterations: in
        stratified designs of m^dim strata of the uniforms (before the grid),
        two samples each, m the largest with 2 m^dim STRATIFIED_DESIGNS <=
        that (as many whole designs as fit, at least STRATIFIED_DESIGNS), when
        m >= 2; else in blocks of 4096 independent samples.  A time budget alone runs independent samples.
        """
        if samples is None:
            return Design("vegas", UNBOUNDED_UNITS, 1, 0, 1, bins=self.bins), None
        per_iteration = max(samples // self.iterations, 1)
        m = _strata_per_axis(per_iteration // (2 * STRATIFIED_DESIGNS), dim)
        if m >= 2:
            units = m**dim
            design = Design("vegas", units, 1, m, -(-units // BLOCK_UNITS), bins=self.bins)
            return design, [max(per_iteration // (2 * units), 1)] * self.iterations
        design = Design("vegas", UNBOUNDED_UNITS, 1, 0, 1, bins=self.bins)
        return design, [max(per_iteration // BLOCK_UNITS, 1)] * self.iterations

    def meta(self) -> dict[str, Any]:
        """What a checkpoint must match."""
        return {"iterations": self.iterations, "bins": self.bins, "alpha": self.alpha}


@dataclass
class VegasJob(IntegrationJob):
    """The integration job of one iteration: the grid and where its samples start."""

    grid_table: np.ndarray | None = None
    block_offset: int = 0

    def runner(self, ctx: runtime.DeviceContext) -> VegasRunner:
        """Build for ``ctx``."""
        return VegasRunner(self, ctx)


class VegasRunner(IntegrationRunner):
    """The integration runner with the grid buffer and the training rows (one build for every iteration)."""

    def __init__(self, job: VegasJob, ctx: runtime.DeviceContext) -> None:
        super().__init__(job, ctx)
        self.bind(job)

    def bind(self, job: VegasJob) -> None:
        """Run ``job`` (the next iteration of the same program) from now on."""
        self.job = job
        mf = cl.mem_flags
        self.grid = cl.Buffer(self.ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=job.grid_table)
        self.row = job.dim * job.design.bins

    def sampler_args(self, nkblocks: int) -> tuple[cl.Buffer, ...]:
        """The grid and a fresh buffer of one training row per block."""
        return self.grid, cl.Buffer(self.ctx.context, cl.mem_flags.WRITE_ONLY, 8 * self.row * max(nkblocks, 1))

    def _launch(self, first_kblock: int, nkblocks: int, shift: float,
                extra: tuple[cl.Buffer, ...] | None = None) -> tuple[cl.Event, np.ndarray]:
        return super()._launch(first_kblock + self.job.block_offset, nkblocks, shift, extra)

    def enqueue(self, first_block: int, nblocks: int) -> tuple[cl.Event, cl.Event, np.ndarray, np.ndarray, int]:
        """Launch blocks ``first_block ..`` of this iteration and read back their training rows too."""
        g = self.job.design.granule_blocks
        extra = self.sampler_args(nblocks * g)
        ev, out = self._launch(first_block * g, nblocks * g, self.job.shift, extra)
        train = np.empty((nblocks * g, self.row), dtype=np.float64)
        ev_train = cl.enqueue_copy(self.ctx.queue, train, extra[1], is_blocking=False)
        return ev, ev_train, out, train, nblocks

    def collect(self, handle: tuple[cl.Event, cl.Event, np.ndarray, np.ndarray, int]) -> np.ndarray:
        """Accumulator rows: the integration columns, then the training sums."""
        ev, ev_train, out, train, nblocks = handle
        ev.wait()
        ev_train.wait()
        g = self.job.design.granule_blocks
        if g > 1:  # the kernel blocks of one design, added in order (as reduce_blocks does)
            train = np.add.accumulate(train.reshape(nblocks, g, self.row), axis=1)[:, -1, :]
        return np.concatenate([reduce_blocks(out, nblocks, self.job.design), train], axis=1)


@dataclass
class Iteration:
    """One finished iteration: its estimate, the variance of it, and what the result reports."""

    estimate: float
    variance: float
    samples: int
    nonfinite: int
    floor: float
    warmup: bool

    def to_dict(self) -> dict[str, Any]:
        """JSON form (checkpoints and the result)."""
        return {"estimate": self.estimate, "variance": self.variance, "samples": self.samples,
                "nonfinite": self.nonfinite, "floor": self.floor, "warmup": self.warmup}


def combine(iterations: list[Iteration]) -> tuple[float, float, float, int]:
    """(estimate, variance, chi^2, degrees of freedom) of the iterations by inverse-variance weights.

    Iterations with a non-finite variance carry no weight; when some have
    variance 0 (an integrand the grid made constant) those alone are averaged.
    """
    its = [it for it in iterations if math.isfinite(it.variance) and math.isfinite(it.estimate)]
    if not its:
        return math.nan, math.nan, math.nan, 0
    exact = [it for it in its if it.variance <= 0]
    if exact:
        return float(np.mean([it.estimate for it in exact])), 0.0, 0.0, len(exact) - 1
    w = np.array([1.0 / it.variance for it in its])
    m = np.array([it.estimate for it in its])
    est = float(np.sum(w * m) / np.sum(w))
    chi2 = float(np.sum(w * (m - est) ** 2))
    return est, float(1.0 / np.sum(w)), chi2, len(its) - 1


def chi2_q(chi2: float, dof: int) -> float:
    """Upper-tail probability of chi^2 on ``dof`` degrees of freedom (Wilson-Hilferty cube-root normal)."""
    if dof <= 0 or not math.isfinite(chi2):
        return 1.0
    k = float(dof)
    z = ((chi2 / k) ** (1.0 / 3.0) - (1.0 - 2.0 / (9.0 * k))) / math.sqrt(2.0 / (9.0 * k))
    return 0.5 * math.erfc(z / math.sqrt(2.0))


@dataclass
class VegasOutcome:
    """What :func:`run_vegas` hands back to :func:`mcocl.integrate`."""

    estimate: float
    variance: float
    samples: int
    nonfinite: int
    floor: float
    seconds: float
    stopped_by: str
    devices: list[str]
    lanes: int
    build_seconds: float
    program_note: str
    notes: list[str] = field(default_factory=list)
    summary: dict[str, Any] = field(default_factory=dict)
    samples_this_run: int = -1  # samples computed by this call (a resumed checkpoint's are not)


def _strata_per_axis(strata: int, dim: int) -> int:
    """The largest m with m^dim <= strata, at most MAX_AXIS_CELLS and m^dim <= MAX_STRATA."""
    m = max(int(strata ** (1.0 / dim)), 1)
    while (m + 1) ** dim <= strata:
        m += 1
    while m > 1 and (m**dim > strata or m**dim > MAX_STRATA):
        m -= 1
    return min(m, MAX_AXIS_CELLS)


def _fresh_state(settings: VegasSettings, dim: int, plan: list[int] | None) -> dict[str, Any]:
    return {"plan": plan, "iteration": 0, "offset": 0,
            "grid": VegasGrid.uniform(dim, settings.bins).to_list(), "done": [], "shift": None}


def run_vegas(
    code: EstimatorCode,
    dim: int,
    seed: int,
    opts: RunOptions,
    samples: int | None,
    settings: VegasSettings,
    meta: dict[str, Any],
    progress_label: str,
) -> VegasOutcome:
    """Run (or resume) the iterations of one VEGAS integration (module docstring)."""
    if samples is None and opts.time_budget is None:
        raise InputError("sampler='vegas' sizes its iterations by samples= or time_budget=; give one of them")
    meta = {**meta, "vegas": {**settings.meta(), "samples": samples}}
    if opts.resume is not None:
        acc = Accumulator.load(opts.resume, expect_meta=meta)
        design = design_from_checkpoint(acc.meta.get("design"), opts.resume, ("vegas",))
        state = acc.meta.get("vegas_state")
    else:
        design, plan = settings.plan(dim, samples)
        state = _fresh_state(settings, dim, plan)
        acc = None
    try:
        grid = VegasGrid.from_list(state["grid"])
        done = [Iteration(**d) for d in state["done"]]
    except (KeyError, TypeError, ValueError) as e:  # a damaged or edited checkpoint (issue 10)
        raise InputError(f"checkpoint {opts.resume}: its VEGAS state is damaged ({type(e).__name__}: {e})") from None
    ctx = runtime.device_context(opts.device)
    job = VegasJob(code, dim, design, seed, 1 << 62, opts.lanes, stat_shape=(ROW + dim * settings.bins,),
                   grid_table=grid.device_table(), block_offset=state["offset"])
    runner = job.runner(ctx)
    per_block = 2 * design.units if design.strata_m > 1 else BLOCK_UNITS  # samples per scheduler block
    callback, bar = opts.progress_reporter(progress_label, "samples", per_block)
    t0: float | None = None  # the clock starts after the first pilot launch (its lazy compilation is build time)
    stopped_by, devices = "samples", [ctx.name]
    report_notes: list[str] = []
    partial: Iteration | None = None
    sampled, sampled_seconds = 0, 0.0  # samples and seconds of this run's iterations: the rate
    this_run = 0  # samples evaluated by this call (the reported throughput; a resumed checkpoint's are not)
    while state["iteration"] < settings.iterations:
        k = state["iteration"]
        job = replace(job, grid_table=grid.device_table(), block_offset=state["offset"])
        runner.bind(job)
        if state["shift"] is None:
            t_pilot = time.perf_counter()
            state["shift"] = runner.pilot_shift()
            if sampled_seconds == 0:  # one block: the first, pessimistic (build-laden) measure of the rate
                sampled, sampled_seconds = BLOCK_UNITS, time.perf_counter() - t_pilot
        if t0 is None:
            t0 = time.perf_counter()
        job.shift = state["shift"]
        if acc is None:
            acc = Accumulator(job.stat_shape, {**meta, "design": design.to_dict()})
        acc.meta["vegas_state"] = state
        budget = None if opts.time_budget is None else max(opts.time_budget - (time.perf_counter() - t0), 0.0)
        blocks = None if state["plan"] is None else state["plan"][k]
        if state["plan"] is None:
            # time alone: this iteration's share of the time left, in blocks at the rate measured so far
            share = 1.0 / (settings.iterations - k)
            rate = sampled / sampled_seconds if sampled_seconds > 0 else 0.0
            blocks = max(int(rate * budget * share / BLOCK_UNITS), 1)
        halting = replace(opts.halting(blocks, None), time_budget=budget)
        blocks_before = acc.blocks_done
        samples_before = int(acc.totals[0] + acc.totals[1])
        report = execute(job, acc, halting, opts.placement, progress=callback, runner=runner, ctx=ctx)
        devices = report.devices or devices
        sampled_seconds += report.seconds
        sampled += BLOCK_UNITS * (acc.blocks_done - blocks_before)
        report_notes = list(getattr(report, "notes", []) or [])
        t = acc.totals
        est, var, _ = estimate_from_totals(t[:ROW], design, job.shift)
        now = Iteration(est, var, int(t[0] + t[1]), int(t[1]), rounding_floor(t), k < settings.warmup)
        this_run += now.samples - samples_before
        if acc.blocks_done == 0:
            stopped_by = report.stopped_by
            break
        if report.stopped_by == "interrupt" or (report.stopped_by == "time" and blocks is not None):
            # cut short inside a planned iteration: reported, and resumable from the checkpoint
            stopped_by, partial = report.stopped_by, now
            break
        done.append(now)
        grid = grid.refine(t[ROW:], settings.alpha)
        state = {**state, "iteration": k + 1, "offset": state["offset"] + acc.blocks_done * design.granule_blocks,
                 "grid": grid.to_list(), "done": [it.to_dict() for it in done], "shift": None}
        acc = Accumulator(job.stat_shape, {**meta, "design": design.to_dict(), "vegas_state": state})
        if state["plan"] is None:
            stopped_by = "time"
        if opts.target_error is not None and not now.warmup:
            v = combine([it for it in done if not it.warmup])[1]
            if math.isfinite(v) and math.sqrt(v) <= opts.target_error:
                stopped_by = "stderr"
                break
    if bar is not None:
        bar.close()
    if opts.checkpoint and acc is not None:
        acc.save(opts.checkpoint)
    seconds = time.perf_counter() - t0 if t0 is not None else 0.0
    out = _outcome(done + ([partial] if partial else []), settings, grid, seconds, stopped_by, devices, runner,
                   report_notes)
    out.samples_this_run = this_run
    return out


def _outcome(its: list[Iteration], settings: VegasSettings, grid: VegasGrid, seconds: float, stopped_by: str,
             devices: list[str], runner: VegasRunner, report_notes: list[str]) -> VegasOutcome:
    main = [it for it in its if not it.warmup]
    est, var, chi2, dof = combine(main)
    floor = 0.0
    if main and all(it.variance > 0 for it in main if math.isfinite(it.variance)):
        w = np.array([1.0 / it.variance for it in main if math.isfinite(it.variance)])
        f = np.array([it.floor for it in main if math.isfinite(it.variance)])
        floor = float(math.sqrt(np.sum((w * f) ** 2)) / np.sum(w)) if len(w) else 0.0
    q = chi2_q(chi2, dof)
    notes = list(report_notes)
    notes.append(f"VEGAS: {len(main)} iterations combined after {len(its) - len(main)} warm-up, "
                 f"{settings.bins} bins per dimension, alpha {settings.alpha:g}, chi2/dof "
                 + (f"{chi2 / dof:.3g} (Q = {q:.3g})" if dof > 0 else "n/a (fewer than two iterations)"))
    if dof > 0 and q < CHI2_Q_WARN:
        notes.append(f"WARNING: the VEGAS iterations disagree (chi2/dof = {chi2 / dof:.3g}, Q = {q:.2g}): "
                     "the estimate and its error are not trustworthy; use more samples per iteration "
                     "(fewer vegas_iterations or more samples) or a smaller alpha")
    if not main:
        notes.append("VEGAS: no iteration after the warm-up finished; no estimate (give more samples or time)")
    summary = {
        "iterations": [it.to_dict() for it in its],
        "chi2_dof": chi2 / dof if dof > 0 else None,
        "q": q if dof > 0 else None,
        "bins": settings.bins,
        "alpha": settings.alpha,
        "warmup": settings.warmup,
        "grid_dim": grid.dim,
    }
    return VegasOutcome(
        estimate=est, variance=var, samples=sum(it.samples for it in its),
        nonfinite=sum(it.nonfinite for it in its), floor=floor, seconds=seconds, stopped_by=stopped_by,
        devices=devices, lanes=runner.lanes, build_seconds=runner.build_seconds,
        program_note=runner.program.note or "", notes=notes, summary=summary)

