"""Arguments and parsing shared by several sub-commands."""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Any


def count(text: str) -> int:
    """A positive count that may be written 1e6, 1_000_000 or 1000000."""
    try:
        v = float(text.replace("_", ""))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number like 1e6, got {text!r}") from None
    if not math.isfinite(v) or v < 1 or v != int(v):
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}")
    return int(v)


def positive(text: str) -> float:
    """A positive float."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(v) or v <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return v


def add_device_args(p: argparse.ArgumentParser) -> None:
    """--device and --lanes."""
    p.add_argument("--device", default=None,
                   help="OpenCL device: index from `mcocl devices` or a name substring (default: PYOPENCL_CTX, else the first device)")
    p.add_argument("--lanes", type=int, choices=(1, 2, 4, 8, 16), default=None,
                   help="samples per vector instruction in the kernel (default: the device's preferred float width; 1 = scalar)")


def print_json(obj: Any) -> None:
    """One JSON object on stdout; NaN and infinities become null (strict JSON)."""

    def clean(v: Any) -> Any:
        if isinstance(v, float) and not math.isfinite(v):
            return None
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        return v

    json.dump(clean(obj), sys.stdout, indent=2)
    sys.stdout.write("\n")
