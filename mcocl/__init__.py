"""mcocl — an OpenCL Monte Carlo engine driven from Python.

OpenCL C kernels do every per-sample computation; Python orchestrates devices,
buffers and progressive accumulation.  Start with :func:`integrate`.
"""

import importlib
import os
import signal
import sys
from typing import Any


def _interrupted_at_start(signum: int, frame: object) -> None:
    """Ctrl-C while the ``mcocl`` command is still starting: end quietly (issue 10: no traceback)."""
    sys.stderr.write("mcocl: interrupted\n")
    os._exit(130)


if os.path.basename(sys.argv[0] if sys.argv else "") == "mcocl" and signal.getsignal(signal.SIGINT) is signal.default_int_handler:
    # the console script imports this package before its main() can catch
    # anything; mcocl.cli.main puts Python's own handler back first thing
    signal.signal(signal.SIGINT, _interrupted_at_start)

from .errors import ConvergenceError, DeviceError, InputError, KernelBuildError, MCOCLError  # noqa: E402

# Everything else is imported on first use (PEP 562): ``import mcocl`` stays
# cheap, so the ``mcocl`` command can take Ctrl-C quietly from its first line
# (NumPy, pyopencl and the renderer load only once a command needs them).
_LAZY: dict[str, tuple[str, str | None]] = {
    "render": ("mcocl.render", None),
    "rng": ("mcocl.rng", None),
    "DeviceFailureWarning": ("mcocl.engine.contract", "DeviceFailureWarning"),
    "RenderResult": ("mcocl.render", "RenderResult"),
    "list_devices": ("mcocl.runtime", "list_devices"),
    "FredholmResult": ("mcocl.walks", "FredholmResult"),
    "solve_fredholm": ("mcocl.walks", "solve_fredholm"),
    **{name: ("mcocl.integration", name) for name in (
        "HeavyTailWarning", "IntegrationResult", "NonFiniteWarning", "Proposal", "analytic", "exponential",
        "integrate", "power", "tabulated", "tabulated2d", "truncnorm", "uniform")},
}


def __getattr__(name: str) -> Any:
    """Import a public name of the package the first time it is used."""
    try:
        module, attribute = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module 'mcocl' has no attribute {name!r}") from None
    value = importlib.import_module(module)
    if attribute is not None:
        value = getattr(value, attribute)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


__version__ = "0.1.0"

__all__ = [
    "ConvergenceError",
    "DeviceError",
    "DeviceFailureWarning",
    "FredholmResult",
    "InputError",
    "IntegrationResult",
    "KernelBuildError",
    "MCOCLError",
    "HeavyTailWarning",
    "NonFiniteWarning",
    "Proposal",
    "RenderResult",
    "analytic",
    "exponential",
    "integrate",
    "list_devices",
    "power",
    "render",
    "rng",
    "solve_fredholm",
    "tabulated",
    "tabulated2d",
    "truncnorm",
    "uniform",
]
