"""Same seed, same sums: whatever the launch split, work-group size, vector width, or a save/resume."""

from __future__ import annotations

import numpy as np
import pytest

import mcocl
from mcocl import runtime
from mcocl.accumulate import Accumulator
from mcocl.errors import InputError
from mcocl.integration.codegen import generate
from mcocl.integration.job import IntegrationJob
from mcocl.integration.samplers import plan
from mcocl.usercode import UserFunction

# A polynomial: no transcendental built-ins, so the scalar and the vector
# builds compute bit-identical values and only the summation order could differ.
POLY = "x[0]*x[1] + 0.5f*x[2]*x[2] - x[1]"


def _job(sampler: str, samples: int, lanes: int | None = None) -> IntegrationJob:
    f = UserFunction("integrand", POLY, "integrand", (("x", 3),))
    code = generate(f, 3, [], [1], "balance", 2.0, None, None)
    design = plan(sampler, 3, 1, samples, None)
    limit = samples if sampler == "independent" else design.units
    return IntegrationJob(code, 3, design, seed=99, unit_limit=limit, lanes=lanes, shift=0.25)


def _fold(job: IntegrationJob, splits: list[int], ctx: runtime.DeviceContext | None = None) -> np.ndarray:
    ctx = ctx or runtime.device_context()
    runner = job.runner(ctx)
    acc = Accumulator(job.stat_shape)
    first = 0
    handles = []
    for n in splits:
        handles.append((first, runner.enqueue(first, n)))
        first += n
    for f, h in reversed(handles):  # fold out of order on purpose
        acc.add(f, runner.collect(h))
    return acc.totals


