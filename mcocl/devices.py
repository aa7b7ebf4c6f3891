"""Device lists and sub-devices: which devices a multi-device run uses.

A placement names its devices in one of these ways (see
:class:`~mcocl.engine.contract.Placement`):

- ``devices="all"``: every device found; a CPU that two installed PoCL
  platforms both list is the same cores, so it is taken once;
- ``devices=[0, "GPU"]`` or ``"0,2"``: each entry an index from
  ``mcocl devices`` or a name substring (:func:`mcocl.runtime.select_device`);
- ``split=N``: every chosen device that supports OpenCL device fission is
  partitioned into N sub-devices with ``CL_DEVICE_PARTITION_EQUALLY`` (OpenCL
  1.2, section 4.3: *each* part gets the given number of compute units, so N
  parts of a device with C units get C // N units each).  On one PoCL CPU this
  gives N devices, each with its own context and queue, which is how a single
  machine (and CI) runs the multi-device path for real.

  Measured (bench/scaling.py, PoCL 3.0 pthread driver): PoCL keeps one thread
  pool for all its devices, so a sub-device of one compute unit still runs
  its kernels on every core, and N sub-devices together are as fast as the
  whole device, not N times one part.  To give each core its own worker, run
  Dask workers with ``POCL_MAX_PTHREAD_COUNT=1`` (:mod:`mcocl.engine.dask_cluster`).

Sub-devices are cached per (parent, N): creating them again would leak
OpenCL handles, and the build cache in :mod:`mcocl.runtime` is keyed by the
device, so reusing the same objects also reuses their compiled programs.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import pyopencl as cl

from .errors import DeviceError, InputError
from .runtime import DeviceContext, device_context, list_devices, register_context, select_device


class SubDeviceContext(DeviceContext):
    """A :class:`~mcocl.runtime.DeviceContext` of one part of a partitioned device.

    Attributes:
        parent: the partitioned device.
        part: which part (0-based).
        parts: how many parts the device was split into.
    """

    def __init__(self, device: cl.Device, parent: cl.Device, part: int, parts: int) -> None:
        super().__init__(device)
        self.parent = parent
        self.part = part
        self.parts = parts
        self.name = f"{parent.name.strip()} [{part + 1}/{parts}]"

    def __repr__(self) -> str:
        return f"SubDeviceContext({self.name!r}, units={self.device.max_compute_units}, lanes={self.lanes})"


_subdevices: dict[tuple[int, int], list[SubDeviceContext]] = {}
_subdevices_lock = threading.Lock()


def can_split(device: cl.Device) -> bool:
    """True when the device supports ``CL_DEVICE_PARTITION_EQUALLY``."""
    try:
        props = device.partition_properties
    except cl.Error:
        return False
    return cl.device_partition_property.EQUALLY in (props or [])


def sub_device_contexts(device: Any, parts: int) -> list[SubDeviceContext]:
    """Partition ``device`` into ``parts`` equal sub-devices (cached).

    Args:
        device: a device spec (index, name substring, ``pyopencl.Device`` or
            ``DeviceContext``).
        parts: the number of sub-devices, at least 2 and at most the
            device's compute units.

    Raises:
        DeviceError: the device does not support fission, or has fewer
            compute units than ``parts``.
    """
    dev = device.device if isinstance(device, DeviceContext) else select_device(device)
    name = dev.name.strip()
    if parts < 2:
        raise InputError(f"split must be at least 2 to partition a device, got {parts}")
    if not can_split(dev):
        raise DeviceError(f"device {name!r} does not support OpenCL device fission (CL_DEVICE_PARTITION_EQUALLY)")
    units = int(dev.max_compute_units)
    if units < parts:
        raise DeviceError(f"device {name!r} has {units} compute units; it cannot be split into {parts} sub-devices")
    key = (dev.int_ptr, parts)
    with _subdevices_lock:
        got = _subdevices.get(key)
        if got is None:
            try:
                subs = dev.create_sub_devices([cl.device_partition_property.EQUALLY, units // parts])
            except cl.Error as e:
                raise DeviceError(f"device {name!r} could not be split into {parts} sub-devices: {e}") from None
            # C // N units each may allow more than N parts (C=8, N=3 -> 4 parts of 2):
            # the extra parts stay idle, as asked.
            # One context per sub-device, shared with the runtime's cache (see register_context).
            got = [register_context(SubDeviceContext(s, dev, k, parts)) for k, s in enumerate(subs[:parts])]
            _subdevices[key] = got
        return got


def parse_device_list(spec: Any) -> list[Any] | str:
    """Normalise a ``devices`` argument: ``"all"``, or a list of device specs.

    A string other than ``"all"`` is a comma-separated list (``"0,2"``,
    ``"GPU,EPYC"``); a list or tuple is taken as is.

    Raises:
        InputError: the argument is empty or of the wrong type.
    """
    if isinstance(spec, str):
        text = spec.strip()
        if text.lower() == "all":
            return "all"
        items: list[Any] = [t.strip() for t in text.split(",") if t.strip()]
    elif isinstance(spec, (int,)) and not isinstance(spec, bool):
        items = [spec]
    elif isinstance(spec, Sequence):
        items = list(spec)
    else:
        raise InputError(f"devices must be 'all', an index, a name or a list of them, got {spec!r}")
    if not items:
        raise InputError(f"devices: empty device list {spec!r}")
    return items


def _chosen_devices(devices: Any, device: Any) -> list[cl.Device]:
    if devices is None:
        return [select_device(device)]
    if device is not None:
        raise InputError("give either device= (one device) or devices= (several), not both")
    parsed = parse_device_list(devices)
    if parsed == "all":
        out: list[cl.Device] = []
        seen_cpus: set[str] = set()
        for info in list_devices():
            d = select_device(info.index)
            if d.type & cl.device_type.CPU:
                # Two PoCL platforms (wheel and distribution) list the same CPU.
                if info.name in seen_cpus:
                    continue
                seen_cpus.add(info.name)
            out.append(d)
        if not out:
            raise DeviceError("devices='all': no OpenCL device found")
        return out
    out = []
    for item in parsed:
        d = select_device(item)
        if any(d.int_ptr == o.int_ptr for o in out):
            raise InputError(f"devices: {item!r} names a device that is already in the list ({d.name.strip()})")
        out.append(d)
    return out


def _check_split(split: Any) -> int:
    if split is None:
        return 1
    if isinstance(split, bool) or not isinstance(split, (int, float)) or split != int(split) or split < 1:
        raise InputError(f"split must be a whole number >= 1, got {split!r}")
    return int(split)


@dataclass
class DeviceChoice:
    """The devices of a placement, and what was not split (with why)."""

    contexts: list[DeviceContext]
    notes: list[str]


def resolve_devices(device: Any = None, devices: Any = None, split: Any = None) -> DeviceChoice:
    """The device contexts a placement runs on.

    Args:
        device: one device spec (used when ``devices`` is None).
        devices: ``"all"``, a comma-separated string or a list of specs.
        split: partition each device that supports fission into this many parts.

    Raises:
        InputError: contradictory or malformed arguments.
        DeviceError: a device does not exist, or ``split`` could be applied
            to none of the chosen devices.
    """
    parts = _check_split(split)
    chosen = _chosen_devices(devices, device)
    contexts: list[DeviceContext] = []
    notes: list[str] = []
    for d in chosen:
        if parts > 1 and can_split(d) and d.max_compute_units >= parts:
            contexts.extend(sub_device_contexts(d, parts))
            if "pocl" in d.platform.version.lower():
                notes.append(f"{d.name.strip()}: PoCL runs every sub-device on one shared thread pool, "
                             "so --split adds queues, not cores (see mcocl devices --split)")
        else:
            if parts > 1:
                why = "no device fission" if not can_split(d) else f"only {d.max_compute_units} compute units"
                notes.append(f"{d.name.strip()} is used whole ({why})")
            contexts.append(device_context(d))
    if parts > 1 and not any(isinstance(c, SubDeviceContext) for c in contexts):
        raise DeviceError(f"split={parts}: no chosen device can be split into {parts} sub-devices ({'; '.join(notes)})")
    return DeviceChoice(contexts, notes)


__all__ = [
    "DeviceChoice",
    "SubDeviceContext",
    "can_split",
    "parse_device_list",
    "resolve_devices",
    "sub_device_contexts",
]
