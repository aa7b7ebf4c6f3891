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


def pytest_configure(config) -> None:  # noqa: ANN001
    """The suite's own marker (see :func:`_auto_sampler_independent_outside_its_tests`)."""
    config.addinivalue_line("markers", "auto_sampler: renders that leave the sampler to auto get what a user's "
                                       "would (sobol for path/nee/mis at 8 spp or more)")


@pytest.fixture(autouse=True)
def _auto_sampler_independent_outside_its_tests(request, monkeypatch):  # noqa: ANN001
    """In-process renders that leave the pixel sampler to ``auto`` (no ``sampler``, ``batches`` or
    ``spp_per_block``) draw independent samples, except in tests marked ``auto_sampler``.

    Why: every scene-feature set a test renders is a kernel build (about 10 CPU-seconds on a cold
    cache), and the feature tests written before ``auto`` existed would each build a Sobol' variant
    beside the independent one their other renders build: 1,775 CPU-seconds instead of about 1,250 for
    the suite on 2 cores.  What ``auto`` chooses and renders is tested in
    tests/test_render_sampler_auto.py (marked), the Sobol' film in tests/test_render_sobol*.py (explicit),
    and the default as users meet it by every CLI test (a child process, not patched).
    """
    if request.node.get_closest_marker("auto_sampler"):
        return
    from mcocl.render import api

    choose = api.resolve_auto_sampler

    def independent_unless_asked(integrator, spp, spp_per_block, batches, pixels, bounded_by_spp=True):  # noqa: ANN001, ANN202
        if spp_per_block is None and batches is None:
            return "independent", "the test suite's default outside auto_sampler tests (tests/conftest.py)", None
        return choose(integrator, spp, spp_per_block, batches, pixels, bounded_by_spp)

    monkeypatch.setattr(api, "resolve_auto_sampler", independent_unless_asked)


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
