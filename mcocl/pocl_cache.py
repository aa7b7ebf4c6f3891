"""PoCL's kernel cache folder: when it is unusable, say so instead of "failed to compile".

PoCL (the CPU OpenCL driver) writes every program it builds into a cache
folder: ``$POCL_CACHE_DIR``, else ``$XDG_CACHE_HOME/pocl/kcache``, else
``~/.cache/pocl/kcache``.  If that folder cannot be created or written, every
build fails with an empty log, which would read as the user's code failing to
compile.  :func:`cache_problem` names the folder and the reason.
"""

from __future__ import annotations

import os
from pathlib import Path


def cache_folder() -> Path:
    """The folder PoCL caches kernels in (by its documented environment variables)."""
    env = os.environ.get("POCL_CACHE_DIR")
    if env:
        return Path(env)
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg) if xdg else Path.home() / ".cache"
    return base / "pocl" / "kcache"


def cache_problem(platform_name: str) -> str | None:
    """Why PoCL's cache folder is unusable, or None (also None for other OpenCL drivers)."""
    if "portable computing language" not in platform_name.lower() and "pocl" not in platform_name.lower():
        return None
    d = cache_folder()
    source = "POCL_CACHE_DIR" if os.environ.get("POCL_CACHE_DIR") else "PoCL's default"
    anc = d
    while not anc.exists() and anc != anc.parent:
        anc = anc.parent
    if not anc.is_dir():
        return f"PoCL's kernel cache folder {str(d)!r} ({source}) cannot be a folder: {str(anc)!r} is a file"
    if not os.access(anc, os.W_OK | os.X_OK):
        what = "is not writable" if anc == d else f"cannot be created ({str(anc)!r} is not writable)"
        return (f"PoCL's kernel cache folder {str(d)!r} ({source}) {what}; PoCL cannot build any kernel "
                "without it: set POCL_CACHE_DIR to a writable folder")
    return None


def no_device_hint() -> str:
    """A sentence to add to "no OpenCL device found" when PoCL's cache folder is the likelier cause."""
    problem = cache_problem("pocl") if os.environ.get("POCL_CACHE_DIR") else None
    return f" ({problem})" if problem else ""


__all__ = ["cache_folder", "cache_problem", "no_device_hint"]
