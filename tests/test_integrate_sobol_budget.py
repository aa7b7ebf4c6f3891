"""sampler="sobol" under a time budget: the replicate size chosen from a measured rate.

mcocl/integration/sobol_budget.py: a pilot measures the rate, then replicates
of the largest 2^M whose R fit the time left run until it is spent.  The
result must be, bit for bit, a ``samples=`` run of the same replicates; the
plan's choices are checked with a stand-in for the engine, where they do not
depend on timing.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

import mcocl
from mcocl.integration.design import Design
from mcocl.integration.samplers import Sobol
from mcocl.integration.sobol_budget import Sampling, run_sobol_budget

SMOOTH = "exp(-(x[0]+x[1]+x[2]))*cos(x[3])"
SMOOTH_EXACT = (1 - math.exp(-1)) ** 3 * math.sin(1)
SPEC = Sobol()


def _replicate_log2(r: mcocl.IntegrationResult) -> int:
    """log2 of the points per replicate of a result (samples = replicates x 2^m)."""
    per = r.samples // r.designs
    assert per * r.designs == r.samples and per & (per - 1) == 0, (r.samples, r.designs)
    return per.bit_length() - 1


def test_time_plan_equals_the_samples_run_of_its_replicates() -> None:
    """The reported numbers are those of samples=k * 2^m, replicates=k (same seed), bit for bit."""
    kw = dict(dim=4, sampler="sobol", seed=11, precision="double")
    timed = mcocl.integrate(SMOOTH, samples=None, time_budget=0.4, **kw)
    assert timed.stopped_by == "time"
    assert any(n.startswith("time plan:") for n in timed.notes), timed.notes
    m = _replicate_log2(timed)
    assert m > SPEC.PILOT_LOG2_POINTS  # a 0.4 s budget affords more than one kernel block per replicate
    fixed = mcocl.integrate(SMOOTH, samples=timed.samples, replicates=timed.designs, **kw)
    assert (fixed.estimate, fixed.stderr, fixed.samples, fixed.designs) == (
        timed.estimate, timed.stderr, timed.samples, timed.designs)
    assert abs(timed.estimate - SMOOTH_EXACT) < 5 * timed.stderr
    assert timed.samples_this_run > timed.samples  # the pilot's samples were computed, not used


def test_replicates_grow_with_the_budget_and_resume_keeps_their_size(tmp_path) -> None:
    """Ten times the time -> larger replicates (the old plan kept 2^18 and added replicates);
    a resumed run adds replicates of the checkpoint's size."""
    kw = dict(dim=4, sampler="sobol", seed=5, replicates=8)
    ckpt = tmp_path / "c.npz"
    short = mcocl.integrate(SMOOTH, samples=None, time_budget=0.15, checkpoint=str(ckpt), **kw)
    long = mcocl.integrate(SMOOTH, samples=None, time_budget=1.5, **kw)
    assert _replicate_log2(long) > _replicate_log2(short)
    m = _replicate_log2(short)
    resumed = mcocl.integrate(SMOOTH, samples=(short.designs + 2) << m, resume=str(ckpt), **kw)
    fresh = mcocl.integrate(SMOOTH, samples=(short.designs + 2) << m,
                            **{**kw, "replicates": short.designs + 2})
    assert (resumed.estimate, resumed.stderr, resumed.samples) == (fresh.estimate, fresh.stderr, fresh.samples)


@pytest.mark.parametrize(("rate", "seconds", "replicates", "expect"), [
    (1e8, 1.0, 16, 22),   # 0.8e8 / 16 = 5e6 -> 2^22
    (1e8, 10.0, 16, 25),  # ten times the time: three levels more
    (1e8, 1.0, 4, 24),    # fewer replicates, larger ones
    (1e3, 1.0, 16, Sobol.PILOT_LOG2_POINTS),  # nothing larger fits: the pilot's size
    (1e12, 1e6, 2, Sobol.MAX_LOG2_POINTS),
    (0.0, 1.0, 16, Sobol.PILOT_LOG2_POINTS),
])
def test_budget_log2(rate: float, seconds: float, replicates: int, expect: int) -> None:
    """The largest 2^M whose R replicates take at most BUDGET_MARGIN of the time, in the allowed range."""
    assert SPEC.budget_log2(rate, seconds, replicates, 1) == expect


