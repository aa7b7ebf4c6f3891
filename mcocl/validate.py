"""Checks of user arguments shared by the public APIs; each error names the argument."""

from __future__ import annotations

import math
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
