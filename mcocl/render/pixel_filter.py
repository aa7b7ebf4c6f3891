"""The reconstruction (pixel) filter: ``box``, ``tent`` and ``gaussian``, by filter importance sampling.

The gather film stays: every camera sample's film point is the pixel centre plus an
offset drawn from the filter (kernels/render/pixel_filter.cl), so each sample
weighs 1 and a pixel's value converges to the filter-weighted mean radiance
``∫ f(x) f(y) L dx dy / (∫ f)^2`` around its centre, the expectation Mitsuba 3's
weighted splatting converges to as well (pbrt-v4 §8.8).  The filters follow
Mitsuba 3's definitions (separable, 1-D profile ``f1``):

- ``box``: ``f1 = 1`` on ``[-1/2, 1/2]`` (mcocl's film before filters existed; bit-identical);
- ``tent``: ``f1(x) = max(0, 1 - |x|/r)``, ``radius`` r (default 1);
- ``gaussian``: ``f1(x) = max(0, exp(-x²/(2s²)) - exp(-r²/(2s²)))``, ``stddev`` s
  (default 0.5) and r = 4 s.

Light tracing and bidirectional path tracing splat a camera connection that lands
at film point x into every pixel p within the filter's reach, weighted by
``f(x - c_p) / ∫f`` (pbrt-v4's splat), so that a pixel estimates the same
filter-weighted mean from both sides; connections are accepted up to
``radius - 1/2`` pixels past the image's edge, where the edge pixels' camera
samples reach (kernels/render/pixel_filter.cl).  bdpt's MIS weights do not depend
on the pixel, so they still sum to 1 over the strategies of every path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import InputError

PIXEL_FILTERS = ("box", "tent", "gaussian")
# The filter_kind codes of kernels/render/pixel_filter.cl (render_params.filter_kind).
FILTER_CODES = {"box": 0, "tent": 1, "gaussian": 2}
TENT_RADIUS = 1.0  # Mitsuba 3's tent default
GAUSSIAN_STDDEV = 0.5  # Mitsuba 3's gaussian default; its radius is 4 stddev
GAUSSIAN_RADII = 4.0
MAX_RADIUS = 16.0  # pixels; a wider filter is a blur, not a reconstruction filter


@dataclass(frozen=True)
class PixelFilter:
    """One reconstruction filter: ``kind`` of :data:`PIXEL_FILTERS`, its ``radius`` in pixels, ``stddev`` (gaussian)."""

    kind: str = "box"
    radius: float = 0.5
    stddev: float = 0.0

    def profile(self, x: np.ndarray) -> np.ndarray:
        """The 1-D filter ``f1`` at offsets ``x`` (pixels) from the pixel centre, float64."""
        x = np.abs(np.asarray(x, np.float64))
        if self.kind == "box":
            return (x <= 0.5).astype(np.float64)
        if self.kind == "tent":
            return np.maximum(0.0, 1.0 - x / self.radius)
        bias = math.exp(-0.5 * (self.radius / self.stddev) ** 2)
        return np.where(x <= self.radius, np.maximum(0.0, np.exp(-0.5 * (x / self.stddev) ** 2) - bias), 0.0)

    def integral(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """∫_a^b f1 dx, exactly (float64), for offsets a <= b."""
        def prim(t: np.ndarray) -> np.ndarray:
            t = np.clip(np.asarray(t, np.float64), -self.radius, self.radius)
            if self.kind == "box":
                return t
            if self.kind == "tent":
                return t - np.sign(t) * t * t / (2.0 * self.radius)
            s = self.stddev
            bias = math.exp(-0.5 * (self.radius / s) ** 2)
            erf = np.vectorize(math.erf)
            return s * math.sqrt(math.pi / 2.0) * erf(t / (s * math.sqrt(2.0))) - bias * t
        return prim(b) - prim(a)

    def defines(self) -> list[str]:
        """The kernel's build options: none for the box, whose build is unchanged; one build for every tent and
        Gaussian, which take their kind, radius and stddev at launch (:meth:`launch_values`)."""
        return [] if self.kind == "box" else ["-DPIXEL_FILTER_SHAPED"]

    def launch_values(self) -> tuple[np.int32, np.float32, np.float32]:
        """``render_params`` filter_kind, filter_radius, filter_stddev (kernels/render/pixel_filter.cl)."""
        return np.int32(FILTER_CODES[self.kind]), np.float32(self.radius), np.float32(self.stddev)

    def to_json(self) -> dict[str, Any]:
        """The filter as scene JSON (``camera.filter``)."""
        if self.kind == "box":
            return {"type": "box"}
        if self.kind == "tent":
            return {"type": "tent", "radius": self.radius}
        return {"type": "gaussian", "stddev": self.stddev}


BOX = PixelFilter()


def make_filter(kind: str, radius: float | None = None, stddev: float | None = None, where: str = "filter") -> PixelFilter:
    """A checked :class:`PixelFilter`; ``where`` names the setting in errors."""
    if kind not in PIXEL_FILTERS:
        raise InputError(f"{where}: unknown reconstruction filter {kind!r}; choose one of {', '.join(PIXEL_FILTERS)}")
    if kind == "box":
        if radius is not None or stddev is not None:
            raise InputError(f"{where}: the box filter takes no radius or stddev (it covers its pixel)")
        return BOX
    if kind == "tent":
        if stddev is not None:
            raise InputError(f"{where}: the tent filter takes a radius, not a stddev")
        r = TENT_RADIUS if radius is None else _positive(radius, f"{where}.radius")
        return PixelFilter("tent", r)
    if radius is not None:
        raise InputError(f"{where}: the gaussian filter's radius is 4 stddev (Mitsuba's); give stddev")
    s = GAUSSIAN_STDDEV if stddev is None else _positive(stddev, f"{where}.stddev", MAX_RADIUS / GAUSSIAN_RADII)
    return PixelFilter("gaussian", GAUSSIAN_RADII * s, s)


def _positive(v: Any, where: str, hi: float = MAX_RADIUS) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise InputError(f"{where}: expected a number, got {v!r}")
    if not 0.0 < v <= hi:
        raise InputError(f"{where}: must lie in (0, {hi:g}] pixels, got {v:g}")
    return float(v)


def parse_filter(v: Any, where: str = "camera.filter") -> PixelFilter:
    """``camera.filter`` of a scene: a name (``"gaussian"``) or ``{"type": ..., "radius"|"stddev": ...}``."""
    if isinstance(v, str):
        return make_filter(v, where=where)
    if not isinstance(v, dict):
        raise InputError(f"{where}: expected a filter name or an object with 'type', got {type(v).__name__}")
    extra = set(v) - {"type", "radius", "stddev", "comment"}
    if extra:
        raise InputError(f"{where}: unknown key(s) {', '.join(sorted(extra))} (a filter has type, radius, stddev)")
    if "type" not in v:
        raise InputError(f"{where}: missing 'type' (one of {', '.join(PIXEL_FILTERS)})")
    return make_filter(v["type"], v.get("radius"), v.get("stddev"), where)


__all__ = ["BOX", "FILTER_CODES", "PIXEL_FILTERS", "PixelFilter", "make_filter", "parse_filter"]
