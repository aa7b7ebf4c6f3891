"""The environment map: an equirectangular image of the radiance arriving from infinitely far.

Conventions are Mitsuba 3's ``envmap`` emitter (its plugin documentation and
behaviour), so that a Mitsuba scene renders the same:

- Direction ↔ image.  In the map's local frame (world → local by the inverse
  of ``to_world``, a rotation), the direction d = (x, y, z) has
  ``u = atan2(x, −z) / 2π`` (wrapped into [0, 1)) and ``v = acos(y) / π``:
  +y is up (the image's top row), the image's centre column looks along
  +z, a quarter of the way across along +x, and the left and right edges
  (the seam) along −z.  Conversely (θ, φ) = (π v, 2π u) gives
  d = (sin θ sin φ, cos θ, −sin θ cos φ).
- Lookup.  The W × H image gets its first column repeated after the last
  (W + 1 columns, so the seam interpolates), and the radiance at (u, v) is
  the bilinear interpolation at texel position (x, y) = (u W − ½ wrapped
  into [0, W), v (H − 1)): texel (i, j) sits at u = (i + ½) / W,
  v = j / (H − 1), which is how Mitsuba 3 looks its maps up (measured
  against its ``envmap`` plugin to 1e-5).  ``scale`` multiplies it.
- Importance sampling (kernels/render/envmap.cl).  The W × (H − 1) cells
  between texel centres get the piecewise-constant density of
  :class:`mcocl.integration.proposals.Tabulated2D` (the integration
  sampler's exact tabulated 2-D construction on the uniforms' grid: rows by
  their marginal, then the column), with cell weight = the mean luminance of
  its four corners times ∫ sin θ dθ over the cell.  A cell whose corners are
  all black gets no mass, any other cell some.  The density in (u, v) becomes
  one in solid angle by dω = 2π² sin θ du dv.  The table's column axis is
  s = x / W, so its cells are exactly the bilinear patches.

The image file: OpenEXR (R, G, B channels), read by
:func:`mcocl.render.image_io.read_exr`.  Radiance HDR files are not read
yet: convert them to EXR.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..integration.proposals import Tabulated2D
from .emitter_choice import LUMINANCE

# At most this many texels (the image lives in one device buffer of float4).
MAX_TEXELS = 1 << 26
HEADER_QUADS = 4  # env_map buffer: (W, H) as uint bits, then the 3 rows of the world -> local rotation


@dataclass
class EnvMap:
    """An environment map: linear RGB ``image`` (H, W, 3), ``scale``, and ``matrix`` (to_world, a rotation)."""

    image: np.ndarray
    scale: float
    matrix: np.ndarray
    filename: str = ""

    @property
    def black(self) -> bool:
        """True when the map emits nothing (it is then no environment at all)."""
        return not (self.scale > 0 and np.any(self.image > 0))


def load_envmap_image(path: Path, what: str) -> np.ndarray:
    """float32 (H, W, 3) linear RGB of an OpenEXR or Radiance .hdr file, checked (finite, >= 0, at least
    2 x 2 texels).

    Raises:
        InputError: a missing, unreadable or unsupported file, or bad pixel values (named by ``what``).
    """
    from .image_io import read_exr
    from .radiance_hdr import read_hdr

    suffix = path.suffix.lower()
    if suffix not in (".exr", ".hdr"):
        raise InputError(f"{what}: {path.name}: environment maps are read from OpenEXR (.exr) or Radiance "
                         f"(.hdr) files, not {suffix or 'a file without a suffix'}")
    img = read_exr(path).mean if suffix == ".exr" else read_hdr(path, what)
    h, w = img.shape[:2]
    if h < 2 or w < 1:
        raise InputError(f"{what}: {path.name}: an environment map needs at least 2 rows, got {w} x {h}")
    if (w + 1) * h > MAX_TEXELS:
        raise InputError(f"{what}: {path.name}: {w} x {h} texels is above the limit of {MAX_TEXELS}")
    bad = ~np.isfinite(img) | (img < 0)
    if np.any(bad):
        y, x, c = np.argwhere(bad)[0]
        raise InputError(f"{what}: {path.name}: pixel ({x}, {y}) channel {'RGB'[c]} is {img[y, x, c]} "
                         f"(radiance must be finite and >= 0)")
    return np.ascontiguousarray(img, np.float32)


def check_rotation(m: np.ndarray, what: str) -> None:
    """An environment map's to_world must be a rotation (a pure direction map; sampling keeps solid angles)."""
    r = np.asarray(m, np.float64)[:3, :3]
    if not (np.allclose(r @ r.T, np.eye(3), atol=1e-5) and np.linalg.det(r) > 0):
        raise InputError(f"{what}: an environment map's transform must be a rotation (no scale, shear or "
                         f"mirroring)")


