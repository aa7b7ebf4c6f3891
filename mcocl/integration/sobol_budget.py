"""``sampler="sobol"`` under a time budget: replicates sized from the measured rate (issue 12).

Randomised QMC needs its points in whole 2^M prefixes of each scrambling,
and its error falls like N^-1.5 only when the prefixes grow: R replicates of
2^M points give an error about 2^(-1.5 M) / sqrt(R), so at equal time many
replicates of a fixed size (the error falling like N^-0.5 in their count)
lose to few large ones.  A time budget without a sample count therefore runs

1. a *pilot*: replicates of 2^PILOT_LOG2_POINTS points for PILOT_SHARE of
   the budget, which measures the rate (samples per second) of this
   integrand on these devices, with the engine's own chunks;
2. the *run*: replicates of 2^M until the time left is spent, 2^M the
   largest power of two whose R replicates are predicted to take at most
   BUDGET_MARGIN of it (:meth:`mcocl.integration.samplers.Sobol.budget_log2`),
   so about R to 2R replicates complete.

The estimate and its standard error are the run's alone (k complete
replicates, the spread of their means): the same numbers, bit for bit, as
``samples=k * 2^M * P, replicates=k`` (the same design, kernel and block
order; tests/test_integrate_sobol_budget.py).  The pilot's samples are left
out (different replicates) and counted in ``samples_this_run`` only.  When
the time runs out before max(2, R // 2) replicates of the run complete (the
devices slowed down, or an interrupt), the run is left out and the pilot's
replicates are the result; the notes say which.  A ``target_error`` stops
either part as it stops any run (from two replicates on).  When the measured rate
allows no replicate larger than the pilot's, the pilot run simply goes on.

Which M is chosen depends on the measured rate, so on the machine and its
load, as where a time budget stops any sampler does; the result for a given
M and replicate count depends on the seed alone.  A checkpoint holds the
design that was reported, and a resumed run adds replicates of that size.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field

from ..accumulate import Accumulator
from ..engine.contract import RunReport
from .design import Design
from .job import IntegrationRunner
from .samplers import Sobol


@dataclass
class Sampling:
    """One run of the integration job over one design (what :func:`mcocl.integrate` reports from).

    Attributes:
        design, acc, shift: the design, its accumulator and the shift of its sums.
        runner: the built job (lanes, program notes).
        report: the engine's :class:`~mcocl.engine.contract.RunReport`.
        unit_limit: the unit limit of the last block (``SamplerSpec.granules``).
        blocks_before: blocks a resumed checkpoint already held.
        device: the device's name.
        seconds, build_seconds: sampling and kernel build time, of every run the result took.
        notes: what the plan reports.
        discarded_samples: samples computed and left out of the estimate (a pilot).
    """

    design: Design
    acc: Accumulator
    shift: float
    runner: IntegrationRunner
    report: RunReport
    unit_limit: int
    blocks_before: int
    device: str
    seconds: float
    build_seconds: float
    notes: list[str] = field(default_factory=list)
    discarded_samples: int = 0


# (design, accumulator or None, shift or None, seconds) -> the run of that design for at most those seconds
SampleRun = Callable[[Design, Accumulator | None, float | None, float], Sampling]


def run_sobol_budget(sample: SampleRun, spec: Sobol, like: Design, points: int, replicates: int,
                     budget: float) -> Sampling:
    """The pilot and the run of a time plan (module docstring); ``like`` gives precision and scrambling."""
    pilot_design = spec.budget_design(spec.PILOT_LOG2_POINTS, points, like)
    pilot = sample(pilot_design, None, None, spec.PILOT_SHARE * budget)
    pilot_samples = spec.samples_used(pilot_design, pilot.acc.blocks_done, pilot.unit_limit)
    left = budget - pilot.seconds
    if pilot.report.stopped_by in ("interrupt", "target") or left <= 0 or pilot.seconds <= 0:
        pilot.notes.append(f"time plan: stopped in its pilot (replicates of 2^{spec.PILOT_LOG2_POINTS})")
        return pilot
    rate = pilot_samples / pilot.seconds
    log2 = spec.budget_log2(rate, left, replicates, points)
    plan = (f"time plan: a pilot of {pilot.acc.blocks_done} replicates of 2^{spec.PILOT_LOG2_POINTS} "
            f"({pilot_samples} samples, {pilot.seconds:.3g} s) measured {rate:.3g} samples/s")
    if log2 == spec.PILOT_LOG2_POINTS:
        more = sample(pilot_design, pilot.acc, pilot.shift, left)
        more.seconds += pilot.seconds
        more.build_seconds += pilot.build_seconds
        more.blocks_before = 0
        more.notes.append(plan + f"; no larger replicate fits the {left:.3g} s left, so the pilot went on")
        return more
    run = sample(spec.budget_design(log2, points, like), None, None, left)
    done = run.acc.blocks_done
    need = max(2, replicates // 2)
    run_samples = spec.samples_used(run.design, done, run.unit_limit)
    if done < need and run.report.stopped_by != "target":
        return dataclasses.replace(
            pilot, report=run.report, seconds=pilot.seconds + run.seconds,
            build_seconds=pilot.build_seconds + run.build_seconds, discarded_samples=run_samples,
            notes=[plan + f"; replicates of 2^{log2} were sized for {replicates} in the {left:.3g} s left, "
                   f"but only {done} completed (fewer than {need}): they are left out ({run_samples} samples) "
                   "and the pilot's replicates are the result"])
    run.seconds += pilot.seconds
    run.build_seconds += pilot.build_seconds
    run.discarded_samples = pilot_samples
    run.notes.append(plan + f" (left out of the estimate); replicates of 2^{log2} were sized for {replicates} "
                     f"to fill {spec.BUDGET_MARGIN:.0%} of the {left:.3g} s left, and {done} completed: "
                     f"the numbers of samples={run_samples}, replicates={done}")
    return run
