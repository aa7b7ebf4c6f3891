"""``mcocl devices``: list the OpenCL devices."""

from __future__ import annotations

import argparse

from .. import runtime
from .common import print_json


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``devices`` parser."""
    p = sub.add_parser("devices", help="list OpenCL devices",
                       description="List every OpenCL device of every platform, with the index that --device takes.")
    p.add_argument("--json", action="store_true", help="print a JSON list")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """List devices."""
    devs = runtime.list_devices()
    if args.json:
        print_json([d.__dict__ for d in devs])
        return 0
    if not devs:
        print("no OpenCL devices found")
        return 1
    for d in devs:
        print(d.describe())
    return 0
