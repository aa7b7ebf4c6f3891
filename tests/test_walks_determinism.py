"""A walk's numbers depend on (seed, query point, walk index, step) alone.

So the sums are bit-identical however the blocks are split into launches,
devices or runs (checkpoint and resume), and — because every walk's value is
stored at its own index and added in walk order — whatever the lane width
(given that the scalar and lane forms of the user's code round alike, as
they do for arithmetic; a built-in such as exp may differ in the last bit
between its scalar and vector versions).
"""

from __future__ import annotations

import numpy as np
import pytest
from walk_problems import SEP1, SEP2

import mcocl.walks.api as walks_api
from mcocl import runtime, solve_fredholm
from mcocl.accumulate import Accumulator
from mcocl.errors import InputError
from mcocl.walks.codegen import generate
from mcocl.walks.job import WalkJob
from mcocl.walks.tabulate import build_tables, default_grid

WPB = 4096


def _solve(p, estimator="nee", walks=8 * WPB, **kw):
    return solve_fredholm(p.kernel, p.source, dim=p.dim, at=p.at, walks=walks, estimator=estimator, seed=9, **kw)


@pytest.mark.parametrize("estimator", ["roulette", "nee"])
def test_same_seed_same_bits(estimator):
    a, b = _solve(SEP2, estimator), _solve(SEP2, estimator)
    assert np.array_equal(a.values, b.values) and np.array_equal(a.stderr, b.stderr)
    c = solve_fredholm(SEP2.kernel, SEP2.source, dim=2, at=SEP2.at, walks=8 * WPB, estimator=estimator, seed=10)
    assert not np.array_equal(a.values, c.values)


def _job(lanes=None):
    code = generate(SEP1.kernel, SEP1.source, 1, "subcritical")
    job = WalkJob(code, np.asarray(SEP1.at), seed=4, walk_limit=7 * WPB + 100, lanes=lanes)
    r = job.runner(runtime.device_context())
    g = default_grid(1)
    job.tables = build_tables(r.tabulate_kernel(g), None, g)
    job.shifts = np.array([0.01, 0.25, 0.8])
    return job, r


def _fold(r, chunks):
    acc = Accumulator((3, 6))
    for first, n in chunks:
        acc.add(first, r.collect(r.enqueue(first, n)))
    return acc


def test_sums_do_not_depend_on_how_blocks_are_launched():
    job, r = _job()
    one = _fold(r, [(0, 8)])
    many = _fold(r, [(0, 1), (1, 2), (3, 4), (7, 1)])
    assert np.array_equal(one.totals, many.totals)
    assert one.totals[:, 0].sum() + one.totals[:, 1].sum() == 3 * (7 * WPB + 100)  # the last block is partial


def test_sums_do_not_depend_on_the_lane_width():
    job1, r1 = _job(lanes=1)
    job8, r8 = _job(lanes=8)
    assert r1.lanes == 1 and r8.lanes == 8
    assert np.array_equal(_fold(r1, [(0, 8)]).totals, _fold(r8, [(0, 8)]).totals)


def test_sub_devices_give_the_same_bits():
    a = _solve(SEP1, "nee", walks=16 * WPB)
    b = _solve(SEP1, "nee", walks=16 * WPB, split=2)
    assert np.array_equal(a.values, b.values) and np.array_equal(a.stderr, b.stderr)


def test_checkpoint_and_resume_give_the_same_bits(tmp_path, monkeypatch):
    full = _solve(SEP1, "nee", walks=32 * WPB)
    ck = tmp_path / "walks.npz"
    # stop the first run after a few blocks, as Ctrl-C or a time budget would
    real_execute = walks_api.execute

    def stop_early(job, acc, halting, *a, **kw):
        halting.max_blocks = 5
        return real_execute(job, acc, halting, *a, **kw)

    monkeypatch.setattr(walks_api, "execute", stop_early)
    part = _solve(SEP1, "nee", walks=32 * WPB, checkpoint=str(ck))
    monkeypatch.undo()
    assert part.walks == 5 * WPB
    assert Accumulator.load(ck).blocks_done == 5
    resumed = _solve(SEP1, "nee", walks=32 * WPB, checkpoint=str(ck), resume=str(ck))
    assert resumed.walks == full.walks
    assert np.array_equal(resumed.values, full.values) and np.array_equal(resumed.stderr, full.stderr)
    # a checkpoint of another problem is refused, naming what differs
    with pytest.raises(InputError, match="estimator"):
        _solve(SEP1, "subcritical", walks=32 * WPB, resume=str(ck))


def test_a_time_budget_stops_and_reports_it():
    r = _solve(SEP1, "roulette", walks=10**12, time_budget=0.3)
    assert r.stopped_by == "time"
    assert 0 < r.walks < 10**12 and np.all(np.isfinite(r.values))


def test_resume_asking_fewer_walks_keeps_and_reports_what_the_checkpoint_holds(tmp_path) -> None:
    """A checkpoint of 8 blocks of walks resumed with 2 blocks' worth: the estimate and its counts are the
    checkpoint's (before, it reported 2 blocks of walks over all 8 blocks' sums)."""
    ck = tmp_path / "w.npz"
    full = _solve(SEP1, "nee", walks=8 * WPB, checkpoint=str(ck))
    again = _solve(SEP1, "nee", walks=2 * WPB, resume=str(ck))
    assert again.walks == full.walks == 8 * WPB and again.walks_this_run == 0
    np.testing.assert_array_equal(again.values, full.values)
    np.testing.assert_array_equal(again.stderr, full.stderr)
    assert again.mean_walk_length == full.mean_walk_length
    assert any("already holds" in n for n in again.notes)
