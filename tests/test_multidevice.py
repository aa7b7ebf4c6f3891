"""Several devices at once: PoCL sub-devices, bit-identical sums, failures.

The only OpenCL device in CI is one PoCL CPU; OpenCL device fission splits it
into two sub-devices, each a device with its own context and queue, which is
what the multi-device scheduler needs to be exercised for real.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from device_doubles import FaultyJob, SlowJob, capture_job, small_cornell

import mcocl
from mcocl.accumulate import Accumulator
from mcocl.cli import main as cli_main
from mcocl.devices import SubDeviceContext, parse_device_list, resolve_devices, sub_device_contexts
from mcocl.engine.chunking import ChunkQueue
from mcocl.engine.contract import DeviceFailureWarning, Halting, Placement
from mcocl.engine.dispatch import execute
from mcocl.engine.multi_device import run_devices
from mcocl.errors import DeviceError, InputError, KernelBuildError
from mcocl.runtime import device_context

F3 = "exp(-x[0]*x[0] - 0.5f*x[1]*x[1] - 0.25f*x[2]*x[2])"


@pytest.fixture(scope="module")
def subs() -> list[SubDeviceContext]:
    return sub_device_contexts(None, 2)


def _totals(path) -> np.ndarray:
    with np.load(path) as z:
        return z["totals"]


# -- devices -----------------------------------------------------------------


def test_sub_devices_are_cached_named_and_shared_with_the_runtime(subs):
    assert len(subs) == 2
    assert [s.name.endswith(f"[{k + 1}/2]") for k, s in enumerate(subs)] == [True, True]
    assert all(int(s.device.max_compute_units) >= 1 for s in subs)
    assert sub_device_contexts(None, 2)[0] is subs[0]
    # One context per sub-device: the runtime's cache returns the same object.
    assert device_context(subs[0].device) is subs[0]


def test_device_lists_and_split_are_checked():
    assert parse_device_list("all") == "all"
    assert parse_device_list("0, 1") == ["0", "1"]
    assert parse_device_list([0]) == [0]
    assert len(resolve_devices(devices="all").contexts) >= 1
    assert len(resolve_devices(devices=[0], split=2).contexts) == 2
    with pytest.raises(InputError, match="already in the list"):
        resolve_devices(devices=[0, 0])
    with pytest.raises(InputError, match="not both"):
        resolve_devices(device=0, devices=[0])
    with pytest.raises(InputError, match="split"):
        resolve_devices(split=0)
    with pytest.raises(DeviceError, match="split into 1000 sub-devices"):
        resolve_devices(split=1000)
    with pytest.raises(DeviceError, match="no device matches"):
        resolve_devices(devices="no-such-device-xyz")


# -- the chunk queue ------------------------------------------------------------


def test_chunk_queue_hands_given_back_blocks_first_and_stops_at_the_end():
    q = ChunkQueue(0, 10)
    assert q.take(4, True, False) == (0, 4)
    assert q.take(4, True, False) == (4, 4)
    q.give_back(0, 4)
    assert q.take(3, True, False) == (0, 3)  # split to the taker's size
    assert q.take(3, True, False) == (3, 1)
    assert q.take(5, True, False) == (8, 2)  # clipped at max_blocks
    assert q.exhausted and q.drained()
    assert q.take(5, True, False) is None
    q.give_back(4, 4)
    assert not q.drained()
    assert q.take(5, False, False) == (4, 4)  # given-back blocks go out even when new ones may not
    q.finish()
    assert q.take(1, True, True) is None  # a finished queue never blocks


# -- bit identity ---------------------------------------------------------------


@pytest.mark.parametrize("sampler", ["independent", "stratified", "nrooks"])
def test_split_gives_the_sums_of_one_device_bit_for_bit(tmp_path, sampler):
    one, two = tmp_path / "one.npz", tmp_path / "two.npz"
    kw = dict(dim=3, samples=3e6, sampler=sampler, seed=11)
    r1 = mcocl.integrate(F3, checkpoint=str(one), **kw)
    r2 = mcocl.integrate(F3, checkpoint=str(two), split=2, **kw)
    assert np.array_equal(_totals(one), _totals(two))
    assert (r1.estimate, r1.stderr, r1.samples) == (r2.estimate, r2.stderr, r2.samples)


def test_sub_devices_of_another_default_width_build_the_jobs_width(tmp_path, monkeypatch):
    """Devices may report different default widths (a driver reporting 1 on one of them); the job's
    width is fixed by the first build, so the split still gives the one-device sums bit for bit (a
    scalar build of exp rounds differently from the vector one)."""
    import mcocl.devices as devices

    init = devices.SubDeviceContext.__init__

    def narrow(self, *args, **kwargs) -> None:
        init(self, *args, **kwargs)
        self.lanes = 1

    monkeypatch.setattr(devices.SubDeviceContext, "__init__", narrow)
    monkeypatch.setattr(devices, "_subdevices", {})  # fresh sub-devices, made with the narrow width
    one, two = tmp_path / "one.npz", tmp_path / "two.npz"
    kw = dict(dim=3, samples=1e6, seed=13)
    mcocl.integrate(F3, checkpoint=str(one), **kw)
    r2 = mcocl.integrate(F3, checkpoint=str(two), split=2, **kw)
    assert "[2/2]" in r2.device
    assert np.array_equal(_totals(one), _totals(two))


@pytest.mark.parametrize("estimator", ["nee", "roulette"])
def test_split_gives_the_random_walk_sums_of_one_device_bit_for_bit(tmp_path, estimator):
    from walk_problems import SEP2

    one, two = tmp_path / "one.npz", tmp_path / "two.npz"
    kw = dict(dim=SEP2.dim, at=SEP2.at, walks=100_000, estimator=estimator, seed=12)
    r1 = mcocl.solve_fredholm(SEP2.kernel, SEP2.source, checkpoint=str(one), **kw)
    r2 = mcocl.solve_fredholm(SEP2.kernel, SEP2.source, checkpoint=str(two), split=2, **kw)
    assert np.array_equal(_totals(one), _totals(two))
    assert np.array_equal(r1.values, r2.values) and np.array_equal(r1.stderr, r2.stderr)
    assert "[2/2]" in r2.device


def test_split_gives_the_film_of_one_device_bit_for_bit(tmp_path):
    from mcocl.render.api import render

    cs = small_cornell()
    one, two = tmp_path / "one.npz", tmp_path / "two.npz"
    r1 = render(cs, spp=16, seed=7, spp_per_block=2, checkpoint=one)
    r2 = render(cs, spp=16, seed=7, spp_per_block=2, checkpoint=two, split=2)
    assert np.array_equal(_totals(one), _totals(two))
    assert np.array_equal(r1.mean, r2.mean) and np.array_equal(r1.variance, r2.variance)
    assert r2.spp == 16 and "[2/2]" in r2.device


def test_many_small_chunks_on_two_sub_devices_give_the_same_sums(monkeypatch, subs):
    ref = capture_job(monkeypatch, F3, dim=3, samples=4e6, seed=3)
    # Paced by sleeps (1 ms a block on each device) so that both feeders take
    # part however busy the machine is (see test_a_slow_device_gets_fewer_blocks).
    job = SlowJob(SlowJob(ref.job, slow=subs[0].name, per_block=0.001), slow=subs[1].name, per_block=0.001)
    acc = Accumulator(ref.shape)
    rates = []
    report = run_devices(job, acc, Halting(max_blocks=ref.max_blocks), subs, max_chunk=7,
                         progress=lambda p: rates.append(p.device_rates))
    assert acc.blocks_done == ref.blocks and not acc.pending
    assert np.array_equal(acc.totals, ref.totals)
    assert report.stopped_by == "blocks" and report.chunks >= ref.blocks // 7
    assert [d.name for d in report.per_device] == [s.name for s in subs]
    assert sum(d.blocks for d in report.per_device) == ref.blocks
    assert all(d.blocks > 0 for d in report.per_device)  # both devices took part
    assert len(rates[-1]) == 2 and all(r >= 0 for _, r in rates[-1])


def test_a_run_resumed_on_two_sub_devices_gives_the_same_sums(monkeypatch, subs):
    ref = capture_job(monkeypatch, F3, dim=3, samples=2e6, seed=4)
    acc = Accumulator(ref.shape)
    # First part on one device, the rest on two sub-devices: still the same sums.
    execute(ref.job, acc, Halting(max_blocks=ref.max_blocks // 3), Placement())
    execute(ref.job, acc, Halting(max_blocks=ref.max_blocks), Placement(split=2))
    assert np.array_equal(acc.totals, ref.totals)


def test_a_slow_device_gets_fewer_blocks(monkeypatch, subs):
    ref = capture_job(monkeypatch, F3, dim=3, samples=4e6, seed=5)
    # Both devices are paced by sleeps (2,000 and 200 blocks/s), far slower
    # than the kernel itself: the run lasts about half a second whatever the
    # machine's load, so the slow device's feeder always wakes in time to take
    # part. (Unpaced, the fast device finished all blocks in 60 ms, and on a
    # busy CI machine the slow feeder sometimes never got a chunk.)
    paced = SlowJob(ref.job, slow=subs[0].name, per_block=0.0005)
    job = SlowJob(paced, slow=subs[1].name, per_block=0.005)
    acc = Accumulator(ref.shape)
    report = run_devices(job, acc, Halting(max_blocks=ref.max_blocks), subs)
    assert np.array_equal(acc.totals, ref.totals)
    fast, slow = report.per_device
    assert fast.blocks > 3 * slow.blocks > 0


# -- failures -------------------------------------------------------------------


@pytest.mark.parametrize("stage", ["enqueue", "collect", "build"])
def test_a_failing_device_loses_no_chunk(monkeypatch, subs, stage):
    ref = capture_job(monkeypatch, F3, dim=3, samples=4e6, seed=6)
    job = FaultyJob(ref.job, where=subs[0].name, stage=stage, after=3)
    acc = Accumulator(ref.shape)
    with pytest.warns(DeviceFailureWarning, match=r"\[1/2\].*injected"):
        report = run_devices(job, acc, Halting(max_blocks=ref.max_blocks), subs, max_chunk=5)
    assert np.array_equal(acc.totals, ref.totals) and not acc.pending
    assert report.stopped_by == "blocks"
    assert len(report.failures) == 1 and subs[0].name in report.failures[0]
    assert "injected" in report.per_device[0].error and report.per_device[1].error is None


def test_no_device_left_is_a_clear_error_and_keeps_what_was_computed(monkeypatch, subs, tmp_path):
    ref = capture_job(monkeypatch, F3, dim=3, samples=4e6, seed=7)
    job = FaultyJob(ref.job, where="*", stage="collect", after=4)
    acc = Accumulator(ref.shape)
    ckpt = tmp_path / "c.npz"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeviceFailureWarning)
        with pytest.raises(DeviceError, match=r"no device left.*\[1/2\].*injected.*\[2/2\].*injected"):
            run_devices(job, acc, Halting(max_blocks=ref.max_blocks, checkpoint=str(ckpt)), subs, max_chunk=5)
    saved = Accumulator.load(ckpt)
    assert 0 < saved.blocks_done < ref.max_blocks
    # What was folded is the exact prefix of the reference: resuming finishes the job identically.
    run_devices(ref.job, saved, Halting(max_blocks=ref.max_blocks), subs)
    assert np.array_equal(saved.totals, ref.totals)


def test_the_same_engine_error_on_every_device_is_raised_as_is(monkeypatch, subs):
    ref = capture_job(monkeypatch, F3, dim=3, samples=1e6, seed=8)

    class Broken(FaultyJob):
        def runner(self, ctx):
            raise KernelBuildError(f"integrand: line 1: error on {ctx.name}")

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeviceFailureWarning)
        with pytest.raises(KernelBuildError, match="integrand"):
            run_devices(Broken(ref.job, None), Accumulator(ref.shape), Halting(max_blocks=ref.max_blocks), subs)


def test_halting_by_time_and_target_leaves_no_gap(monkeypatch, subs):
    ref = capture_job(monkeypatch, F3, dim=3, samples=2e6, seed=9)
    acc = Accumulator(ref.shape)
    report = run_devices(ref.job, acc, Halting(max_blocks=None, time_budget=0.3), subs)
    assert report.stopped_by == "time" and acc.blocks_done > 0 and not acc.pending
    acc = Accumulator(ref.shape)
    report = run_devices(ref.job, acc, Halting(max_blocks=None, target=lambda a: a.blocks_done >= 50), subs)
    assert report.stopped_by == "target" and acc.blocks_done >= 50 and not acc.pending


# -- command line ---------------------------------------------------------------


def test_cli_split_and_devices(capsys):
    assert cli_main(["devices", "--split", "2"]) == 0
    out = capsys.readouterr().out
    assert "[1/2]" in out and "[2/2]" in out
    args = ["integrate", F3, "--dim", "3", "--samples", "1e6", "--seed", "2", "--json"]
    assert cli_main(args) == 0
    one = capsys.readouterr().out
    assert cli_main([*args, "--split", "2"]) == 0
    two = capsys.readouterr().out
    assert cli_main([*args, "--devices", "all"]) == 0
    every = capsys.readouterr().out
    import json

    e1, e2, e3 = (json.loads(t)["estimate"] for t in (one, two, every))
    assert e1 == e2 == e3
    assert cli_main([*args, "--split", "99"]) == 2
    assert "split into 99 sub-devices" in capsys.readouterr().err
