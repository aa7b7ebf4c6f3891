"""``mcocl devices``: list the OpenCL devices (and, with ``--split N``, their sub-devices)."""

from __future__ import annotations

import argparse

from .. import runtime
from ..errors import DeviceError
from ..pocl_cache import no_device_hint
from .common import print_json, split_count


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``devices`` parser."""
    p = sub.add_parser(
        "devices", help="list OpenCL devices",
        description="List every OpenCL device of every platform, with the index that --device and --devices take. "
                    "With --split N, also show how each device is partitioned into N sub-devices "
                    "(OpenCL device fission), as `--split N` of every other command uses them.",
    )
    p.add_argument("--json", action="store_true", help="print a JSON list")
    p.add_argument("--split", type=split_count, default=None, metavar="N",
                   help="show the N sub-devices each device is split into")
    p.set_defaults(func=run)


def _split_of(info: runtime.DeviceInfo, parts: int) -> dict:
    from ..devices import can_split, sub_device_contexts

    dev = runtime.select_device(info.index)
    entry: dict = {"index": info.index, "name": info.name, "compute_units": info.compute_units, "parts": []}
    if parts < 2:
        entry["note"] = "used whole (split 1)"
        return entry
    if not can_split(dev):
        entry["note"] = "used whole: no device fission (CL_DEVICE_PARTITION_EQUALLY)"
        return entry
    try:
        subs = sub_device_contexts(dev, parts)
    except DeviceError as e:
        entry["note"] = f"used whole: {e}"
        return entry
    entry["parts"] = [
        {"part": s.part, "name": s.name, "compute_units": int(s.device.max_compute_units), "lanes": s.lanes}
        for s in subs
    ]
    notes = []
    unused = info.compute_units - sum(p["compute_units"] for p in entry["parts"])
    if unused:
        notes.append(f"{unused} compute unit(s) left idle (equal parts only)")
    if "PoCL" in info.platform_version:
        # Measured (bench/scaling.py): PoCL 3's pthread driver has one thread
        # pool for all devices, so a part is a separate queue, not separate cores.
        notes.append("PoCL runs the kernels of every part on one shared thread pool: "
                     "the parts are separate queues, not separate cores")
    if notes:
        entry["note"] = "; ".join(notes)
    return entry


def run(args: argparse.Namespace) -> int:
    """List devices, or show their split."""
    devs = runtime.list_devices()
    if not devs:  # the same kind of problem every other command reports with status 2
        raise DeviceError("no OpenCL device found (install an OpenCL driver, e.g. pip install 'mcocl[pocl]')"
                          + no_device_hint())
    if args.split is not None:
        split = [_split_of(d, args.split) for d in devs]
        if args.json:
            print_json(split)
            return 0
        for d, s in zip(devs, split, strict=True):
            print(d.describe())
            for part in s["parts"]:
                print(f"    part {part['part'] + 1}/{args.split}: {part['name']} "
                      f"({part['compute_units']} compute unit(s), {part['lanes']} lanes)")
            if s.get("note"):
                print(f"    {s['note']}")
        return 0
    if args.json:
        print_json([d.__dict__ for d in devs])
        return 0
    for d in devs:
        print(d.describe())
    return 0