class _FakeRuns:
    """A stand-in for the engine: each run completes the replicates its rate allows in its seconds."""

    def __init__(self, rates: list[float], stops: list[str] | None = None) -> None:
        self.rates, self.stops, self.calls = rates, stops or [], []

    def __call__(self, design: Design, acc: object, shift: float | None, seconds: float) -> Sampling:
        i = len(self.calls)
        self.calls.append((design.units, acc is not None, seconds))
        done = int(self.rates[i] * seconds) // design.units + (acc.blocks_done if acc is not None else 0)
        stop = self.stops[i] if i < len(self.stops) else "time"
        return Sampling(design, SimpleNamespace(blocks_done=done), 0.0 if shift is None else shift, None,
                        SimpleNamespace(stopped_by=stop), design.units, 0, "fake", seconds, 1.0)


LIKE = Design("sobol", 1, 1, 0, 1, 0, double=1, scrambling=1)


def test_plan_runs_the_largest_fitting_replicates_after_a_pilot() -> None:
    """After the pilot, 2^M is the largest whose 16 replicates fit 80% of the time left."""
    runs = _FakeRuns([1e8, 1e8])
    out = run_sobol_budget(runs, SPEC, LIKE, 1, 16, 10.0)
    pilot_seconds = SPEC.PILOT_SHARE * 10.0
    assert runs.calls[0] == (1 << SPEC.PILOT_LOG2_POINTS, False, pilot_seconds)
    assert runs.calls[1] == (1 << 25, False, 10.0 - pilot_seconds)  # 16 * 2^25 < 0.8 * 9.5e8 < 16 * 2^26
    assert (out.design.units, out.design.double, out.design.scrambling) == (1 << 25, 1, 1)
    assert 16 <= out.acc.blocks_done < 32
    assert out.seconds == 10.0 and out.build_seconds == 2.0
    assert out.discarded_samples == (int(1e8 * pilot_seconds) >> SPEC.PILOT_LOG2_POINTS) << SPEC.PILOT_LOG2_POINTS


def test_plan_keeps_the_pilot_when_the_run_falls_short() -> None:
    """Fewer than R / 2 complete replicates of the run: the pilot's are reported, and the notes say so."""
    runs = _FakeRuns([1e8, 1e6])  # the devices slow down 100x after the pilot
    out = run_sobol_budget(runs, SPEC, LIKE, 1, 16, 10.0)
    assert out.design.units == 1 << SPEC.PILOT_LOG2_POINTS
    assert out.discarded_samples == 0  # 9.5e6 samples: not one replicate of 2^25 completed
    assert out.seconds == 10.0
    assert "pilot's replicates are the result" in out.notes[-1]


def test_plan_continues_the_pilot_when_nothing_larger_fits() -> None:
    """A slow integrand: the pilot's replicates go on in the same accumulator."""
    runs = _FakeRuns([1e5, 1e5])  # 16 * 2^13 samples need 1.3 s; 0.76 s are left
    out = run_sobol_budget(runs, SPEC, LIKE, 1, 16, 1.0)
    assert [c[:2] for c in runs.calls] == [(1 << 12, False), (1 << 12, True)]  # the same accumulator goes on
    assert "pilot went on" in out.notes[-1]


@pytest.mark.parametrize("stop", ["interrupt", "target"])
def test_plan_stops_in_the_pilot(stop: str) -> None:
    """An interrupt or a reached target error in the pilot ends the run there."""
    runs = _FakeRuns([1e8], [stop])
    out = run_sobol_budget(runs, SPEC, LIKE, 1, 16, 10.0)
    assert len(runs.calls) == 1 and out.report.stopped_by == stop


def test_a_target_error_may_end_the_run_early() -> None:
    """A run stopped by the target error after two replicates is the result, not the pilot."""
    runs = _FakeRuns([1e8, 2.5 * (1 << 25) / 9.5], ["time", "target"])  # two replicates of 2^25 done
    out = run_sobol_budget(runs, SPEC, LIKE, 1, 16, 10.0)
    assert out.design.units == 1 << 25 and out.acc.blocks_done == 2 and out.report.stopped_by == "target"
