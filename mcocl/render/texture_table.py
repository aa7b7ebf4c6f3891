"""The one device buffer of a textured scene: ``textures`` (kernels/render/texture.cl).

float4 rows; fields marked (int) hold int32/uint32 bits:

- row 0, the header (int): first row of the material map, of the triangles'
  UVs, of the spheres' frames, of the texture descriptors;
- the material map, one row per material (int): the texture of its colour
  (``rgb``), of its roughness (``alpha``), of a dielectric's transmittance
  (``transmittance_rgb``), −1 for none, and 0;
- the triangles' UVs, two rows per triangle: (u0, v0, u1, v1), (u2, v2, 0, 0)
  (mcocl/render/shape_uvs.py), at least one triangle's worth;
- the spheres' frames, three rows per sphere: the world -> local rows, at least one sphere's worth;
- the texture descriptors, three rows per texture: (kind | filter << 4 | wrap << 8,
  width, height, first texel row) (int), to_uv (a, b, d, e), (c, f, 0, 0);
- the texels of every texture, RGB and 0, row after row from the image's top
  (a checkerboard's are its two colours).  Textures that are the same object
  (a Mitsuba ``<ref>``, equal definitions) share one descriptor; textures of
  one image (one file, read once by the parser) share one copy of its texels.

Area emitters' textured radiance: ``emitter_radiance``'s w holds the
emitter's texture index + 1 (0: constant; :func:`emitter_texture_code`).

A scene without textures has no such table and its kernels are built
without -DTEXTURES: they render bit for bit as before.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from .shape_uvs import sphere_frames, triangle_uvs
from .textures import FILTERS, KINDS, MAX_TEXELS, WRAPS, Texture

# What the kernels read for textures when the scene has none (OpenCL has no empty buffers).
TEXTURES_ABSENT = {"textures": np.zeros((1, 4), np.float32)}
# The record fields a texture can replace, in the material map's column order.
TEXTURED_FIELDS = ("rgb", "alpha", "transmittance_rgb")
DESCRIPTOR_ROWS = 3


def _ints(*values: int) -> np.ndarray:
    """A float4 row holding int32 bits."""
    return np.array(values, np.int32).view(np.float32)


def scene_textures(materials: list, shapes: list) -> list[Texture]:
    """The scene's distinct textures in descriptor order: the materials', then the area emitters' radiance."""
    textures: list = []
    found = [t for m in materials for t in m.textures.values()]
    found += [sh.radiance_texture for sh in shapes if getattr(sh, "radiance_texture", None) is not None]
    for t in found:
        if all(t is not u for u in textures):
            textures.append(t)
    return textures


def emitter_texture_code(texture: Texture | None, textures: list[Texture]) -> float:
    """``emitter_radiance``'s w of an area emitter: its texture's index in ``textures`` + 1, 0 for a constant."""
    if texture is None:
        return 0.0
    return float(next(k for k, t in enumerate(textures) if t is texture) + 1)


def texture_table(materials: list, shapes: list) -> np.ndarray | None:
    """The ``textures`` table (N, 4) float32 of a scene, or None when no material or emitter has a texture.

    Raises:
        InputError: the textures' texels together exceed :data:`MAX_TEXELS`.
    """
    textures = scene_textures(materials, shapes)
    if not textures:
        return None
    # the texel rows of each distinct texel source: a bitmap's image array, a checkerboard's own colours
    sources: dict[int, Texture] = {}
    for t in textures:
        sources.setdefault(id(t.image) if t.image is not None else id(t), t)
    total = sum(t.size[0] * t.size[1] for t in sources.values())
    if total > MAX_TEXELS:
        raise InputError(f"the scene's textures hold {total} texels, more than the {MAX_TEXELS} one device buffer takes")
    uvs = triangle_uvs(shapes)
    frames = sphere_frames(shapes)
    ntri, nsph = max(len(uvs), 1), max(len(frames), 1)
    mat_row = 1
    tri_row = mat_row + len(materials)
    sph_row = tri_row + 2 * ntri
    desc_row = sph_row + 3 * nsph
    texel_row = desc_row + DESCRIPTOR_ROWS * len(textures)
    table = np.zeros((texel_row + total, 4), np.float32)
    table[0] = _ints(mat_row, tri_row, sph_row, desc_row)
    for i, m in enumerate(materials):
        ids = [next((k for k, t in enumerate(textures) if t is m.textures.get(f)), -1) for f in TEXTURED_FIELDS]
        table[mat_row + i] = _ints(*ids, 0)
    tri = table[tri_row:tri_row + 2 * len(uvs)].reshape(-1, 8)
    tri[:, :6] = uvs.reshape(-1, 6)
    table[sph_row:sph_row + 3 * len(frames), :3] = frames.reshape(-1, 3)
    first: dict[int, int] = {}
    row = texel_row
    for key, t in sources.items():
        w, h = t.size
        first[key] = row
        table[row:row + w * h, :3] = t.texels()
        row += w * h
    for k, t in enumerate(textures):
        w, h = t.size
        d = desc_row + DESCRIPTOR_ROWS * k
        code = KINDS.index(t.kind) | FILTERS.index(t.filter_type) << 4 | WRAPS.index(t.wrap_mode) << 8
        table[d] = _ints(code, w, h, first[id(t.image) if t.image is not None else id(t)])
        a, b, c, dd, e, f = t.to_uv
        table[d + 1] = (a, b, dd, e)
        table[d + 2] = (c, f, 0.0, 0.0)
    return table


def texture_defines(tables: dict) -> list[str]:
    """The build option of a scene with textures (none otherwise)."""
    return ["-DTEXTURES"] if "textures" in tables else []


__all__ = ["TEXTURED_FIELDS", "TEXTURES_ABSENT", "emitter_texture_code", "scene_textures", "texture_defines",
           "texture_table"]
