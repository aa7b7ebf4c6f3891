"""mcocl — an OpenCL Monte Carlo engine driven from Python.

OpenCL C kernels do every per-sample computation; Python orchestrates devices,
buffers and progressive accumulation.  Start with :func:`integrate`.
"""

from . import rng
from .errors import ConvergenceError, DeviceError, InputError, KernelBuildError, MCOCLError
from .integration import (
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
from .runtime import list_devices

__version__ = "0.1.0"

__all__ = [
    "ConvergenceError",
    "DeviceError",
    "InputError",
    "IntegrationResult",
    "KernelBuildError",
    "MCOCLError",
    "NonFiniteWarning",
    "Proposal",
    "analytic",
    "exponential",
    "integrate",
    "list_devices",
    "power",
    "rng",
    "tabulated",
    "tabulated2d",
    "truncnorm",
    "uniform",
]
