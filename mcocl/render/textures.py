"""Textures of material colours: Mitsuba 3's ``checkerboard`` and ``bitmap`` (kernels/render/texture.cl).

A material key that takes a colour (:attr:`mcocl.bsdf_registry.Param.texturable`)
also takes a texture object instead of the constant::

    {"type": "checkerboard", "color0": 0.4, "color1": 0.2, "to_uv": [{"scale": [4, 4]}]}
    {"type": "bitmap", "filename": "wood.png", "raw": false, "filter_type": "bilinear",
     "wrap_mode": "repeat", "to_uv": [{"translate": [0.5, 0, 0]}]}

Conventions are Mitsuba 3's (its plugin documentation, and its scalar_rgb
variant queried at chosen points: tests/test_render_textures.py states them):

- ``to_uv`` maps the surface's (u, v) first: a transform in the shapes'
  vocabulary (translate, scale, rotate, matrix) of which the x and y rows
  act on (u, v, 0, 1).
- checkerboard: ``color0`` (default 0.4) where frac(u) > ½ and frac(v) > ½
  agree, else ``color1`` (default 0.2).
- bitmap: row 0 of the file is v = 0 (the image's top row); nearest
  filtering reads texel (floor(u W), floor(v H)); bilinear filtering blends
  the four texels around (u W − ½, v H − ½); integer texel indices outside
  the image wrap by ``wrap_mode``: ``repeat`` (modulo), ``mirror`` (period
  2 W, the second half reversed) or ``clamp`` (to the edge).
- 8-bit and 16-bit images are sRGB-encoded unless ``raw`` is true: their
  values are decoded to linear RGB by the sRGB transfer function (IEC
  61966-2-1) on loading; float images (OpenEXR, float TIFF) are linear.

Images are read by Pillow (PNG, JPEG, BMP, TGA, TIFF, ...), OpenEXR files by
:func:`mcocl.render.image_io.read_exr` and Radiance ``.hdr`` files by
:func:`mcocl.render.radiance_hdr.read_hdr` (linear, like EXR).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError

KINDS = ("checkerboard", "bitmap")
FILTERS = ("nearest", "bilinear")  # their index is the kernel's TEX_FILTER_* code
WRAPS = ("repeat", "mirror", "clamp")  # their index is the kernel's TEX_WRAP_* code
# All textures' texels together at most (they live in one device buffer of float4).
MAX_TEXELS = 1 << 26
IDENTITY_UV = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)


@dataclass(eq=False)
class Texture:
    """A texture: ``kind`` of :data:`KINDS`; ``to_uv`` the 2-D affine map (a, b, c, d, e, f):
    (u, v) -> (a u + b v + c, d u + e v + f); a checkerboard's two colours, or a bitmap's
    linear-RGB ``image`` (H, W, 3) float32 with its filter and wrap mode."""

    kind: str
    to_uv: tuple[float, ...] = IDENTITY_UV
    color0: np.ndarray = field(default_factory=lambda: np.full(3, 0.4))
    color1: np.ndarray = field(default_factory=lambda: np.full(3, 0.2))
    image: np.ndarray | None = None
    filter_type: str = "bilinear"
    wrap_mode: str = "repeat"
    filename: str = ""

    def texels(self) -> np.ndarray:
        """The texels the kernel reads: the image's rows, or the checkerboard's two colours (N, 3)."""
        if self.kind == "checkerboard":
            return np.stack([self.color0, self.color1]).astype(np.float32)
        assert self.image is not None
        return self.image.reshape(-1, 3)

    def mean(self) -> np.ndarray:
        """The mean texel (3,) float64: what the material record holds in place of the texture."""
        return self.texels().astype(np.float64).mean(axis=0)

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) of a bitmap; (2, 1) for a checkerboard's two colours."""
        if self.image is None:
            return 2, 1
        return int(self.image.shape[1]), int(self.image.shape[0])


