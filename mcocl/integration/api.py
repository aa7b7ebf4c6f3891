"""``mcocl.integrate``: Monte Carlo integration over the unit cube on OpenCL."""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from .. import runtime
from ..accumulate import Accumulator
from ..engine.contract import Progress
from ..engine.dispatch import execute
from ..errors import HeavyTailWarning, InputError, NonFiniteWarning
from ..run_options import RunOptions, renamed_keyword
from ..usercode import UserFunction
from ..validate import whole_number
from .codegen import HEURISTICS, EstimatorCode, generate
from .density_check import check_user_densities
from .design import UNBOUNDED_UNITS, Design, design_from_checkpoint
from .heavy_tail import PEAK_KEY, TailWatchingAccumulator, heavy_tail_note
from .job import ROW, IntegrationJob, estimate_from_totals, rounding_floor
from .proposals import Proposal
from .samplers import SAMPLER_SPECS, SamplerSpec, Sobol, Vegas, sampler_spec, spec_of
from .sobol_budget import Sampling, run_sobol_budget
from .vegas import VegasOutcome, VegasSettings, run_vegas

# The registered sampler names, for --help and error messages (mcocl/integration/samplers.py).
SAMPLERS = tuple(SAMPLER_SPECS)
# Sample counts travel as 64-bit unsigned integers in the kernels; 2^62 leaves room for rounding up.
MAX_SAMPLES = 1 << 62
FLOAT32_MAX = float(np.finfo(np.float32).max)
# precision= values: float32 evaluation (the default) or double (Design.double).
PRECISIONS = ("single", "double")


