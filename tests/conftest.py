"""Shared test setup: every test runs on the default OpenCL device (PoCL CPU in CI)."""

from __future__ import annotations

import signal
import warnings

import pyopencl as cl
import pytest

# PoCL reports vector-ABI notes as compiler warnings; they are not test failures.
warnings.filterwarnings("ignore", category=cl.CompilerWarning)


def pytest_terminal_summary(terminalreporter, exitstatus, config) -> None:  # noqa: ANN001
    """End the report with the machine the suite ran on: a CI log shows only its tail."""
    import platform

    from mcocl import runtime
    from mcocl.host_simd import cpuinfo_value, host_simd_width

    try:
        d = runtime.device_context(None).device
        line = (f"{d.name.strip()} ({d.platform.version.strip()}), preferred float width "
                f"{d.preferred_vector_width_float}, lanes {runtime.default_lanes(d)}")
    except Exception as e:  # the summary must never hide the tests' own outcome
        line = f"no device ({e})"
    cpu = cpuinfo_value(("model name",)) or platform.processor() or "?"
    terminalreporter.write_line(f"mcocl device: {line}; CPU {cpu}, host SIMD width {host_simd_width()}, "
                                f"Python {platform.python_version()}")


@pytest.fixture(autouse=True)
def _signal_handlers_restored():
    """Each test leaves SIGINT and SIGTERM as it found them: an in-process ``mcocl.cli.main()`` that a
    test stops on request ignores both from then on (as the console script must, issue 10), which
    would otherwise change what later tests in the same worker process see."""
    saved = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    yield
    for s, h in saved.items():
        if signal.getsignal(s) is not h:
            signal.signal(s, h)