def srgb_to_linear(x: np.ndarray) -> np.ndarray:
    """The sRGB transfer function's inverse (IEC 61966-2-1) on values in [0, 1]."""
    x = np.asarray(x, np.float64)
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def load_image(path: Path, raw: bool, what: str) -> np.ndarray:
    """float32 (H, W, 3) linear RGB of an image file (see the module docstring for the decoding).

    Raises:
        InputError: the file is missing, not an image, an unsupported format, or holds non-finite
            or negative values; ``what`` names the scene key.
    """
    if not path.is_file():
        raise InputError(f"{what}: {path} not found")
    suffix = path.suffix.lower()
    if suffix == ".hdr":
        from .radiance_hdr import read_hdr

        img = read_hdr(path, what)
    elif suffix == ".exr":
        from .image_io import read_exr

        img = read_exr(path).mean
    else:
        img = _pillow_image(path, raw, what)
    if img.ndim != 3 or img.shape[0] < 1 or img.shape[1] < 1:
        raise InputError(f"{what}: {path.name}: an empty image")
    if not np.all(np.isfinite(img)) or np.any(img < 0):
        raise InputError(f"{what}: {path.name}: texel values must be finite and >= 0")
    return np.ascontiguousarray(img, np.float32)


def _pillow_image(path: Path, raw: bool, what: str) -> np.ndarray:
    """An image file read by Pillow, as float RGB: integer images scaled to [0, 1] and sRGB-decoded unless ``raw``."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as im:
            im.load()
            mode = im.mode
            if mode in ("F", "I"):
                a = np.asarray(im, np.float64)
                scale = 1.0 if mode == "F" else 65535.0 if a.max(initial=0) > 255 else 255.0
                a = np.repeat(a[..., None] / scale, 3, axis=2)
                encoded = mode != "F"
            elif mode.startswith("I;16"):
                a = np.repeat(np.asarray(im, np.float64)[..., None] / 65535.0, 3, axis=2)
                encoded = True
            else:
                a = np.asarray(im.convert("RGB"), np.float64) / 255.0
                encoded = True
    except UnidentifiedImageError:
        raise InputError(f"{what}: {path.name}: not an image file Pillow can read (PNG, JPEG, ...; "
                         "or OpenEXR .exr)") from None
    except OSError as e:
        raise InputError(f"{what}: {path.name}: unreadable image ({e})") from None
    return (a if raw or not encoded else srgb_to_linear(a)).astype(np.float32)


def affine_uv(matrix: np.ndarray) -> tuple[float, ...]:
    """The (u, v) part of a 4 x 4 transform: rows x, y on (u, v, 0, 1)."""
    m = np.asarray(matrix, np.float64)
    return tuple(float(x) for x in (m[0, 0], m[0, 1], m[0, 3], m[1, 0], m[1, 1], m[1, 3]))


def parse_texture(c: Any, value: dict, key: str, roots: list[Path], transform) -> Texture:
    """A texture object of a scene file (``c``: the scene's checker, mcocl/render/scene.py;
    ``transform(c, v, key)`` parses ``to_uv`` as a shape's transform; ``roots`` confine ``filename``)."""
    if "type" not in value:
        c.fail(f"{key}.type", "missing required key (a texture is 'checkerboard' or 'bitmap')")
    kind = c.string(value["type"], f"{key}.type", KINDS)
    if kind == "checkerboard":
        o = c.obj(value, key, ("type",), ("color0", "color1", "to_uv"))
        tex = Texture(kind, color0=c.rgb(o.get("color0", 0.4), f"{key}.color0"),
                      color1=c.rgb(o.get("color1", 0.2), f"{key}.color1"))
    else:
        o = c.obj(value, key, ("type", "filename"), ("raw", "filter_type", "wrap_mode", "to_uv"))
        rel = c.string(o["filename"], f"{key}.filename")
        path = c.mesh_file(rel, f"{key}.filename", roots, text=False)
        raw = c.boolean(o.get("raw", False), f"{key}.raw")
        filt = c.string(o.get("filter_type", "bilinear"), f"{key}.filter_type", FILTERS)
        wrap = c.string(o.get("wrap_mode", "repeat"), f"{key}.wrap_mode", WRAPS)
        # one array per image file and decoding, however many textures use it (texture_table shares its texels)
        image = c.images.get((path, raw))
        if image is None:
            image = c.images[(path, raw)] = load_image(path, raw, f"{c.file}: {key}.filename")
        tex = Texture(kind, image=image, filter_type=filt, wrap_mode=wrap, filename=rel)
    if "to_uv" in o:
        m = transform(c, o["to_uv"], f"{key}.to_uv")
        tex.to_uv = affine_uv(m)
        if not all(np.isfinite(tex.to_uv)):
            c.fail(f"{key}.to_uv", "the transform must be finite")
    return tex


__all__ = ["FILTERS", "KINDS", "MAX_TEXELS", "WRAPS", "Texture", "affine_uv", "load_image", "parse_texture",
           "srgb_to_linear"]
