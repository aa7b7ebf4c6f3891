"""The engine's shared layers: the chunking policy, the fold loop, Ctrl-C, one context per device.

The back ends run on real devices in test_multidevice.py and
test_distributed.py; here the policy and the loop they share are checked
against hand-computed numbers, with jobs and streams that are plain Python.
"""

from __future__ import annotations

import os
import signal
import time

import numpy as np
import pytest

from mcocl.accumulate import Accumulator, RowRanges
from mcocl.engine.chunking import MAX_CHUNK_BYTES, ChunkPolicy, ChunkQueue, Sizer, chunk_block_limit
from mcocl.engine.contract import Halting, InterruptFlag, Progress
from mcocl.engine.fold import FinishedChunk, fold_chunks
from mcocl.engine.one_device import run_one_device
from mcocl.errors import DeviceError
from mcocl.runtime import DeviceContext, device_context, register_context


def _sizer(max_blocks: int | None, takers: int = 1, budget: float | None = None, **policy) -> Sizer:
    return Sizer(ChunkQueue(0, max_blocks), Halting(max_blocks=max_blocks, time_budget=budget),
                 ChunkPolicy(**policy), (4,), takers=takers)


# -- the chunking policy ----------------------------------------------------------


def test_an_unmeasured_taker_doubles_its_chunks_up_to_the_limit():
    s = _sizer(None, first_chunk=3, max_chunk=20)
    assert [s.size(0)[0] for _ in range(5)] == [3, 6, 12, 20, 20]


def test_a_measured_taker_gets_chunk_seconds_of_work():
    s = _sizer(None, chunk_seconds=0.5)
    s.measure(0, 400, 2.0)  # 200 blocks/s
    assert s.size(0) == (100, True)
    s.measure(0, 100, 0.25)  # 400 blocks/s, smoothed half and half: 300
    assert s.takers[0].rate == 300.0 and s.size(0) == (150, True)


def test_the_guided_tail_gives_each_taker_half_its_share_of_what_is_left():
    s = _sizer(1000, takers=2, chunk_seconds=1.0)
    s.chunks.take(900, True, False)  # 100 blocks left
    s.measure(0, 100, 1.0)  # 100 blocks/s: a quarter of the throughput
    s.measure(1, 300, 1.0)  # 300 blocks/s
    assert s.size(0)[0] == 13  # ceil(100 * 1/4 / 2); the floor is 100 // 8 = 12
    assert s.size(1)[0] == 38  # ceil(100 * 3/4 / 2)
    s.drop(1)  # a failed taker has no share: the survivor alone takes the rest
    assert s.size(0)[0] == 100


def test_the_guided_tail_never_goes_under_its_floor():
    s = _sizer(10_000, takers=2, chunk_seconds=1.0)
    s.chunks.take(9_990, True, False)  # 10 blocks left
    s.measure(0, 800, 1.0)
    s.measure(1, 800, 1.0)
    assert s.size(0)[0] == 100  # 800 // 8, not ceil(10 / 4)


def test_alike_workers_split_one_pooled_share():
    s = _sizer(1000, takers=1, chunk_seconds=1.0, tail_floor=10)
    s.chunks.take(600, True, False)  # 400 left
    s.measure(0, 500, 1.0)
    assert s.size(0, alike=4)[0] == 50  # ceil(400 / 4 / 2)
    assert s.size(0, alike=1)[0] == 500  # one worker: no tail (the queue clips the chunk to the 400 left)
    assert s.chunks.take(500, True, False) == (600, 400)


def test_a_time_budget_shortens_chunks_and_then_stops_new_blocks():
    s = _sizer(None, budget=1.0, chunk_seconds=10.0)
    s.measure(0, 100, 1.0)  # 100 blocks/s
    s.start_clock(time.perf_counter() - 0.5)  # half the budget is gone
    n, allow = s.size(0, inflight_blocks=20)  # the blocks in flight take 0.2 s of the 0.5 s left
    assert allow and 20 <= n <= 31  # 31 at once; 51 if the blocks in flight were forgotten
    s.start_clock(time.perf_counter() - 2.0)
    assert s.size(0)[1] is False


def test_a_chunk_holds_at_most_max_chunk_bytes_of_statistics():
    per_block = MAX_CHUNK_BYTES // 8 // 3  # three blocks fit
    assert chunk_block_limit((per_block,)) == 3
    assert chunk_block_limit((per_block,), max_chunk=2) == 2
    assert chunk_block_limit((4 * MAX_CHUNK_BYTES,)) == 1


# -- the fold loop ----------------------------------------------------------------


