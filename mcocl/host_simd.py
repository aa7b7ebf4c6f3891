"""The host CPU's SIMD width in floats, read from the kernel's CPU flags.

A CPU OpenCL device runs on the host, so the host's vector registers bound
what its kernels can use.  A driver may report a preferred float vector
width of 1 for a CPU with wide vectors (a CI machine's failures point to
that), and mcocl would then run every kernel scalar (about 10x slower on
AVX-512).
:func:`mcocl.runtime.default_lanes` uses this width when the device reports
less than a SIMD register's worth.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

# Widest float vector register by CPU flag (x86: /proc/cpuinfo "flags";
# Arm: "Features"), widest first.
_FLAG_WIDTHS = (("avx512f", 16), ("avx2", 8), ("avx", 8), ("sse2", 4), ("asimd", 4), ("neon", 4))


def simd_width_from_flags(flags: set[str]) -> int:
    """Floats per vector register for a CPU with these feature flags (1 if none is known)."""
    for flag, width in _FLAG_WIDTHS:
        if flag in flags:
            return width
    return 1


@cache
def cpuinfo_value(keys: tuple[str, ...], cpuinfo: str = "/proc/cpuinfo") -> str | None:
    """The value of the first line of ``cpuinfo`` whose key is one of ``keys`` (lower case), or None."""
    try:
        text = Path(cpuinfo).read_text(errors="replace")
    except OSError:
        return None
    for line in text.splitlines():
        key, _, value = line.partition(":")
        if key.strip().lower() in keys:
            return value.strip()
    return None


def host_simd_width(cpuinfo: str = "/proc/cpuinfo") -> int:
    """Floats per vector register of this machine's CPU, or 1 if it cannot be read."""
    flags = cpuinfo_value(("flags", "features"), cpuinfo)
    return simd_width_from_flags(set(flags.split())) if flags is not None else 1


__all__ = ["cpuinfo_value", "host_simd_width", "simd_width_from_flags"]
