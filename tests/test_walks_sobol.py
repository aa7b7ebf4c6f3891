"""The walk sampler ``sobol`` (solve_fredholm(..., sampler="sobol"); mcocl/walks/sobol_walks.py).

- Closed-form problems (tests/walk_problems.py) are solved within the reported
  stderr (Šidák over points), with the nee and roulette estimators.
- The stderr, from the spread of the replicate means, is calibrated (rms z
  over 20 seeds) and well below independent sampling's at equal walks on a
  smooth problem.
- Results do not depend on lanes, launch splits or checkpoint and resume;
  replicates sets the blocks; bad values are refused.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats
from walk_problems import CONST1, CONST2, SEP1

from mcocl.accumulate import Accumulator
from mcocl.errors import InputError
from mcocl.walks import api as walks_api
from mcocl.walks.api import solve_fredholm
from mcocl.walks.sobol_walks import sobol_walks_per_block, walk_batches


def solve(p, walks, estimator="nee", seed=1, **kw):
    """solve_fredholm on a problem with the sobol sampler."""
    return solve_fredholm(p.kernel, p.source, dim=p.dim, at=p.at, walks=walks, estimator=estimator, seed=seed,
                          sampler="sobol", **kw)


@pytest.mark.parametrize("p", [SEP1, CONST2], ids=lambda p: p.name)
@pytest.mark.parametrize("estimator", ["nee", "roulette"])
def test_closed_form_within_stderr(p, estimator) -> None:
    r = solve(p, 1 << 16, estimator, seed=5)
    z = (r.values - p.truth()) / r.stderr
    bound = stats.norm.isf((1.0 - (1.0 - 1e-3) ** (1.0 / len(z))) / 2.0)
    assert np.all(np.abs(z) < bound), z
    assert r.walks == 1 << 16 and any("16 independent" in n for n in r.notes)


def test_stderr_is_calibrated_and_smaller_than_independent() -> None:
    zs = []
    for seed in range(20):
        r = solve(CONST1, 1 << 13, seed=seed)
        zs.append((r.values - CONST1.truth()) / r.stderr)
    rms = float(np.sqrt(np.mean(np.square(zs))))
    assert 0.7 < rms < 1.4, rms  # t with 15 dof: 1.07
    ind = solve_fredholm(CONST1.kernel, CONST1.source, at=CONST1.at, walks=1 << 16, seed=3)
    qmc = solve(CONST1, 1 << 16, seed=3)
    assert np.all(qmc.stderr < 0.5 * ind.stderr), (qmc.stderr, ind.stderr)


def test_sobol_walks_do_not_depend_on_lanes_or_split() -> None:
    a = solve(SEP1, 1 << 14, seed=9)
    b = solve(SEP1, 1 << 14, seed=9, lanes=1)
    c = solve(SEP1, 1 << 14, seed=9, split=2)
    np.testing.assert_array_equal(a.values, b.values)
    np.testing.assert_array_equal(a.stderr, b.stderr)
    np.testing.assert_array_equal(a.values, c.values)
    np.testing.assert_array_equal(a.stderr, c.stderr)


def test_replicates_and_batches() -> None:
    assert sobol_walks_per_block(1 << 14, 8, 4096) == 2048
    assert sobol_walks_per_block(1 << 14, None, 4096) == 1024
    assert sobol_walks_per_block(1 << 30, None, 4096) == 4096
    assert sobol_walks_per_block(None, None, 4096) == 4096
    r = solve(SEP1, 1 << 14, replicates=8)
    assert any("8 independent" in n and "2048 walks" in n for n in r.notes)
    s = np.array([[[4.0, 1.0, 2.0, 9.0, 30.0, 0.0]], [[0.0, 2.0, 0.0, 0.0, 5.0, 0.0]]])
    b = walk_batches(s)
    np.testing.assert_array_equal(b[0, 0], [1.0, 1.0, 0.5, 0.25, 30.0, 0.0])
    np.testing.assert_array_equal(b[1, 0], [0.0, 2.0, 0.0, 0.0, 5.0, 0.0])


def test_bad_walk_sampler_is_refused() -> None:
    with pytest.raises(InputError, match="sampler"):
        solve_fredholm(SEP1.kernel, SEP1.source, walks=1000, sampler="halton")
    with pytest.raises(InputError, match="replicates"):
        solve_fredholm(SEP1.kernel, SEP1.source, walks=1000, replicates=8)
    with pytest.raises(InputError, match="replicates"):
        solve_fredholm(SEP1.kernel, SEP1.source, walks=1000, sampler="sobol", replicates=1)


def test_sobol_resume_gives_the_same_bits(tmp_path, monkeypatch) -> None:
    full = solve(SEP1, 1 << 14, seed=2)  # 16 replicates of 1024 walks
    ck = tmp_path / "walks.npz"
    real_execute = walks_api.execute

    def stop_early(job, acc, halting, *a, **kw):
        halting.max_blocks = 5
        return real_execute(job, acc, halting, *a, **kw)

    monkeypatch.setattr(walks_api, "execute", stop_early)
    part = solve(SEP1, 1 << 14, seed=2, checkpoint=str(ck))
    monkeypatch.undo()
    assert part.walks == 5 * 1024 and Accumulator.load(ck).blocks_done == 5
    with pytest.raises(InputError, match="sampler"):  # not resumable as an independent run
        solve_fredholm(SEP1.kernel, SEP1.source, at=SEP1.at, walks=1 << 14, seed=2, resume=str(ck))
    resumed = solve(SEP1, 1 << 14, seed=2, resume=str(ck))
    assert np.array_equal(resumed.values, full.values) and np.array_equal(resumed.stderr, full.stderr)
