"""The one-device loop stays responsive to Ctrl-C while a launch runs (issue 10, mcocl/engine/one_device.py)."""

from __future__ import annotations

import time

import numpy as np
import pyopencl as cl

from mcocl import runtime
from mcocl.engine.contract import InterruptFlag
from mcocl.engine.one_device import wait_unless_urgent

SPIN = """
__kernel void spin(__global float *out, uint n) {
    float s = 0.0f;
    for (uint i = 0; i < n; ++i) s = s * 0.999999f + 1.0f;  /* a dependent chain: n steps of latency */
    out[0] = s;
}
"""


def _spin_launch(ctx: runtime.DeviceContext, n: int) -> tuple[cl.Event, np.ndarray]:
    prog = cl.Program(ctx.context, SPIN).build()
    out = np.zeros(1, np.float32)
    buf = cl.Buffer(ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    prog.spin(ctx.queue, (1,), None, buf, np.uint32(n))
    ev = cl.enqueue_copy(ctx.queue, out, buf, is_blocking=False)
    return ev, out


def test_an_urgent_stop_abandons_a_running_launch_at_once() -> None:
    ctx = runtime.device_context(None)
    ev, out = _spin_launch(ctx, 400_000_000)  # about a second of one core
    flag = InterruptFlag()
    flag.requested = flag.urgent = True
    t0 = time.perf_counter()
    assert wait_unless_urgent((ev, out, 0), flag) is False
    assert time.perf_counter() - t0 < 0.2
    assert ev.command_execution_status != cl.command_execution_status.COMPLETE  # it was still running
    ev.wait()  # leave no launch behind for the next test


def test_a_launch_is_waited_for_when_no_stop_is_urgent() -> None:
    ctx = runtime.device_context(None)
    ev, out = _spin_launch(ctx, 1_000_000)
    flag = InterruptFlag()
    flag.requested = True  # a first request waits for the launch in flight (it is folded)
    assert wait_unless_urgent((ev, out, 0), flag) is True
    assert ev.command_execution_status == cl.command_execution_status.COMPLETE
    assert np.isfinite(out[0]) and out[0] > 0