@dataclass
class IntegrationResult:
    """The outcome of :func:`integrate`.

    Attributes:
        estimate: the integral's estimate.
        stderr: its standard error (honest for every sampler: see ``variance_method``).
        variance: variance per sample, ``stderr**2 * samples``: what efficiency
            comparisons divide by.
        samples: integrand evaluations made (``nonfinite`` of them were left out).
        seconds: wall time of the sampling (build excluded).
        device: the device's name.
        sampler, seed: as requested.
        nonfinite: NaN/Inf samples, counted and left out.
        estimator: one-line description of the estimator.
        variance_method: how ``stderr`` was obtained.
        lanes: samples per vector instruction in the kernel that ran.
        designs: complete designs (stratified, nrooks), else 0.
        stopped_by: ``samples``, ``time``, ``stderr`` or ``interrupt``.
        build_seconds: kernel build time (0 when cached).
        rounding_floor: the part of ``stderr`` that stands for float32
            rounding of the integrand (2^-24 times the mean |value|), added in
            quadrature; when it dominates, more samples no longer help.
        notes: anything the user should know (scalar fallback, rounding).
        samples_this_run: samples computed by this call (fewer than ``samples``
            when it resumed a checkpoint; more under a ``sobol`` time plan,
            whose pilot is not in the estimate); ``samples_per_second`` counts these.
        vegas: for ``sampler="vegas"``: the iterations (estimate, variance,
            samples, warm-up or not), ``chi2_dof`` and its tail probability
            ``q``, ``bins``, ``alpha``, ``warmup``; else None.
    """

    estimate: float
    stderr: float
    variance: float
    samples: int
    seconds: float
    device: str
    sampler: str
    seed: int
    nonfinite: int
    dim: int = 0
    estimator: str = ""
    variance_method: str = ""
    lanes: int = 1
    designs: int = 0
    stopped_by: str = "samples"
    build_seconds: float = 0.0
    rounding_floor: float = 0.0
    notes: list[str] = field(default_factory=list)
    vegas: dict[str, Any] | None = None
    samples_this_run: int = -1

    @property
    def samples_per_second(self) -> float:
        """Throughput of the sampling done by this call (a resumed checkpoint's samples are not counted)."""
        n = self.samples if self.samples_this_run < 0 else self.samples_this_run
        return n / self.seconds if self.seconds > 0 else math.nan

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict of every field plus ``samples_per_second``."""
        d = asdict(self)
        d["samples_per_second"] = self.samples_per_second
        return d

    def __str__(self) -> str:
        s = f"{self.estimate:.10g} ± {self.stderr:.3g} ({self.samples} samples, {self.sampler}, {self.seconds:.3g} s)"
        if self.nonfinite:
            s += f" [{self.nonfinite} non-finite samples left out]"
        return s


@dataclass
class _Request:
    integrand: str
    dim: int
    sampler: SamplerSpec
    seed: int
    proposals: list[Proposal]
    shares: list[int]
    heuristic: str
    beta: float
    control: str | None
    control_integral: float
    roulette: float | None
    precision: str = "single"

    def meta(self) -> dict[str, Any]:
        # precision only when not the default, so checkpoints written before it still resume
        extra = {"precision": self.precision} if self.precision != "single" else {}
        return {**extra,
            "kind": "integrate",
            "integrand": self.integrand,
            "dim": self.dim,
            "sampler": self.sampler.name,
            "seed": self.seed,
            "proposals": [p.spec() for p in self.proposals],
            "shares": self.shares,
            "heuristic": self.heuristic if len(self.proposals) > 1 else None,
            "beta": self.beta if len(self.proposals) > 1 and self.heuristic == "power" else None,
            "control": self.control,
            "roulette": self.roulette,
        }

    def describe(self) -> str:
        parts = [f"{self.sampler.name} sampling" + (", evaluated in double" if self.precision == "double" else "")]
        if len(self.proposals) == 1:
            parts.append("importance sampling (" + ", ".join(f["type"] for f in self.proposals[0].spec()) + ")")
        elif self.proposals:
            h = self.heuristic + (f"(beta={self.beta:g})" if self.heuristic == "power" else "")
            parts.append(f"combined estimator of {len(self.proposals)} proposals, shares {self.shares}, {h} weights")
        if self.control:
            parts.append(f"control variate (J={self.control_integral:g})")
        if self.roulette is not None:
            parts.append(f"Russian roulette (P={self.roulette:g})")
        return ", ".join(parts)


def _validate(
    integrand: Any, dim: Any, sampler: Any, seed: int, proposal: Any, proposals: Any, shares: Any,
    heuristic: Any, beta: Any, control: Any, control_integral: Any, roulette: Any,
) -> _Request:
    if not isinstance(integrand, str) or not integrand.strip():
        raise InputError(f"integrand must be OpenCL C code (an expression or a body that returns), got {integrand!r}")
    dim = whole_number("dim", dim)
    if dim > 64:
        raise InputError(f"dim must be <= 64, got {dim}")
    spec = sampler_spec(sampler)
    if proposal is not None and proposals is not None:
        raise InputError("give either proposal= (importance sampling) or proposals= (combined estimator), not both")
    props: list[Proposal] = []
    if proposal is not None:
        props = [Proposal.parse(proposal, dim, "proposal")]
    elif proposals is not None:
        if not isinstance(proposals, Sequence) or isinstance(proposals, str) or len(proposals) < 1:
            raise InputError("proposals must be a list of at least one proposal")
        props = [Proposal.parse(p, dim, f"proposals[{i}]") for i, p in enumerate(proposals)]
    if len(props) > 1:
        if shares is None:
            shares = [1] * len(props)
        if not isinstance(shares, Sequence) or len(shares) != len(props):
            raise InputError(f"shares must list one sample count per proposal ({len(props)}), got {shares!r}")
        shares = [whole_number(f"shares[{i}]", s) for i, s in enumerate(shares)]
        if sum(shares) > 64:
            raise InputError(f"shares add up to {sum(shares)} samples per unit; at most 64 are supported")
        if heuristic not in HEURISTICS:
            raise InputError(f"heuristic: unknown heuristic {heuristic!r}; choose one of {', '.join(HEURISTICS)}")
        try:
            beta = float(beta)
        except (TypeError, ValueError):
            raise InputError(f"beta must be a number > 0, got {beta!r}") from None
        if not (math.isfinite(beta) and beta > 0):
            raise InputError(f"beta must be a number > 0, got {beta!r}")
    else:
        if shares is not None and list(shares) != [1]:
            raise InputError("shares only apply to a combined estimator (two or more proposals)")
        shares = [1] * len(props)
    if (control is None) != (control_integral is None):
        raise InputError("a control variate needs both control= (the function g) and control_integral= (its exact integral J)")
    if control is not None:
        if not isinstance(control, str) or not control.strip():
            raise InputError(f"control must be OpenCL C code, got {control!r}")
        try:
            control_integral = float(control_integral)
        except (TypeError, ValueError):
            raise InputError(f"control_integral must be a number, got {control_integral!r}") from None
        if not math.isfinite(control_integral):
            raise InputError(f"control_integral must be finite, got {control_integral!r}")
    if roulette is not None:
        try:
            roulette = float(roulette)
        except (TypeError, ValueError):
            raise InputError(f"roulette (survival probability P) must be a number in (0, 1], got {roulette!r}") from None
        if not 0 < roulette <= 1:
            raise InputError(f"roulette (survival probability P) must be in (0, 1], got {roulette!r}")
    return _Request(integrand, dim, spec, seed, props, list(shares), heuristic, float(beta),
                    control, float(control_integral or 0.0), roulette)


def _check_precision(precision: Any, req: _Request) -> str:
    """``precision=`` checked against what the request uses (InputError naming the conflict)."""
    if precision not in PRECISIONS:
        raise InputError(f"precision: unknown precision {precision!r}; choose one of {', '.join(PRECISIONS)}")
    if precision == "double":
        if precision not in req.sampler.precisions:
            ok = [n for n, s in SAMPLER_SPECS.items() if "double" in s.precisions]
            raise InputError(f"precision='double' is built for sampler {' and '.join(repr(n) for n in ok)}, "
                             f"not {req.sampler.name!r}")
        if req.proposals or req.roulette is not None:
            raise InputError("precision='double' evaluates the plain estimator (and a control variate); "
                             "it does not take proposal=, proposals= nor roulette=")
    return precision


def _check_scrambling(scrambling: Any, req: _Request) -> int:
    """``scrambling=`` as an index into ``Sobol.SCRAMBLINGS`` (0 when not given); InputError naming the problem."""
    if scrambling is None:
        return 0
    names = Sobol.SCRAMBLINGS
    if scrambling not in names:
        raise InputError(f"scrambling: unknown scrambling {scrambling!r}; choose one of {', '.join(names)}")
    if not isinstance(req.sampler, Sobol):
        raise InputError(f"scrambling: it belongs to sampler='sobol', not {req.sampler.name!r}")
    return names.index(scrambling)


def require_fp64(device: Any) -> None:
    """Refuse ``precision="double"`` on a device without double-precision arithmetic (cl_khr_fp64)."""
    extensions = str(getattr(device, "extensions", "")).split()
    if "cl_khr_fp64" not in extensions:
        name = str(getattr(device, "name", "the device")).strip()
        raise InputError(f"precision='double': device {name!r} has no double-precision arithmetic "
                         "(cl_khr_fp64); use precision='single' or another device")


def integrate(
    integrand: str,
    dim: int = 1,
    samples: int | float | None = 1_000_000,
    *,
    sampler: str = "independent",
    seed: int = 0,
    proposal: Any = None,
    proposals: Sequence[Any] | None = None,
    shares: Sequence[int] | None = None,
    heuristic: str = "balance",
    beta: float = 2.0,
    control: str | None = None,
    control_integral: float | None = None,
    roulette: float | None = None,
    time_budget: float | None = None,
    target_error: float | None = None,
    design_samples: int | None = None,
    replicates: int | None = None,
    scrambling: str | None = None,
    device: Any = None,
    devices: Any = None,
    split: int | None = None,
    client: Any = None,
    lanes: int | None = None,
    checkpoint: str | None = None,
    resume: str | None = None,
    progress: bool | Callable[[Progress], None] = False,
    target_stderr: float | None = None,
    vegas_iterations: int | None = None,
    vegas_bins: int | None = None,
    alpha: float | None = None,
    precision: str = "single",
) -> IntegrationResult:
    """Estimate the integral of ``integrand`` over the unit cube [0, 1]^dim.

    Args:
        integrand: OpenCL C over ``float x[dim]``: an expression such as
            ``"exp(-x[0]*x[0])"`` or a function body that ``return``s.
        dim: dimension of the cube.
        samples: integrand evaluations (at most; see ``samplers.py`` for how
            stratified and N-rooks designs round it).  ``None``: no limit,
            give ``time_budget`` or ``target_error``.
        sampler: ``independent`` (the secondary estimator), ``stratified``
            (jittered, 2 samples per stratum), ``nrooks`` (Latin hypercube) or
            ``sobol`` (Owen-scrambled Sobol' points, randomised quasi-Monte Carlo).
        seed: 64-bit seed; the result depends on nothing else.
        proposal: importance sampling density (see :mod:`mcocl.integration.proposals`).
        proposals: two or more densities for a combined estimator.
        shares: samples of each proposal per unit (default one each).
        heuristic: combined weights: ``average``, ``max``, ``balance``, ``power``.
        beta: exponent of the power heuristic.
        control: control variate g (OpenCL C over ``x``), with ``control_integral`` = its exact integral J.
        roulette: survival probability P of the single-integral Russian roulette.
        time_budget: stop after this many seconds (``sobol`` without ``samples``:
            replicates sized from a measured rate, :mod:`mcocl.integration.sobol_budget`).
        target_error: stop once the standard error is at most this.
        design_samples: samples per stratified / N-rooks design / Sobol' replicate (default: see samplers.py).
        replicates: independent scramblings of a ``sobol`` run (default 16);
            the standard error is their spread, and ``samples`` is rounded
            down to ``replicates`` x 2^m (``Sobol`` in samplers.py).
        scrambling: how a ``sobol`` run scrambles its replicates: ``"hash"``
            (the default: Laine-Karras hashing, Owen's nested scrambling
            approximately) or ``"linear"`` (a random lower-triangular matrix
            and a digital shift, Matoušek's; smaller errors at large N, README
            "Quasi-Monte Carlo").  A resumed run keeps its checkpoint's.
        device: device index or name substring (``mcocl devices``).
        devices: several devices (a list of specs, or ``"all"``).
        split: partition each CPU device into this many sub-devices.
        client: a ``dask.distributed`` client (or scheduler address).
        lanes: vector width override (1 forces the scalar kernel).
        checkpoint: save the accumulator to this file periodically and at the end.
        resume: continue from a checkpoint; the job must match.
        progress: True for a progress bar on stderr, or a callback.
        target_stderr: deprecated name of ``target_error``.
        vegas_iterations, vegas_bins, alpha: ``sampler="vegas"`` only: iterations
            (default 10), grid bins per dimension (a power of two, default 256)
            and the damping exponent of the grid refinement (default 1.5); see
            :class:`mcocl.integration.samplers.Vegas` for how the budget is split.
        precision: ``"single"`` (default): the integrand is evaluated in
            float32, which floors the relative error near 1e-8
            (``rounding_floor``).  ``"double"`` (samplers ``independent`` and
            ``sobol``, no proposals nor roulette; the device needs
            cl_khr_fp64): the uniforms have 32 bits (cell centres of the 2^-32
            grid), the snippets are compiled with ``float`` meaning
            ``double`` and their ``f``-suffixed literals as double constants,
            and the sums are double.  Slower per sample (by the device's
            double rate), for results below float's floor.

    The shared options (seed, time_budget, target_error, placement, lanes,
    checkpoint, resume, progress) are checked by :class:`mcocl.run_options.RunOptions`.

    Returns:
        an :class:`IntegrationResult`.

    Raises:
        InputError: invalid arguments (the message names the argument).
        KernelBuildError: the integrand (or a proposal, control) does not compile.
    """
    target_error = renamed_keyword("integrate", "target_error", target_error, "target_stderr", target_stderr)
    opts = RunOptions(seed=seed, time_budget=time_budget, target_error=target_error, device=device, devices=devices,
                      split=split, client=client, lanes=lanes, checkpoint=checkpoint, resume=resume, progress=progress)
    req = _validate(integrand, dim, sampler, opts.seed, proposal, proposals, shares, heuristic, beta,
                    control, control_integral, roulette)
    req.precision = _check_precision(precision, req)
    real = "double" if req.precision == "double" else "float"
    if samples is not None:
        samples = whole_number("samples", samples, 1, MAX_SAMPLES)
    opts.require_stop("samples", samples)
    if design_samples is not None:
        design_samples = whole_number("design_samples", design_samples, 1, MAX_SAMPLES)
    if replicates is not None:
        replicates = whole_number("replicates", replicates, 1, 1 << 20)
    scramble_index = _check_scrambling(scrambling, req)

    users = UserFunction("integrand", req.integrand, "integrand", (("x", req.dim),), real)
    control_fn = UserFunction("control", req.control, "control", (("x", req.dim),), real) if req.control else None
    code = generate(users, req.dim, req.proposals, req.shares, req.heuristic, req.beta, control_fn, req.roulette,
                    req.precision)
    check_user_densities(req.proposals, code.includes, opts.device)  # a wrong analytic pdf is refused, not used

    meta = req.meta()
    vegas_options = (vegas_iterations, vegas_bins, alpha)
    if isinstance(req.sampler, Vegas):
        req.sampler.plan(req.dim, code.points, samples, design_samples)  # checks what vegas cannot do
        outcome = run_vegas(code, req.dim, req.seed, opts, samples, VegasSettings.parse(*vegas_options),
                            meta, f"integrate [{req.sampler.name}]")
        return _vegas_result(outcome, req)
    if any(v is not None for v in vegas_options):
        raise InputError("vegas_iterations, vegas_bins and alpha apply only to sampler='vegas'")
    acc: Accumulator | None = None
    if opts.resume is not None:
        acc = TailWatchingAccumulator.load(opts.resume, expect_meta=meta)
        if PEAK_KEY in acc.meta:
            acc.meta_float(PEAK_KEY, opts.resume, math.inf)
        design = design_from_checkpoint(acc.meta.get("design"), opts.resume, SAMPLER_SPECS)
        shift = acc.meta_float("shift", opts.resume, FLOAT32_MAX)  # a mean of float32 samples
        acc.check_shape((ROW,), opts.resume)
    else:
        design = req.sampler.plan_replicated(req.dim, code.points, samples, design_samples, replicates)
        if req.precision == "double":
            design = dataclasses.replace(design, double=1)
        if scramble_index:
            design = dataclasses.replace(design, scrambling=scramble_index)
        shift = None
    spec = spec_of(design)
    if (acc is not None and acc.meta.get("partial_tail") and not _holds_more(spec, design, acc, samples)
            and acc.meta_int("unit_limit", opts.resume, 1, UNBOUNDED_UNITS) != spec.granules(design, samples)[1]):
        raise InputError(
            f"checkpoint {opts.resume} ends in a partial block of {spec.units_per_block} units; "
            f"resume it with the same samples ({acc.meta.get('unit_limit') * design.samples_per_unit}) "
            "or start runs with a multiple of the block size"
        )
    label = f"integrate [{req.sampler.name}]"
    if acc is None and samples is None and design_samples is None and opts.time_budget is not None \
            and isinstance(spec, Sobol):
        run = run_sobol_budget(lambda d, a, sh, t: _sample(code, req, opts, meta, d, a, sh, None, t, label),
                               spec, design, code.points, replicates or spec.REPLICATES, opts.time_budget)
    else:
        run = _sample(code, req, opts, meta, design, acc, shift, samples, opts.time_budget, label)
    if opts.checkpoint:
        run.acc.save(opts.checkpoint)
    acc, design, shift, runner, report, unit_limit = run.acc, run.design, run.shift, run.runner, run.report, run.unit_limit
    notes = [runner.program.note] if runner.program.note else []
    notes += list(getattr(report, "notes", []) or [])
    est, var, n = estimate_from_totals(acc.totals, design, shift)
    floor = rounding_floor(acc.totals, design)
    if math.isfinite(var) and floor * floor > 0.5 * var:
        notes.append(f"the standard error is mostly the {'double' if design.double else 'float32'} "
                     "rounding floor (see rounding_floor)")
    if req.control:
        est += req.control_integral
    samples_used = spec.samples_used(design, acc.blocks_done, unit_limit)
    samples_before = spec.samples_used(design, run.blocks_before, unit_limit) if run.blocks_before else 0
    nonfinite = int(acc.totals[1])
    stderr = math.sqrt(var) if var >= 0 else math.nan
    notes += spec.notes(design, req.dim) + run.notes
    tail = heavy_tail_note(acc)
    if tail:
        notes.append(tail)
    result = IntegrationResult(
        estimate=est,
        stderr=stderr,
        variance=var * samples_used if math.isfinite(var) else math.nan,
        samples=samples_used,
        seconds=run.seconds,
        device=", ".join(report.devices) if report.devices else run.device,
        sampler=req.sampler.name,
        seed=req.seed,
        nonfinite=nonfinite,
        dim=req.dim,
        estimator=req.describe(),
        variance_method=spec.variance_method,
        rounding_floor=floor,
        lanes=runner.lanes,
        designs=spec.designs_done(acc.blocks_done),
        stopped_by={"blocks": "samples", "target": "stderr"}.get(report.stopped_by, report.stopped_by),
        build_seconds=run.build_seconds,
        notes=notes,
        samples_this_run=samples_used - samples_before + run.discarded_samples,
    )
    if nonfinite:
        warnings.warn(
            f"{nonfinite} of {samples_used} samples were NaN or infinite and were left out of the estimate",
            NonFiniteWarning,
            stacklevel=2,
        )
    if tail:
        warnings.warn(tail.removeprefix("WARNING: "), HeavyTailWarning, stacklevel=2)
    _report_overflowed_sums(acc.totals, result)
    return result


def _sample(code: EstimatorCode, req: _Request, opts: RunOptions, meta: dict[str, Any], design: Design,
            acc: Accumulator | None, shift: float | None, samples: int | None, time_budget: float | None,
            label: str) -> Sampling:
    """Run the integration job of ``design`` into ``acc`` (a fresh accumulator when None) until
    ``samples``, ``time_budget`` seconds, the target error or an interrupt stops it."""
    spec = spec_of(design)
    max_blocks, unit_limit = spec.granules(design, samples)
    held_notes = []
    if acc is not None and _holds_more(spec, design, acc, samples):
        # A resumed checkpoint already holds more than samples asks for: its samples stay in the estimate
        # (nothing computed is thrown away), so the counts are its own, and nothing is added.
        unit_limit = int(acc.meta["unit_limit"])
        max_blocks = acc.blocks_done
        held_notes.append(f"the checkpoint already holds {spec.samples_used(design, acc.blocks_done, unit_limit)} "
                          f"samples, more than the {samples} asked for: nothing was added")
    ctx = runtime.device_context(opts.device)
    if design.double:
        require_fp64(ctx.device)
    job = IntegrationJob(code, req.dim, design, req.seed, unit_limit, opts.lanes)
    runner = job.runner(ctx)
    if shift is None:
        shift = runner.pilot_shift()
    job.shift = shift
    if acc is None:
        acc = TailWatchingAccumulator((job.stat_shape[0],), {**meta, "design": design.to_dict(), "shift": shift})

    def target(a: Accumulator) -> bool:
        est, var, n = estimate_from_totals(a.totals, design, shift)
        return spec.target_ready(a.blocks_done, n) and math.isfinite(var) and math.sqrt(var) <= opts.target_error

    callback, bar = opts.progress_reporter(label, "samples", spec.samples_per_block(design))
    acc.meta["unit_limit"] = unit_limit
    halting = dataclasses.replace(opts.halting(max_blocks, target if opts.target_error else None),
                                  time_budget=time_budget)
    blocks_before = acc.blocks_done  # a resumed checkpoint's blocks: not this run's throughput
    report = execute(job, acc, halting, opts.placement, progress=callback, runner=runner, ctx=ctx)
    if bar is not None:
        bar.close()
    acc.meta["partial_tail"] = bool(spec.partial_tail(design, acc.blocks_done, unit_limit))
    return Sampling(design, acc, shift, runner, report, unit_limit, blocks_before, ctx.name,
                    report.seconds, runner.build_seconds, held_notes)


def _holds_more(spec: Any, design: Design, acc: Accumulator, samples: int | None) -> bool:
    """Whether a resumed checkpoint's blocks hold more samples than ``samples`` allows."""
    saved = acc.meta.get("unit_limit")
    if samples is None or isinstance(saved, bool) or not isinstance(saved, int) or not 1 <= saved <= UNBOUNDED_UNITS:
        return False
    asked = spec.granules(design, samples)[1]
    return spec.samples_used(design, acc.blocks_done, saved) > spec.samples_used(design, acc.blocks_done, asked)


def _report_overflowed_sums(totals: np.ndarray, result: IntegrationResult) -> None:
    """Say loudly when the sums of the finite samples are not finite.

    The kernel sums finite samples in double (kernels/integrate/integrate.cl,
    FLUSH), so this should not happen; if it does, a NaN must not pass for a
    result (issue 10).
    """
    sums = np.asarray(totals, dtype=np.float64)[[2, 3, 8]]  # sum (v - shift), its square (pairs), sum |v| (job.py)
    if not np.all(np.isfinite(sums)):
        msg = (f"the sums of the {result.samples - result.nonfinite} finite samples are not finite ({sums.tolist()}): "
               f"the estimate ({result.estimate}) is meaningless; scale the integrand down")
        result.notes.append("WARNING: " + msg)
        warnings.warn(msg, NonFiniteWarning, stacklevel=3)


def _vegas_result(out: VegasOutcome, req: _Request) -> IntegrationResult:
    """The :class:`IntegrationResult` of a VEGAS run (mcocl/integration/vegas.py)."""
    var = out.variance
    result = IntegrationResult(
        estimate=out.estimate + (req.control_integral if req.control else 0.0),
        stderr=math.sqrt(var) if var >= 0 else math.nan,
        variance=var * out.samples if math.isfinite(var) else math.nan,
        samples=out.samples, seconds=out.seconds, device=", ".join(out.devices), sampler=req.sampler.name,
        seed=req.seed, nonfinite=out.nonfinite, dim=req.dim, estimator=req.describe(),
        variance_method=req.sampler.variance_method, lanes=out.lanes, designs=0,
        stopped_by={"blocks": "samples", "target": "stderr"}.get(out.stopped_by, out.stopped_by),
        build_seconds=out.build_seconds, rounding_floor=out.floor,
        notes=([out.program_note] if out.program_note else []) + out.notes, vegas=out.summary,
        samples_this_run=out.samples_this_run,
    )
    if out.nonfinite:
        warnings.warn(f"{out.nonfinite} of {out.samples} samples were NaN or infinite and were left out of the estimate",
                      NonFiniteWarning, stacklevel=3)
    return result
