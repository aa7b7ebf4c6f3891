"""No silently wrong result, second part (issue 10): overflowing float partial
sums, user densities that are not densities, a wrong row integral, and the
throughput of a resumed run."""

from __future__ import annotations

import mcocl

POLY = "x[0]*x[1] + x[2]"


def test_a_resumed_integration_reports_the_throughput_of_its_own_samples(tmp_path) -> None:
    ckpt = tmp_path / "run.npz"
    total = 1 << 20
    mcocl.integrate(POLY, dim=3, samples=total // 2, seed=5, checkpoint=str(ckpt))
    resumed = mcocl.integrate(POLY, dim=3, samples=total, seed=5, resume=str(ckpt))
    assert resumed.samples == total and resumed.samples_this_run == total // 2
    assert resumed.samples_per_second == (total // 2) / resumed.seconds
    assert resumed.to_dict()["samples_this_run"] == total // 2
    fresh = mcocl.integrate(POLY, dim=3, samples=total // 2, seed=5)
    assert fresh.samples_this_run == fresh.samples


def test_a_resumed_vegas_integration_counts_only_its_own_samples(tmp_path) -> None:
    kw = dict(dim=2, samples=1 << 22, sampler="vegas", seed=3, vegas_iterations=4)
    done = tmp_path / "done.npz"
    first = mcocl.integrate("x[0]*x[1]", checkpoint=str(done), **kw)
    assert first.samples_this_run == first.samples > 0
    again = mcocl.integrate("x[0]*x[1]", resume=str(done), **kw)  # finished: nothing is sampled again
    assert again.samples == first.samples and again.samples_this_run == 0


def test_a_resumed_solve_reports_the_throughput_of_its_own_walks(tmp_path) -> None:
    ckpt = tmp_path / "w.npz"
    kw = dict(dim=1, at=[0.5], seed=2)
    part = mcocl.solve_fredholm("0.5f", "1.0f", walks=1 << 14, checkpoint=str(ckpt), **kw)
    resumed = mcocl.solve_fredholm("0.5f", "1.0f", walks=1 << 15, resume=str(ckpt), **kw)
    assert resumed.walks == 1 << 15 and resumed.walks_this_run == (1 << 15) - part.walks
    assert resumed.walks_per_second == resumed.walks_this_run / resumed.seconds