@pytest.mark.parametrize("sampler", ["independent", "stratified", "nrooks"])
def test_launch_split_does_not_change_sums(sampler: str) -> None:
    job = _job(sampler, 200_000)
    n = {"independent": 49, "stratified": 1, "nrooks": 16}[sampler]
    whole = _fold(job, [n])
    if n > 1:
        parts = _fold(job, [1, n // 2 - 1, n - n // 2])
        assert np.array_equal(whole, parts)
    if sampler == "stratified":
        # a design is one block; compare two designs computed together or apart
        assert np.array_equal(_fold(job, [2]), _fold(job, [1, 1]))


def test_work_group_size_does_not_change_sums() -> None:
    job = _job("independent", 100_000)
    ctx = runtime.device_context()
    base = _fold(job, [25], ctx)
    old = ctx.group
    try:
        ctx.group = 4
        other = _fold(job, [25], ctx)
    finally:
        ctx.group = old
    assert np.array_equal(base, other)


def test_vector_width_does_not_change_sums() -> None:
    # sums run over 16 virtual lanes whatever the build's LANES
    scalar = _fold(_job("nrooks", 100_000, lanes=1), [16])
    vector = _fold(_job("nrooks", 100_000, lanes=8), [16])
    assert np.array_equal(scalar, vector)


@pytest.mark.parametrize("sampler", ["independent", "stratified", "nrooks"])
def test_checkpoint_and_resume_give_the_uninterrupted_result(sampler: str, tmp_path) -> None:
    ckpt = tmp_path / "run.npz"
    total = 1 << 20
    kw = dict(dim=3, sampler=sampler, seed=5)
    if sampler != "independent":
        kw["design_samples"] = 1 << 16
    full = mcocl.integrate(POLY, samples=total, **kw)
    half = mcocl.integrate(POLY, samples=total // 2, checkpoint=str(ckpt), **kw)
    assert half.samples == total // 2
    resumed = mcocl.integrate(POLY, samples=total, resume=str(ckpt), **kw)
    assert resumed.estimate == full.estimate
    assert resumed.stderr == full.stderr
    assert resumed.samples == full.samples


def test_resume_refuses_a_different_job(tmp_path) -> None:
    ckpt = tmp_path / "run.npz"
    mcocl.integrate(POLY, dim=3, samples=1 << 16, seed=1, checkpoint=str(ckpt))
    with pytest.raises(InputError, match="seed"):
        mcocl.integrate(POLY, dim=3, samples=1 << 17, seed=2, resume=str(ckpt))
    with pytest.raises(InputError, match="integrand"):
        mcocl.integrate("x[0]", dim=3, samples=1 << 17, seed=1, resume=str(ckpt))


def test_resume_after_a_partial_block_names_the_problem(tmp_path) -> None:
    ckpt = tmp_path / "run.npz"
    mcocl.integrate(POLY, dim=3, samples=10_000, seed=1, checkpoint=str(ckpt))
    with pytest.raises(InputError, match="partial block"):
        mcocl.integrate(POLY, dim=3, samples=20_000, seed=1, resume=str(ckpt))
    # resuming with the same sample count is allowed and changes nothing
    a = mcocl.integrate(POLY, dim=3, samples=10_000, seed=1, resume=str(ckpt))
    b = mcocl.integrate(POLY, dim=3, samples=10_000, seed=1)
    assert a.estimate == b.estimate


def test_time_budget_stops_and_reports() -> None:
    from mcocl.engine.one_device import IN_FLIGHT

    folds = []
    r = mcocl.integrate(POLY, dim=3, samples=None, time_budget=0.3, seed=1, progress=folds.append)
    assert r.stopped_by == "time"
    assert 0.2 < r.seconds
    # The run stops promptly, whatever the machine's load: once the budget is spent no chunk is launched,
    # so at most the IN_FLIGHT chunks already enqueued are folded after it, and the run ends with the
    # fold that follows them (a wall-clock bound here flaked on a loaded machine).
    late = [p.elapsed for p in folds if p.elapsed >= 0.3]
    assert 1 <= len(late) <= IN_FLIGHT, [p.elapsed for p in folds]
    assert r.seconds <= late[-1] + 0.25 * (late[-1] - folds[0].elapsed) + 0.05, (r.seconds, late)
    exact = 0.25 + 0.5 / 3 - 0.5
    assert abs(r.estimate - exact) <= 5 * r.stderr


def test_target_error_stops_when_reached() -> None:
    r = mcocl.integrate(POLY, dim=3, samples=10**9, target_error=2e-4, seed=1)
    assert r.stopped_by == "stderr"
    assert r.stderr <= 2e-4
    assert r.samples < 10**9


def test_ctrl_c_keeps_what_was_computed(tmp_path) -> None:
    import json
    import signal
    import subprocess
    import sys
    import time

    ckpt = tmp_path / "run.npz"
    cmd = [sys.executable, "-m", "mcocl", "integrate", POLY, "--dim", "3", "--samples", "1e13", "--seed", "4",
           "--checkpoint", str(ckpt), "--json"]
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while not ckpt.exists() and time.time() < deadline:  # the first checkpoint comes with the first fold
        time.sleep(0.2)
    time.sleep(1.0)
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    d = json.loads(out)
    assert d["stopped_by"] == "interrupt" and d["samples"] > 0
    exact = 0.25 + 0.5 / 3 - 0.5
    assert abs(d["estimate"] - exact) <= 5 * d["stderr"]
    # the checkpoint holds exactly what was reported and can be continued
    more = mcocl.integrate(POLY, dim=3, samples=d["samples"] + (1 << 20), seed=4, resume=str(ckpt))
    assert more.samples == d["samples"] + (1 << 20)


@pytest.mark.parametrize("total", [1 << 20, 1_000_000])
def test_resume_asking_fewer_samples_keeps_and_reports_what_the_checkpoint_holds(total: int, tmp_path) -> None:
    """A checkpoint of ``total`` samples (a partial last block, or none) resumed with a quarter of them:
    the estimate is the checkpoint's, and so are its counts, with a note."""
    ckpt = tmp_path / "run.npz"
    full = mcocl.integrate(POLY, dim=3, samples=total, seed=5, checkpoint=str(ckpt))
    again = mcocl.integrate(POLY, dim=3, samples=total // 4, seed=5, resume=str(ckpt))
    assert again.samples == total and again.samples_this_run == 0
    assert (again.estimate, again.stderr) == (full.estimate, full.stderr)
    assert any(f"already holds {total} samples" in n for n in again.notes)
