"""The command line protects the user's process from the user's code (issue 10).

User snippets run natively: an endless loop never returns from its kernel
launch and a wild write kills the process.  ``mcocl`` therefore runs the
device work in a supervised child (mcocl/cli/supervise.py).  These tests run
the real console entry point in a subprocess, as a user would.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

pytestmark = pytest.mark.skipif(os.name != "posix", reason="process groups and signals are POSIX")


def _mcocl(*args: str, **kw) -> subprocess.Popen:
    env = {k: v for k, v in os.environ.items() if k not in ("MCOCL_SUPERVISE", "MCOCL_HEARTBEAT_FD")}
    return subprocess.Popen([sys.executable, "-m", "mcocl", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=env, **kw)


def test_time_budget_holds_against_an_endless_integrand() -> None:
    t0 = time.monotonic()
    p = _mcocl("integrate", "float s = 0; for (;;) { s += 1; } return s;", "--time", "2")
    out, err = p.communicate(timeout=60)
    took = time.monotonic() - t0
    assert p.returncode == 2, (out, err)
    assert "outlived --time 2" in err and "Traceback" not in err
    # start-up and compilation are not counted by the supervisor, but the
    # whole run still ends within a few seconds of the budget
    assert took < 2 + 12, took


def test_a_crashing_integrand_is_reported_not_a_bare_segfault() -> None:
    p = _mcocl("integrate", "float a[4]; a[(int)(x[0]*1e9f)] = 1.0f; return a[0];", "--samples", "1e6")
    out, err = p.communicate(timeout=60)
    assert p.returncode == 2, (out, err)
    assert "crashed the device process (SIG" in err and "Traceback" not in err


def test_sigterm_stops_like_ctrl_c_and_keeps_the_result(tmp_path) -> None:
    ckpt = tmp_path / "run.ckpt"
    p = _mcocl("integrate", "exp(-x[0]*x[0])", "--samples", "1e14", "--checkpoint", str(ckpt))
    deadline = time.monotonic() + 60
    while not ckpt.exists() and time.monotonic() < deadline and p.poll() is None:
        time.sleep(0.1)  # the first fold is checkpointed at once: sampling has begun
    assert ckpt.exists(), p.communicate(timeout=5)
    p.send_signal(signal.SIGTERM)
    out, err = p.communicate(timeout=60)
    assert p.returncode == 130, (out, err)
    assert "estimate" in out and "interrupt" in (out + err) and "Traceback" not in err