class ScriptedStream:
    """Delivers given chunks in the given (not block) order, one per call."""

    def __init__(self, script: list[FinishedChunk]) -> None:
        self.script = list(script)
        self.stopped = False
        self.closed: bool | None = None

    exhausted = True

    def start(self, interrupt: InterruptFlag) -> float:
        return time.perf_counter()

    def next(self, interrupt: InterruptFlag) -> FinishedChunk | None:
        return self.script.pop(0) if self.script else None

    def stop(self) -> None:
        self.stopped = True

    def done(self) -> bool:
        return not self.script

    def device_rates(self, elapsed: float) -> tuple[tuple[str, float], ...]:
        return (("a", 1.0), ("b", 2.0))

    def close(self, failed: bool) -> None:
        self.closed = failed


def _blocks(first: int, n: int) -> np.ndarray:
    return np.arange(first, first + n, dtype=np.float64)[:, None] * np.array([1.0, 0.5])


def test_the_fold_loop_folds_out_of_order_chunks_in_block_order(tmp_path):
    ckpt = tmp_path / "run.npz"
    stream = ScriptedStream([FinishedChunk(3, _blocks(3, 4)), FinishedChunk(0, _blocks(0, 3)),
                             FinishedChunk(7, _blocks(7, 1))])
    acc = Accumulator((2,))
    reports: list[Progress] = []
    out = fold_chunks(stream, acc, Halting(max_blocks=8, checkpoint=str(ckpt)), reports.append)
    assert out.stopped_by == "blocks" and stream.stopped and stream.closed is False
    assert [p.blocks_done for p in reports] == [0, 7, 8]  # blocks 3..6 wait for 0..2
    assert reports[-1].device_rates == (("a", 1.0), ("b", 2.0))
    expected = np.zeros(2)
    for b in range(8):  # the reference: one block after the other
        expected = expected + _blocks(b, 1)[0]
    assert np.array_equal(acc.totals, expected)
    assert Accumulator.load(ckpt).blocks_done == 8


def test_a_sparse_fold_gives_the_bits_of_the_dense_one():
    """Blocks that are zero outside one range of rows (sobol's pixel-range blocks) fold into the same bits
    whether given densely or as RowRanges, in chunks or one by one, out of order or not; a wrong shape is refused."""
    rng = np.random.default_rng(3)
    shape, ranges = (6, 5, 3), [(0, 12), (12, 12), (24, 6)]
    blocks = []
    for b in range(9):
        s, n = ranges[b % 3]
        blocks.append((s, n, rng.random((12, 3)) * 10.0 ** rng.integers(-8, 8)))
    dense = np.zeros((9, 30, 3))
    for b, (s, n, v) in enumerate(blocks):
        dense[b, s:s + n] = v[:n]
    one = Accumulator(shape)
    one.add(0, dense.reshape(9, *shape))
    sparse = Accumulator(shape)
    values = np.stack([v for _, _, v in blocks])
    starts, counts = tuple(s for s, _, _ in blocks), tuple(n for _, n, _ in blocks)
    sparse.add(4, RowRanges(values[4:], starts[4:], counts[4:], shape))  # waits for blocks 0..3
    sparse.add(0, RowRanges(values[:4], starts[:4], counts[:4], shape))
    assert sparse.blocks_done == 9
    assert np.array_equal(one.totals.view(np.uint64), sparse.totals.view(np.uint64))
    assert np.array_equal(np.asarray(RowRanges(values, starts, counts, shape)), dense.reshape(9, *shape))
    with pytest.raises(ValueError, match="shape"):
        Accumulator((6, 5, 4)).add(0, RowRanges(values, starts, counts, shape))


def test_the_fold_loop_stops_on_the_target_but_folds_what_is_in_flight():
    stream = ScriptedStream([FinishedChunk(k, _blocks(k, 1)) for k in range(5)])
    acc = Accumulator((2,))
    out = fold_chunks(stream, acc, Halting(target=lambda a: a.blocks_done >= 2))
    assert out.stopped_by == "target" and stream.stopped and acc.blocks_done == 5


def test_the_fold_loop_closes_the_stream_on_a_failure():
    class Failing(ScriptedStream):
        def next(self, interrupt: InterruptFlag) -> FinishedChunk | None:
            raise RuntimeError("device lost")

    stream = Failing([FinishedChunk(0, _blocks(0, 1))])
    with pytest.raises(RuntimeError, match="device lost"):
        fold_chunks(stream, Accumulator((2,)), Halting())
    assert stream.closed is True


# -- one device, with a job that is plain NumPy -----------------------------------------


