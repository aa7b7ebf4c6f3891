"""``mcocl.integrate``: Monte Carlo integration over the unit cube on OpenCL."""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from .. import runtime
from ..accumulate import Accumulator
from ..errors import InputError
from ..output_files import check_output_file
from ..progress import ProgressBar
from ..schedule import Halting, Placement, Progress, execute
from ..usercode import UserFunction
from ..validate import positive_number, whole_number
from .codegen import HEURISTICS, generate
from .design import UNBOUNDED_UNITS, Design, design_from_checkpoint, plan, total_granules
from .job import ROW, IntegrationJob, estimate_from_totals, rounding_floor
from .proposals import Proposal

SAMPLERS = ("independent", "stratified", "nrooks")
# Sample counts travel as 64-bit unsigned integers in the kernels; 2^62 leaves room for rounding up.
MAX_SAMPLES = 1 << 62
FLOAT32_MAX = float(np.finfo(np.float32).max)


class NonFiniteWarning(RuntimeWarning):
    """Some samples were NaN or infinite and were left out of the estimate."""


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

    @property
    def samples_per_second(self) -> float:
        """Throughput of the sampling."""
        return self.samples / self.seconds if self.seconds > 0 else math.nan

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
    sampler: str
    seed: int
    proposals: list[Proposal]
    shares: list[int]
    heuristic: str
    beta: float
    control: str | None
    control_integral: float
    roulette: float | None

    def meta(self) -> dict[str, Any]:
        return {
            "kind": "integrate",
            "integrand": self.integrand,
            "dim": self.dim,
            "sampler": self.sampler,
            "seed": self.seed,
            "proposals": [p.spec() for p in self.proposals],
            "shares": self.shares,
            "heuristic": self.heuristic if len(self.proposals) > 1 else None,
            "beta": self.beta if len(self.proposals) > 1 and self.heuristic == "power" else None,
            "control": self.control,
            "roulette": self.roulette,
        }

    def describe(self) -> str:
        parts = [f"{self.sampler} sampling"]
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
    integrand: Any, dim: Any, sampler: Any, seed: Any, proposal: Any, proposals: Any, shares: Any,
    heuristic: Any, beta: Any, control: Any, control_integral: Any, roulette: Any,
) -> _Request:
    if not isinstance(integrand, str) or not integrand.strip():
        raise InputError(f"integrand must be OpenCL C code (an expression or a body that returns), got {integrand!r}")
    dim = whole_number("dim", dim)
    if dim > 64:
        raise InputError(f"dim must be <= 64, got {dim}")
    if sampler not in SAMPLERS:
        raise InputError(f"sampler: unknown sampler {sampler!r}; choose one of {', '.join(SAMPLERS)}")
    seed = whole_number("seed", seed, 0, 2**64 - 1)
    if seed >= 2**64:
        raise InputError(f"seed must be below 2**64, got {seed}")
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
    return _Request(integrand, dim, sampler, seed, props, list(shares), heuristic, float(beta),
                    control, float(control_integral or 0.0), roulette)


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
    target_stderr: float | None = None,
    design_samples: int | None = None,
    device: Any = None,
    devices: Any = None,
    split: int | None = None,
    client: Any = None,
    lanes: int | None = None,
    checkpoint: str | None = None,
    resume: str | None = None,
    progress: bool | Callable[[Progress], None] = False,
) -> IntegrationResult:
    """Estimate the integral of ``integrand`` over the unit cube [0, 1]^dim.

    Args:
        integrand: OpenCL C over ``float x[dim]``: an expression such as
            ``"exp(-x[0]*x[0])"`` or a function body that ``return``s.
        dim: dimension of the cube.
        samples: integrand evaluations (at most; see ``design.py`` for how
            stratified and N-rooks designs round it).  ``None``: no limit,
            give ``time_budget`` or ``target_stderr``.
        sampler: ``independent`` (the secondary estimator), ``stratified``
            (jittered, 2 samples per stratum) or ``nrooks`` (Latin hypercube).
        seed: 64-bit seed; the result depends on nothing else.
        proposal: importance sampling density (see :mod:`mcocl.integration.proposals`).
        proposals: two or more densities for a combined estimator.
        shares: samples of each proposal per unit (default one each).
        heuristic: combined weights: ``average``, ``max``, ``balance``, ``power``.
        beta: exponent of the power heuristic.
        control: control variate g (OpenCL C over ``x``), with ``control_integral`` = its exact integral J.
        roulette: survival probability P of the single-integral Russian roulette.
        time_budget: stop after this many seconds.
        target_stderr: stop once the standard error is at most this.
        design_samples: samples per stratified / N-rooks design (default: see design.py).
        device: device index or name substring (``mcocl devices``).
        devices: several devices (a list of specs, or ``"all"``).
        split: partition each CPU device into this many sub-devices.
        client: a ``dask.distributed`` client (or scheduler address).
        lanes: vector width override (1 forces the scalar kernel).
        checkpoint: save the accumulator to this file periodically and at the end.
        resume: continue from a checkpoint; the job must match.
        progress: True for a progress bar on stderr, or a callback.

    Returns:
        an :class:`IntegrationResult`.

    Raises:
        InputError: invalid arguments (the message names the argument).
        KernelBuildError: the integrand (or a proposal, control) does not compile.
    """
    req = _validate(integrand, dim, sampler, seed, proposal, proposals, shares, heuristic, beta,
                    control, control_integral, roulette)
    if samples is not None:
        samples = whole_number("samples", samples, 1, MAX_SAMPLES)
    if time_budget is not None:
        positive_number("time_budget", time_budget, "seconds")
    if target_stderr is not None:
        positive_number("target_stderr", target_stderr)
    if samples is None and time_budget is None and target_stderr is None:
        raise InputError("samples=None needs time_budget= or target_stderr= to know when to stop")
    if design_samples is not None:
        design_samples = whole_number("design_samples", design_samples, 1, MAX_SAMPLES)

    users = UserFunction("integrand", req.integrand, "integrand", (("x", req.dim),))
    control_fn = UserFunction("control", req.control, "control", (("x", req.dim),)) if req.control else None
    code = generate(users, req.dim, req.proposals, req.shares, req.heuristic, req.beta, control_fn, req.roulette)

    if checkpoint is not None:  # before any work: a run must not end in "cannot write"
        check_output_file(checkpoint, "checkpoint")
    meta = req.meta()
    acc: Accumulator | None = None
    if resume is not None:
        acc = Accumulator.load(resume, expect_meta=meta)
        design = design_from_checkpoint(acc.meta.get("design"), resume)
        shift = acc.meta_float("shift", resume, FLOAT32_MAX)  # a mean of float32 samples
        acc.check_shape((ROW,), resume)
    else:
        design = plan(req.sampler, req.dim, code.points, samples, design_samples)
        shift = None
    max_blocks, unit_limit = total_granules(design, samples)
    if acc is not None and acc.meta.get("partial_tail") and acc.meta_int("unit_limit", resume, 1, UNBOUNDED_UNITS) != unit_limit:
        raise InputError(
            f"checkpoint {resume} ends in a partial block of {design.units_per_block} units; "
            f"resume it with the same samples ({acc.meta.get('unit_limit') * design.samples_per_unit}) "
            "or start runs with a multiple of the block size"
        )

    placement = Placement(device=device, devices=devices, split=split, client=client)
    ctx = runtime.device_context(device)
    job = IntegrationJob(code, req.dim, design, req.seed, unit_limit, lanes)
    runner = job.runner(ctx)
    if shift is None:
        shift = runner.pilot_shift()
    job.shift = shift
    if acc is None:
        acc = Accumulator((job.stat_shape[0],), {**meta, "design": design.to_dict(), "shift": shift})
    notes = [runner.program.note] if runner.program.note else []

    def target(a: Accumulator) -> bool:
        if target_stderr is None:
            return False
        est, var, n = estimate_from_totals(a.totals, design, shift)
        enough = a.blocks_done >= 2 if design.sampler != "independent" else n >= 1000
        return enough and math.isfinite(var) and math.sqrt(var) <= target_stderr

    callback: Callable[[Progress], None] | None = None
    bar: ProgressBar | None = None
    if progress is True:
        per_block = design.units_per_block * design.samples_per_unit * (design.granule_blocks if design.sampler != "independent" else 1)
        bar = ProgressBar(f"integrate [{req.sampler}]", unit="samples", per_block=per_block)
        callback = bar.update
    elif callable(progress):
        callback = progress

    acc.meta["unit_limit"] = unit_limit
    halting = Halting(max_blocks=max_blocks, time_budget=time_budget, target=target if target_stderr else None,
                      checkpoint=checkpoint)
    report = execute(job, acc, halting, placement, progress=callback, runner=runner, ctx=ctx)
    if bar is not None:
        bar.close()
    acc.meta["partial_tail"] = bool(design.sampler == "independent" and acc.blocks_done * design.units_per_block > unit_limit)
    if checkpoint:
        acc.save(checkpoint)

    notes += list(getattr(report, "notes", []) or [])
    est, var, n = estimate_from_totals(acc.totals, design, shift)
    floor = rounding_floor(acc.totals)
    if math.isfinite(var) and floor * floor > 0.5 * var:
        notes.append("the standard error is mostly the float32 rounding floor (see rounding_floor)")
    if req.control:
        est += req.control_integral
    samples_used = _samples_used(acc, design, unit_limit)
    nonfinite = int(acc.totals[1])
    stderr = math.sqrt(var) if var >= 0 else math.nan
    method = {
        "independent": "sample variance of the primary estimates / N",
        "stratified": "sum over strata of (f1 - f2)^2 / (4 H^2), two samples per stratum",
        "nrooks": "spread of the means of independent Latin hypercube designs",
    }[design.sampler]
    if design.sampler == "stratified":
        notes.append(f"{design.strata_m}^{req.dim} strata per design, 2 samples each")
    if design.sampler == "nrooks":
        notes.append(f"Latin hypercube designs of {design.units} points")
    result = IntegrationResult(
        estimate=est,
        stderr=stderr,
        variance=var * samples_used if math.isfinite(var) else math.nan,
        samples=samples_used,
        seconds=report.seconds,
        device=", ".join(report.devices) if report.devices else ctx.name,
        sampler=req.sampler,
        seed=req.seed,
        nonfinite=nonfinite,
        dim=req.dim,
        estimator=req.describe(),
        variance_method=method,
        rounding_floor=floor,
        lanes=runner.lanes,
        designs=int(acc.blocks_done) if design.sampler != "independent" else 0,
        stopped_by={"blocks": "samples", "target": "stderr"}.get(report.stopped_by, report.stopped_by),
        build_seconds=runner.build_seconds,
        notes=notes,
    )
    if nonfinite:
        warnings.warn(
            f"{nonfinite} of {samples_used} samples were NaN or infinite and were left out of the estimate",
            NonFiniteWarning,
            stacklevel=2,
        )
    return result


def _samples_used(acc: Accumulator, design: Design, unit_limit: int) -> int:
    if design.sampler == "independent":
        units = min(acc.blocks_done * design.units_per_block, unit_limit)
    else:
        units = acc.blocks_done * design.units
    return int(units * design.samples_per_unit)
