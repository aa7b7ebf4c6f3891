"""mcocl — an OpenCL Monte Carlo engine driven from Python.

OpenCL C kernels do every per-sample computation; Python orchestrates devices,
buffers and progressive accumulation.  Start with :func:`integrate`.
"""

from . import render, rng
from .engine.contract import DeviceFailureWarning
from .errors import ConvergenceError, DeviceError, InputError, KernelBuildError, MCOCLError
from .integration import (
    HeavyTailWarning,
    IntegrationResult,
    NonFiniteWarning,
    Proposal,
    analytic,
    exponential,
    integrate,
    power,
    tabulated,
    tabulated2d,
    truncnorm,
    uniform,
)
from .render import RenderResult
from .runtime import list_devices
from .walks import FredholmResult, solve_fredholm

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