class CountingRunner:
    def enqueue(self, first_block: int, nblocks: int) -> tuple[int, int]:
        return first_block, nblocks

    def collect(self, handle: tuple[int, int]) -> np.ndarray:
        return _blocks(*handle)


class CountingJob:
    stat_shape = (2,)

    def runner(self, ctx: object) -> CountingRunner:
        return CountingRunner()


class FakeDevice:
    name = "fake device"


def test_one_device_resumes_to_the_same_sums_as_one_run():
    whole = Accumulator((2,))
    report = run_one_device(CountingJob(), whole, Halting(max_blocks=500), FakeDevice(), chunk_seconds=1e-4)
    assert report.stopped_by == "blocks" and report.blocks == 500 and report.chunks > 1
    assert report.per_device[0].blocks == 500
    part = Accumulator((2,))
    run_one_device(CountingJob(), part, Halting(max_blocks=123), FakeDevice(), first_chunk=7)
    run_one_device(CountingJob(), part, Halting(max_blocks=500), FakeDevice())
    assert np.array_equal(part.totals, whole.totals)


def test_ctrl_c_stops_one_device_after_the_chunks_in_flight():
    acc = Accumulator((2,))
    before = signal.getsignal(signal.SIGINT)

    def press_ctrl_c(p: Progress) -> None:
        if p.blocks_done == 1:
            os.kill(os.getpid(), signal.SIGINT)

    report = run_one_device(CountingJob(), acc, Halting(max_blocks=None), FakeDevice(), progress=press_ctrl_c)
    assert report.stopped_by == "interrupt" and report.interrupted
    assert acc.blocks_done == 3 and not acc.pending  # the first chunk (1 block) and the one behind it (2)
    assert signal.getsignal(signal.SIGINT) is before


def test_a_second_request_stops_at_once_and_keeps_what_is_folded(tmp_path):
    """Two SIGTERMs in a row: the loop stops without folding the chunks in
    flight, but returns (and checkpoints) every block folded so far."""
    ckpt = str(tmp_path / "c.ckpt")
    stream = ScriptedStream([FinishedChunk(k, _blocks(k, 1)) for k in range(10)])
    acc = Accumulator((2,))

    def terminate_twice(p: Progress) -> None:
        if p.blocks_done == 3:
            os.kill(os.getpid(), signal.SIGTERM)
            os.kill(os.getpid(), signal.SIGTERM)

    out = fold_chunks(stream, acc, Halting(checkpoint=ckpt), progress=terminate_twice)
    assert out.stopped_by == "interrupt" and acc.blocks_done == 3 and stream.closed is True
    assert Accumulator.load(ckpt).blocks_done == 3
    assert np.array_equal(acc.totals, sum(_blocks(k, 1)[0] for k in range(3)))


def test_stop_requests_escalate_and_sigterm_counts_as_ctrl_c():
    """First request: stop after the blocks in flight; second: stop at once but
    keep what is folded (urgent); third: KeyboardInterrupt.  SIGTERM is a request
    like Ctrl-C, and both handlers are restored afterwards."""
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    with InterruptFlag() as flag:
        os.kill(os.getpid(), signal.SIGTERM)
        assert flag.requested and not flag.urgent
        os.kill(os.getpid(), signal.SIGINT)
        assert flag.urgent
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)
    assert {s: signal.getsignal(s) for s in before} == before


def test_on_the_command_line_requests_after_a_stopped_run_are_still_counted(monkeypatch):
    """With ``linger`` (the command line's setting), a second Ctrl-C or a SIGTERM that arrives after the
    stopped run has returned, while its result is being reported and saved, does not raise: only the
    third request in all does (issue 10: a second request a moment after the first lost the result)."""
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    monkeypatch.setattr(InterruptFlag, "linger", True)
    try:
        with InterruptFlag() as flag:
            os.kill(os.getpid(), signal.SIGINT)
        os.kill(os.getpid(), signal.SIGTERM)  # after the run: counted, not raised, not fatal
        assert flag.urgent
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)
        assert {s: signal.getsignal(s) for s in before} == before
    finally:
        for s, h in before.items():
            signal.signal(s, h)
    with InterruptFlag() as flag:  # a run that was not stopped restores the handlers as it ends
        pass
    assert {s: signal.getsignal(s) for s in before} == before


# -- one context per device ------------------------------------------------------------


def test_a_device_keeps_its_one_registered_context():
    ctx = device_context(None)
    assert register_context(ctx) is ctx  # registering the same context again is harmless
    with pytest.raises(DeviceError, match="already has a context"):
        register_context(DeviceContext(ctx.device))
    assert device_context(ctx.device) is ctx
