"""Exceptions raised by mcocl.

Every error a user can cause derives from :class:`MCOCLError`, so a caller can
catch the engine's complaints without catching its bugs; the command line turns
them into one readable message and a non-zero exit status.  The warnings a run
may emit about its result live here too, so that any module can raise or
filter them without importing another module's API.
"""

from __future__ import annotations


class MCOCLError(Exception):
    """Base class of every error mcocl raises on purpose."""


class InputError(MCOCLError, ValueError):
    """A parameter, file or table given by the user is invalid.

    The message names the offending parameter (or key path) and says what was
    expected.
    """


class KernelBuildError(MCOCLError):
    """OpenCL C code failed to compile.

    Attributes:
        message: the readable summary (the user's offending lines and the
            compiler's messages for them).
        log: the complete compiler log, for the rare case it is needed.
    """

    def __init__(self, message: str, log: str = "") -> None:
        super().__init__(message)
        self.log = log


class DeviceError(MCOCLError):
    """No OpenCL device matches the request, or a device failed."""


class ConvergenceError(MCOCLError):
    """A random walk did not terminate: the Neumann series appears not to converge."""


class PlottingUnavailableError(MCOCLError):
    """Plots were requested but matplotlib is not installed."""


# Warnings: the run finished, but the user should know something about its result.


class NonFiniteWarning(RuntimeWarning):
    """Some samples were NaN or infinite and were left out of the estimate (integration, random walks)."""


class HeavyTailWarning(RuntimeWarning):
    """The variance looks infinite or unresolved, so the standard error is unreliable (mcocl/integration/heavy_tail.py)."""


class NonFiniteSampleWarning(RuntimeWarning):
    """Some path samples were NaN or infinite and were left out of the image (rendering)."""


class SceneSubstitutionWarning(UserWarning):
    """A scene file used something mcocl does not support and ``lenient`` replaced it by a documented substitute.

    The message names the file, line and element, and says what was used
    instead (scenes/README.md, "Mitsuba XML", lists every substitute).
    """
