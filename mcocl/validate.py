"""Checks of user arguments shared by the public APIs; each error names the argument."""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

from .errors import InputError


def whole_number(name: str, v: Any, minimum: int = 1, maximum: int | None = None) -> int:
    """``v`` as an int in [minimum, maximum] (1e6 and 1_000_000.0 accepted), else InputError naming ``name``."""
    bound = f">= {minimum}" + (f" and <= {maximum}" if maximum is not None else "")
    if isinstance(v, bool):
        raise InputError(f"{name} must be an integer {bound}, got {v!r}")
    if isinstance(v, (int, np.integer)):  # exactly, without a detour through float (seeds beyond 2^53)
        i = int(v)
        if i < minimum or (maximum is not None and i > maximum):
            raise InputError(f"{name} must be an integer {bound}, got {v!r}")
        return i
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be an integer {bound}, got {v!r}") from None
    if not math.isfinite(f) or f != int(f) or f < minimum or (maximum is not None and f > maximum):
        raise InputError(f"{name} must be an integer {bound}, got {v!r}")
    return int(f)


def positive_number(name: str, v: Any, what: str = "") -> float:
    """``v`` as a finite float > 0, else InputError naming ``name`` (and what it measures)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        unit = f" ({what})" if what else ""
        raise InputError(f"{name} must be a positive number{unit}, got {v!r}")
    return float(v)


def exact_integer(name: str, v: Any, minimum: int, below: int, below_text: str) -> int:
    """``v`` as an int in [minimum, below), kept exact (a large int is never rounded through a float).

    Integral floats (``7.0``) are accepted, as :func:`whole_number` accepts them;
    ``below_text`` is how the message writes the bound (e.g. ``2**64``).
    """
    message = f"{name} must be an integer in [{minimum}, {below_text}), got {v!r}"
    if isinstance(v, bool):
        raise InputError(message)
    if isinstance(v, float):
        if not (math.isfinite(v) and v == int(v)):
            raise InputError(message)
        v = int(v)
    try:
        n = int(v.__index__())
    except (AttributeError, TypeError):
        raise InputError(message) from None
    if not minimum <= n < below:
        raise InputError(message)
    return n


def file_path(name: str, v: Any) -> str | None:
    """``v`` (a str or path-like, or None) as a str path, else InputError naming ``name``."""
    if v is None:
        return None
    if not isinstance(v, (str, os.PathLike)) or not os.fspath(v):
        raise InputError(f"{name} must be a file path, got {v!r}")
    return str(os.fspath(v))
