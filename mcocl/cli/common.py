"""Arguments and parsing shared by several sub-commands.

The options every job shares are parsed here as plain numbers and checked by
:class:`mcocl.run_options.RunOptions` (through the API each command calls), so
a bad ``--time``, ``--target-error``, ``--seed``, ``--split`` or ``--lanes``
gets the same message as the same bad value given to the Python API.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Any

from ..errors import InputError
from ..render.image_io import EXPOSURE_LIMIT


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


def finite_number(text: str) -> float:
    """Any finite float (an exposure in stops may be negative; NaN and Inf are refused)."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return v



def exposure_stops(text: str) -> float:
    """A PNG exposure in stops: a finite number within +-EXPOSURE_LIMIT."""
    v = finite_number(text)
    if abs(v) > EXPOSURE_LIMIT:
        raise argparse.ArgumentTypeError(f"expected stops between {-EXPOSURE_LIMIT:g} and {EXPOSURE_LIMIT:g}, got {text!r}")
    return v


def file_path(text: str) -> str:
    """A file name given on the command line: never empty (an empty one would read as "not given",
    and an output would then go to its default place unasked)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a file name, got an empty one")
    return text


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
    p.add_argument("--checkpoint", type=file_path, default=None, help="save progress to this file (periodically and at the end)")
    p.add_argument("--resume", type=file_path, default=None, help=f"continue from a checkpoint of the same {job}")
    p.add_argument("--json", action="store_true", help=json_help)
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def add_device_args(p: argparse.ArgumentParser) -> None:
    """--device, --devices, --split, --dask and --lanes (read them back with :func:`run_option_kwargs`)."""
    g = p.add_argument_group("devices")
    g.add_argument("--device", default=None,
                   help="OpenCL device: index from `mcocl devices` or a name substring (default: PYOPENCL_CTX, else the first device)")
    g.add_argument("--devices", default=None, metavar="LIST",
                   help="run on several devices at once: 'all', or a comma-separated list of indices/names (e.g. 0,2); "
                        "on devices of one kind the result is bit-identical to a one-device run")
    g.add_argument("--split", type=int, default=None, metavar="N",
                   help="partition each CPU device into N sub-devices (OpenCL device fission) and use them as devices; "
                        "`mcocl devices --split N` shows the parts")
    g.add_argument("--dask", default=None, metavar="ADDRESS",
                   help="run the chunks as tasks on a Dask cluster (scheduler address, e.g. tcp://host:8786); "
                        "needs pip install 'mcocl[dask]' here and mcocl on the workers")
    g.add_argument("--lanes", type=int, default=None,
                   help="samples per vector instruction in the kernel: 1, 2, 4, 8 or 16 "
                        "(default: the device's preferred float width; 1 = scalar)")


class _DeprecatedFlag(argparse.Action):
    """An old spelling of an option: stores its value aside and says which flag replaces it."""

    def __init__(self, option_strings: list[str], dest: str, new: str = "", **kwargs: Any) -> None:
        super().__init__(option_strings, dest, **kwargs)
        self.new = new

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> None:
        print(f"mcocl: {option_string} is deprecated; use {self.new} instead", file=sys.stderr)
        setattr(namespace, self.dest, (option_string, values))


def add_halting_args(p: argparse.ArgumentParser, target_help: str, deprecated_target: str) -> None:
    """--time and --target-error (and the deprecated spelling ``deprecated_target`` of the latter).

    Read them back with :func:`halting_kwargs`.
    """
    p.add_argument("--time", dest="time_budget", type=float, default=None, metavar="SECONDS",
                   help="stop after this many seconds")
    p.add_argument("--target-error", type=float, default=None, metavar="E", help=target_help)
    p.add_argument(deprecated_target, dest="deprecated_target_error", type=float, default=None,
                   action=_DeprecatedFlag, new="--target-error", help=argparse.SUPPRESS)


def halting_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """The ``time_budget`` and ``target_error`` keyword arguments of the APIs, from parsed options."""
    target = args.target_error
    if args.deprecated_target_error is not None:
        old, value = args.deprecated_target_error
        if target is not None:
            raise InputError(f"give --target-error only ({old} is its deprecated name), not both")
        target = value
    return {"time_budget": args.time_budget, "target_error": target}


def placement_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """The ``device``, ``devices``, ``split`` and ``client`` keyword arguments of the APIs, from parsed options."""
    return {
        "device": getattr(args, "device", None),
        "devices": getattr(args, "devices", None),
        "split": getattr(args, "split", None),
        "client": getattr(args, "dask", None),
    }


def run_option_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """Every option :class:`mcocl.run_options.RunOptions` holds, as the APIs' keyword arguments.

    Halting, placement, seed, lanes, checkpoint, resume and the progress bar
    (shown unless ``--quiet`` or ``--json``).
    """
    return {
        "seed": args.seed,
        **halting_kwargs(args),
        **placement_kwargs(args),
        "lanes": args.lanes,
        "checkpoint": args.checkpoint,
        "resume": args.resume,
        "progress": not args.quiet and not args.json,
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
