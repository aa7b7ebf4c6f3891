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


def split_count(text: str) -> int:
    """A number of sub-devices: a whole number >= 1."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number of sub-devices, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}")
    return v


def add_persistence_args(p: argparse.ArgumentParser, job: str, json_help: str = "print one JSON object") -> None:
    """--checkpoint, --resume, --json and --quiet, the same for every long-running command."""
    p.add_argument("--checkpoint", default=None, help="save progress to this file (periodically and at the end)")
    p.add_argument("--resume", default=None, help=f"continue from a checkpoint of the same {job}")
    p.add_argument("--json", action="store_true", help=json_help)
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def add_device_args(p: argparse.ArgumentParser) -> None:
    """--device, --devices, --split, --dask and --lanes (read them back with :func:`placement_kwargs`)."""
    g = p.add_argument_group("devices")
    g.add_argument("--device", default=None,
                   help="OpenCL device: index from `mcocl devices` or a name substring (default: PYOPENCL_CTX, else the first device)")
    g.add_argument("--devices", default=None, metavar="LIST",
                   help="run on several devices at once: 'all', or a comma-separated list of indices/names (e.g. 0,2); "
                        "on devices of one kind the result is bit-identical to a one-device run")
    g.add_argument("--split", type=split_count, default=None, metavar="N",
                   help="partition each CPU device into N sub-devices (OpenCL device fission) and use them as devices; "
                        "`mcocl devices --split N` shows the parts")
    g.add_argument("--dask", default=None, metavar="ADDRESS",
                   help="run the chunks as tasks on a Dask cluster (scheduler address, e.g. tcp://host:8786); "
                        "needs pip install 'mcocl[dask]' here and mcocl on the workers")
    g.add_argument("--lanes", type=int, choices=(1, 2, 4, 8, 16), default=None,
                   help="samples per vector instruction in the kernel (default: the device's preferred float width; 1 = scalar)")


def placement_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """The ``device``, ``devices``, ``split`` and ``client`` keyword arguments of the APIs, from parsed options."""
    return {
        "device": getattr(args, "device", None),
        "devices": getattr(args, "devices", None),
        "split": getattr(args, "split", None),
        "client": getattr(args, "dask", None),
    }


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