def envmap_tables(env: EnvMap) -> tuple[np.ndarray, np.ndarray]:
    """The device tables ``(env_map, env_cdf)`` of kernels/render/envmap.cl.

    ``env_map`` float32 (4 + H (W + 1), 4): the header (W, H as uint bits;
    the rotation world → local as three rows), then the texels row by row,
    scaled, with the wrap column; ``env_cdf`` uint32: the marginal CDF over
    the H − 1 cell rows, then each row's conditional CDF over its W cells
    (:class:`~mcocl.integration.proposals.Tabulated2D`).
    """
    img = np.asarray(env.image, np.float64) * env.scale
    h, w = img.shape[:2]
    wrapped = np.concatenate([img, img[:, :1]], axis=1)
    out = np.zeros((HEADER_QUADS + h * (w + 1), 4), np.float32)
    out[0, :2] = np.array([w, h], np.uint32).view(np.float32)
    out[1:4, :3] = np.asarray(env.matrix, np.float64)[:3, :3].T  # world -> local: the rotation's inverse
    out[HEADER_QUADS:, :3] = wrapped.reshape(-1, 3)
    lum = wrapped @ LUMINANCE
    corners = (lum[:-1, :-1] + lum[:-1, 1:] + lum[1:, :-1] + lum[1:, 1:]) / 4
    theta = np.linspace(0.0, math.pi, h)
    band = np.cos(theta[:-1]) - np.cos(theta[1:])  # ∫ sin θ dθ over each row of cells
    tab = Tabulated2D(corners * band[:, None])
    return out, np.concatenate([tab.marg, tab.cond]).astype(np.uint32)


def envmap_pdf_np(env: EnvMap, d: np.ndarray) -> np.ndarray:
    """The solid-angle density (n,) with which kernels/render/envmap.cl samples world directions d (n, 3)."""
    _, cdf = envmap_tables(env)
    h, w = env.image.shape[:2]
    na, nb = h - 1, w
    marg = cdf[:na + 1].astype(np.int64)
    cond = cdf[na + 1:].astype(np.int64).reshape(na, nb + 1)
    local = d @ np.asarray(env.matrix, np.float64)[:3, :3]  # R^T d for a rotation R
    local /= np.linalg.norm(local, axis=1, keepdims=True)
    u = np.mod(np.arctan2(local[:, 0], -local[:, 2]) / (2 * math.pi) - 0.5 / env.image.shape[1], 1.0)
    theta = np.arccos(np.clip(local[:, 1], -1, 1))
    v = theta / math.pi
    i = np.minimum((v * na).astype(np.int64), na - 1)
    j = np.minimum((u * nb).astype(np.int64), nb - 1)
    mass = np.diff(marg)[i] * np.diff(cond, axis=1)[i, j] / float(1 << 23) ** 2
    return mass * na * nb / (2 * math.pi**2 * np.sin(theta))


def envmap_radiance_np(env: EnvMap, d: np.ndarray) -> np.ndarray:
    """The radiance (n, 3) arriving from world directions d (n, 3): the bilinear lookup above, scaled."""
    img = np.asarray(env.image, np.float64) * env.scale
    h, w = img.shape[:2]
    wrapped = np.concatenate([img, img[:, :1]], axis=1)
    local = d @ np.asarray(env.matrix, np.float64)[:3, :3]
    local /= np.linalg.norm(local, axis=1, keepdims=True)
    u = np.mod(np.arctan2(local[:, 0], -local[:, 2]) / (2 * math.pi), 1.0)
    v = np.arccos(np.clip(local[:, 1], -1, 1)) / math.pi
    x, y = np.mod(u * w - 0.5, w), v * (h - 1)
    x0 = np.minimum(np.floor(x).astype(np.int64), w - 1)
    y0 = np.minimum(np.floor(y).astype(np.int64), h - 2)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    return ((1 - fy) * ((1 - fx) * wrapped[y0, x0] + fx * wrapped[y0, x0 + 1])
            + fy * ((1 - fx) * wrapped[y0 + 1, x0] + fx * wrapped[y0 + 1, x0 + 1]))


__all__ = ["EnvMap", "check_rotation", "envmap_pdf_np", "envmap_radiance_np", "envmap_tables", "load_envmap_image"]
