"""Chunks as Dask tasks: same sums as a local run, killed workers, failing workers.

A LocalCluster of two worker processes (one thread each, PoCL limited to one
thread each) stands in for a cluster; the tests skip when dask.distributed
is not installed (it is the optional ``dask`` extra).
"""

from __future__ import annotations

import json
import logging
import os
import signal
import warnings

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")
cloudpickle = pytest.importorskip("cloudpickle")

import device_doubles  # noqa: E402
from device_doubles import FaultyJob, SlowJob, capture_job, small_cornell  # noqa: E402

import mcocl  # noqa: E402
from mcocl.accumulate import Accumulator  # noqa: E402
from mcocl.cli import main as cli_main  # noqa: E402
from mcocl.engine.contract import DeviceFailureWarning, Halting, Placement  # noqa: E402
from mcocl.engine.dask_cluster import compute_chunk, job_fingerprint, run_dask  # noqa: E402
from mcocl.errors import DeviceError, InputError  # noqa: E402
from mcocl.runtime import device_context  # noqa: E402

F3 = "exp(-x[0]*x[0] - 0.5f*x[1]*x[1] - 0.25f*x[2]*x[2])"

# The test doubles live in this test directory, which workers cannot import:
# ship them by value.
cloudpickle.register_pickle_by_value(device_doubles)


@pytest.fixture(scope="module")
def cluster():
    c = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
        silence_logs=logging.CRITICAL, env={"POCL_MAX_PTHREAD_COUNT": "1"},
    )
    yield c
    c.close()


@pytest.fixture
def client(cluster):
    with distributed.Client(cluster) as c:
        c.wait_for_workers(2, timeout=60)
        yield c


def _worker_pids(client) -> dict[str, int]:
    return client.run(os.getpid)


def test_compute_chunk_caches_the_built_job(monkeypatch):
    import pickle

    ref = capture_job(monkeypatch, F3, dim=3, samples=1e6, seed=1)
    payload = pickle.dumps(ref.job)
    fp = job_fingerprint(payload)
    a = compute_chunk(payload, fp, None, 0, 10)
    b = compute_chunk(b"not a pickle: the cached job is used", fp, None, 10, 5)
    assert a.error is None and b.error is None and a.build_seconds >= 0 and b.build_seconds == 0
    acc = Accumulator(ref.shape)
    acc.add(a.first, a.stats)
    acc.add(b.first, b.stats)
    local = Accumulator(ref.shape)
    ctx = device_context(None)
    runner = ref.job.runner(ctx)
    local.add(0, runner.collect(runner.enqueue(0, 15)))
    assert np.array_equal(acc.totals, local.totals)


def test_dask_gives_the_local_sums(client, tmp_path):
    one, two = tmp_path / "one.npz", tmp_path / "two.npz"
    kw = dict(dim=3, samples=4e6, sampler="nrooks", seed=21)
    r1 = mcocl.integrate(F3, checkpoint=str(one), **kw)
    r2 = mcocl.integrate(F3, checkpoint=str(two), client=client, **kw)
    with np.load(one) as a, np.load(two) as b:
        assert np.array_equal(a["totals"], b["totals"])
    assert (r1.estimate, r1.stderr, r1.samples) == (r2.estimate, r2.stderr, r2.samples)


def test_dask_gives_the_local_random_walk_sums(client, tmp_path):
    from walk_problems import SEP1

    one, two = tmp_path / "one.npz", tmp_path / "two.npz"
    kw = dict(dim=SEP1.dim, at=SEP1.at, walks=100_000, estimator="nee", seed=13)
    r1 = mcocl.solve_fredholm(SEP1.kernel, SEP1.source, checkpoint=str(one), **kw)
    r2 = mcocl.solve_fredholm(SEP1.kernel, SEP1.source, checkpoint=str(two), client=client, **kw)
    with np.load(one) as a, np.load(two) as b:
        assert np.array_equal(a["totals"], b["totals"])
    assert np.array_equal(r1.values, r2.values) and np.array_equal(r1.stderr, r2.stderr)


@pytest.mark.parametrize("integrator", ["mis", "lt", "bdpt"])
def test_dask_gives_the_local_film(client, tmp_path, integrator):
    from mcocl.render.api import render

    cs = small_cornell()
    one, two = tmp_path / "one.npz", tmp_path / "two.npz"
    r1 = render(cs, spp=16, seed=8, spp_per_block=2, checkpoint=one, integrator=integrator)
    r2 = render(cs, spp=16, seed=8, spp_per_block=2, checkpoint=two, client=client, integrator=integrator)
    with np.load(one) as a, np.load(two) as b:
        assert np.array_equal(a["totals"], b["totals"])
    assert np.array_equal(r1.mean, r2.mean) and r2.spp == 16


def test_many_small_tasks_and_per_worker_rates(client, monkeypatch):
    ref = capture_job(monkeypatch, F3, dim=3, samples=4e6, seed=22)
    acc = Accumulator(ref.shape)
    rates = []
    report = run_dask(ref.job, acc, Halting(max_blocks=ref.max_blocks), Placement(client=client),
                      max_chunk=40, progress=lambda p: rates.append(p.device_rates))
    assert np.array_equal(acc.totals, ref.totals) and not acc.pending
    assert report.stopped_by == "blocks" and report.chunks >= ref.max_blocks // 40
    assert sum(d.blocks for d in report.per_device) == ref.max_blocks
    assert all(name.startswith("tcp://") for name, _ in rates[-1])


def test_a_failing_worker_loses_no_chunk(client, monkeypatch):
    ref = capture_job(monkeypatch, F3, dim=3, samples=4e6, seed=23)
    addr, pid = sorted(_worker_pids(client).items())[0]
    job = FaultyJob(ref.job, where=pid, stage="collect", after=2)
    acc = Accumulator(ref.shape)
    with pytest.warns(DeviceFailureWarning, match="injected collect failure"):
        report = run_dask(job, acc, Halting(max_blocks=ref.max_blocks), Placement(client=client), max_chunk=40)
    assert np.array_equal(acc.totals, ref.totals) and not acc.pending
    assert len(report.failures) == 1 and report.failures[0].startswith(addr)


def test_no_worker_left_is_a_clear_error(client, monkeypatch):
    ref = capture_job(monkeypatch, F3, dim=3, samples=2e6, seed=24)
    job = FaultyJob(ref.job, where="*", stage="build", error="device")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeviceFailureWarning)
        with pytest.raises(DeviceError, match="no Dask worker left.*injected build failure"):
            run_dask(job, Accumulator(ref.shape), Halting(max_blocks=ref.max_blocks), Placement(client=client))


def test_address_string_cli_and_bad_placements(cluster, capsys):
    args = ["integrate", F3, "--dim", "3", "--samples", "1e6", "--seed", "2", "--json"]
    assert cli_main(args) == 0
    local = json.loads(capsys.readouterr().out)
    assert cli_main([*args, "--dask", cluster.scheduler_address]) == 0
    remote = json.loads(capsys.readouterr().out)
    assert (local["estimate"], local["stderr"]) == (remote["estimate"], remote["stderr"])
    with pytest.raises(InputError, match="devices= and split= apply to local runs"):
        mcocl.integrate(F3, dim=3, samples=1e5, client=cluster.scheduler_address, split=2)


def test_a_worker_killed_mid_job_loses_nothing(client, monkeypatch):
    # Runs last: the nanny restarts the killed worker, but that takes a moment.
    ref = capture_job(monkeypatch, F3, dim=3, samples=8e6, seed=25)
    device = device_context(None).name
    job = SlowJob(ref.job, slow=device, per_block=0.001)  # tasks of ~40 ms, so several are in flight
    victim_addr, victim = sorted(_worker_pids(client).items())[0]
    killed_at = []
    lost_tasks = []

    def kill_once(p):
        if killed_at or p.blocks_done < ref.max_blocks // 5:
            return
        held = client.processing([victim_addr]).get(victim_addr, ())
        if held:  # kill it while it holds tasks (between two tasks it may hold none)
            killed_at.append(p.blocks_done)
            lost_tasks.extend(held)
            os.kill(victim, signal.SIGKILL)

    acc = Accumulator(ref.shape)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeviceFailureWarning)
        report = run_dask(job, acc, Halting(max_blocks=ref.max_blocks), Placement(client=client),
                          max_chunk=40, progress=kill_once)
    assert killed_at and killed_at[0] < ref.max_blocks  # the kill came mid-job
    assert lost_tasks  # ... while the victim held tasks, which Dask had to rerun
    assert np.array_equal(acc.totals, ref.totals) and not acc.pending
    assert report.stopped_by == "blocks"
    assert victim not in _worker_pids(client).values()
