"""Scene files: JSON loading and validation (the format is documented in ``scenes/README.md``).

:func:`load_scene` reads a scene file into a :class:`Scene` of plain Python and
NumPy values, checking every key on the way.  A mistake — an unknown key, a
missing field, a value of the wrong type or range, a dangling material
reference, a non-uniform scale on a sphere — raises
:class:`~mcocl.errors.InputError` whose message starts with the file and the
key path, e.g. ``scenes/x.json: shapes[3].material: unknown material 'wite'
(defined: white, red)``.  Nothing here raises a bare Python exception on bad
input.

:mod:`mcocl.render.compiled` turns a :class:`Scene` into the flat arrays the
kernels read.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..bsdf_registry import BSDFS, BsdfSpec, record_values
from ..datafile import decode_utf8
from ..errors import InputError
from ..layouts import Integrator, MaterialKind
from . import transform as tf
from .delta_lights import DeltaLight, parse_lights
from .emitter_choice import LUMINANCE
from .envmap import EnvMap, check_rotation, load_envmap_image
from .json_arrays import InlineArray
from .pixel_filter import BOX, PixelFilter, parse_filter
from .shape_registry import GEOMETRY_LIMIT, SHAPES
from .textures import Texture, parse_texture

# The names a scene file uses: the codes of mcocl/layouts.py, lower case.
INTEGRATORS = tuple(kind.name.lower() for kind in Integrator)
MATERIAL_KINDS = tuple(kind.name.lower() for kind in MaterialKind)
SHAPE_KINDS = tuple(SHAPES)  # mcocl/render/shape_registry.py

# Defaults, with Mitsuba 3's where it has one (max_depth -1, rr_depth 5); the
# materials' defaults are declared with each BSDF in mcocl/bsdf_registry.py.
DEFAULT_INTEGRATOR = "mis"
DEFAULT_MAX_DEPTH = -1
DEFAULT_RR_DEPTH = 5
DEFAULT_SPP = 64

# What the kernels take: depths are 32-bit ints; coordinates are float32, and a point or matrix
# entry beyond 1e15 leaves no precision for ray intersection (and products of two of them stay
# finite in float32).  Pixels: the film keeps STATS float64 sums per pixel, plus a block's
# partials and the output image (film.BYTES_PER_PIXEL); refuse an image that cannot fit.
MAX_DEPTH_LIMIT = 2**31 - 1
RGB_LIMIT = 1e30  # float32 radiance, with room for the film's sums of squares in float64
MAX_IMAGE_SIDE = 2**20
MAX_SPP = 2**32 - 2  # below render.job.UNBOUNDED_SPP, the 32-bit "no limit" marker
# float64 totals and a float64 copy (STATS each), float32 block partials, float32 mean/variance/count
BYTES_PER_PIXEL = 8 * 8 * 2 + 8 * 4 + 7 * 4
# How light sampling chooses an area light (mcocl/render/emitter_choice.py, kernels/render/light_bvh.cl).
LIGHT_SAMPLERS = ("auto", "power", "uniform", "bvh")
# auto: bvh where its tree is flat (2-16 area lights, no point/spot/directional light), where it costs what
# power costs per sample and wins on MSE per second (veach_mis.json); power elsewhere, where the deep tree's
# 1.5x cost per sample lost on MSE per second (many_lights.json): scenes/README.md, emitter_choice.py.
DEFAULT_LIGHT_SAMPLER = "auto"
# integrator.sampler: independent uniforms, per-pixel RQMC (mcocl/render/sobol_film.py), or auto: sobol where
# the render can form its batches, independent elsewhere (mcocl/render/sampler_choice.py, with the rule and
# the measurements that chose it).
RENDER_SAMPLERS = ("auto", "independent", "sobol")
DEFAULT_RENDER_SAMPLER = "auto"


@dataclass
class Camera:
    """A perspective camera; ``fov`` is the full angle in degrees on the image's smaller axis.

    ``aperture_radius`` 0 is a pinhole; above 0 a thin lens (Mitsuba's ``thinlens``) focused at
    ``focus_distance`` along the viewing direction (None: the distance to ``target``).
    """

    origin: np.ndarray
    target: np.ndarray
    up: np.ndarray
    fov: float
    width: int
    height: int
    aperture_radius: float = 0.0
    focus_distance: float | None = None
    pixel_filter: PixelFilter = BOX  # camera.filter (mcocl/render/pixel_filter.py)
    crop: tuple[int, int, int, int] | None = None  # offset x, y, width, height of the rendered window
    near_clip: float = 0.0  # primary rays start this far along the optical axis (camera connections too)
    far_clip: float | None = None  # ... and end this far along it (None: never)


@dataclass
class Material:
    """One material: ``kind`` is one of :data:`MATERIAL_KINDS`; the rest are its ``material_record`` fields.

    ``rgb`` is the albedo or specular reflectance; which key fills which field is
    declared by the BSDF's registration (mcocl/bsdf_registry.py).
    """

    name: str
    kind: str
    rgb: np.ndarray
    alpha: float = 0.0
    int_ior: float = 1.0
    ext_ior: float = 1.0
    flags: int = 0  # bits of mcocl.bsdf_registry.FLAG_BITS (twosided)
    alpha_second: float = 0.0  # anisotropic roughness along the second tangent (the key alpha_v)
    eta_rgb: np.ndarray = field(default_factory=lambda: np.zeros(3))  # a conductor's complex IOR
    k_rgb: np.ndarray = field(default_factory=lambda: np.zeros(3))
    # a dielectric's transmission tint when it is not rgb (flags bit "transmittance"; mcocl/bsdf_registry.py)
    transmittance_rgb: np.ndarray = field(default_factory=lambda: np.zeros(3))
    # Record fields ("rgb", "alpha", "transmittance_rgb") given by a texture (mcocl/render/textures.py), looked up per hit.
    textures: dict[str, Texture] = field(default_factory=dict)


@dataclass
class Shape:
    """One shape in local coordinates with its world transform.

    ``vertices``/``faces`` hold the local triangle mesh of a rectangle, cube,
    disk, cylinder or mesh; a sphere has ``center``/``radius`` instead.  ``radiance`` is the
    RGB radiance of its area emitter, ``None`` when it does not emit.
    """

    kind: str
    key: str  # key path in the scene file, e.g. "shapes[3]"
    material: int
    matrix: np.ndarray
    flip_normals: bool = False
    radiance: np.ndarray | None = None
    # a textured area emitter's radiance (mcocl/render/textures.py); ``radiance`` then holds its mean texel
    radiance_texture: Texture | None = None
    vertices: np.ndarray | None = None
    faces: np.ndarray | None = None
    center: np.ndarray | None = None
    radius: float = 0.0
    name: str = ""
    # Per-vertex data of a mesh file: normals shade smoothly (render/shading_normals.py), uvs place textures
    # (render/shape_uvs.py).
    normals: np.ndarray | None = None
    uvs: np.ndarray | None = None


@dataclass
class Scene:
    """A validated scene file."""

    path: Path
    camera: Camera
    materials: list[Material]
    shapes: list[Shape]
    env_radiance: np.ndarray = field(default_factory=lambda: np.zeros(3))
    integrator: str = DEFAULT_INTEGRATOR
    max_depth: int = DEFAULT_MAX_DEPTH
    rr_depth: int = DEFAULT_RR_DEPTH
    spp: int = DEFAULT_SPP
    light_sampler: str = DEFAULT_LIGHT_SAMPLER
    sampler: str = DEFAULT_RENDER_SAMPLER
    batches: int | None = None  # integrator.batches: sobol's batches per pixel (None: the default, 4)
    lights: list[DeltaLight] = field(default_factory=list)  # point, spot, directional (delta_lights.py)
    env_map: EnvMap | None = None  # an environment map (envmap.py); env_radiance is then 0


class _Checker:
    """Type and key checks that raise :class:`InputError` naming the file and key path."""

    def __init__(self, file: str) -> None:
        self.file = file
        # Textures read so far, by their JSON text: equal definitions share one Texture (one copy of the texels).
        self.textures: dict[str, Texture] = {}
        self.images: dict[tuple[Path, bool], np.ndarray] = {}  # image arrays by (file, raw): one per file

    def fail(self, key: str, msg: str) -> None:
        raise InputError(f"{self.file}: {key}: {msg}" if key else f"{self.file}: {msg}")

    def obj(self, value: Any, key: str, required: tuple[str, ...], optional: tuple[str, ...] = ()) -> dict:
        """``value`` as a dict with all ``required`` keys and no key outside ``required + optional + comment``."""
        if not isinstance(value, dict):
            self.fail(key, f"expected an object {{...}}, got {_kind(value)}")
        allowed = set(required) | set(optional) | {"comment"}
        for k in value:
            if k not in allowed:
                self.fail(_join(key, k), f"unknown key (allowed here: {', '.join(sorted(allowed))})")
        for k in required:
            if k not in value:
                self.fail(_join(key, k), "missing required key")
        if "comment" in value and not isinstance(value["comment"], (str, list)):
            self.fail(_join(key, "comment"), "a comment must be a string or a list of strings")
        return value

    def number(self, value: Any, key: str, lo: float | None = None, hi: float | None = None,
               lo_open: bool = False, hi_open: bool = False) -> float:
        """A finite JSON number within the bounds (open or closed)."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(key, f"expected a number, got {_kind(value)}")
        x = float(value)
        if not math.isfinite(x):
            self.fail(key, f"expected a finite number, got {value}")
        if lo is not None and (x < lo or (lo_open and x == lo)):
            self.fail(key, f"must be {'>' if lo_open else '>='} {lo:g}, got {x:g}")
        if hi is not None and (x > hi or (hi_open and x == hi)):
            self.fail(key, f"must be {'<' if hi_open else '<='} {hi:g}, got {x:g}")
        return x

    def integer(self, value: Any, key: str, lo: int | None = None, hi: int | None = None) -> int:
        """A JSON integer (``3``, not ``3.0`` or ``"3"``) in ``[lo, hi]``."""
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(key, f"expected an integer, got {_kind(value)}")
        if lo is not None and value < lo:
            self.fail(key, f"must be >= {lo}, got {value}")
        if hi is not None and value > hi:
            self.fail(key, f"must be <= {hi}, got {value}")
        return int(value)

    def string(self, value: Any, key: str, choices: tuple[str, ...] | None = None) -> str:
        """A JSON string, one of ``choices`` when given."""
        if not isinstance(value, str):
            self.fail(key, f"expected a string, got {_kind(value)}")
        if choices is not None and value not in choices:
            self.fail(key, f"unknown value {value!r} (expected one of: {', '.join(choices)})")
        return value

    def boolean(self, value: Any, key: str) -> bool:
        """A JSON ``true``/``false``."""
        if not isinstance(value, bool):
            self.fail(key, f"expected true or false, got {_kind(value)}")
        return value

    def vector(self, value: Any, key: str, n: int = 3, limit: float | None = None) -> np.ndarray:
        """A list of ``n`` finite numbers (of magnitude at most ``limit`` when given)."""
        if not isinstance(value, list) or len(value) != n:
            self.fail(key, f"expected a list of {n} numbers, got {_kind(value)}")
        lo = -limit if limit is not None else None
        return np.array([self.number(x, f"{key}[{i}]", lo, limit) for i, x in enumerate(value)], dtype=np.float64)

    def rgb(self, value: Any, key: str) -> np.ndarray:
        """An RGB triple of non-negative numbers, or one number for grey."""
        if isinstance(value, list):
            v = self.vector(value, key, 3, limit=RGB_LIMIT)
        else:
            v = np.full(3, self.number(value, key, -RGB_LIMIT, RGB_LIMIT))
        if np.any(v < 0):
            self.fail(key, "RGB values must be >= 0")
        return v

    def array(self, value: Any, key: str, width: int, integer: bool) -> np.ndarray:
        """A list of lists of ``width`` numbers (vertices or faces), vectorised check.

        An :class:`~mcocl.render.json_arrays.InlineArray` (parsed from the file by NumPy) is checked by the
        same rules at once, or raises :class:`~mcocl.render.json_arrays.ExactReadNeededError` for the exact reader.
        """
        if isinstance(value, InlineArray):
            return value.checked(width, integer, 2**31 - 1 if integer else GEOMETRY_LIMIT)
        if not isinstance(value, list):
            self.fail(key, f"expected a list of [{', '.join('abc'[:width])}] lists, got {_kind(value)}")
        for i, row in enumerate(value):
            if not isinstance(row, list) or len(row) != width:
                self.fail(f"{key}[{i}]", f"expected a list of {width} {'integers' if integer else 'numbers'}")
            for j, x in enumerate(row):
                ok = isinstance(x, int) if integer else isinstance(x, (int, float))
                if isinstance(x, bool) or not ok:
                    self.fail(f"{key}[{i}][{j}]", f"expected {'an integer' if integer else 'a number'}, got {_kind(x)}")
        big = [(i, x) for i, row in enumerate(value) for x in row if abs(x) > (2**31 - 1 if integer else GEOMETRY_LIMIT)]
        if big:
            self.fail(f"{key}[{big[0][0]}]", f"the number {big[0][1]:g} is out of range (at most "
                      f"{'2**31 - 1' if integer else f'{GEOMETRY_LIMIT:g}'} in magnitude)")
        a = np.array(value, dtype=np.int64 if integer else np.float64).reshape(-1, width)
        return a

    def mesh_file(self, rel: str, key: str, roots: list[Path], text: bool = True) -> Path:
        """The mesh file ``rel`` names, resolved in the scene's folder; it must lie inside one of ``roots``.

        A scene file is data: it must not read ``/etc/passwd`` or climb out with
        ``..`` (links are resolved first, so a link cannot leave either).  A
        ``text`` file (OBJ) must be UTF-8 (the parser reads it next); a PLY file may be binary.
        """
        if "\0" in rel or not rel.strip():
            self.fail(key, f"not a file name: {rel!r}")
        path = (roots[0] / rel).resolve()
        allowed = [r.resolve() for r in roots]
        if not any(path.is_relative_to(r) for r in allowed):
            self.fail(key, f"{rel!r} lies outside the scene's folder {allowed[0]}; mesh files must be inside it"
                   + (f" or inside {allowed[1]}" if len(allowed) > 1 else " (the mesh_folder option allows another)"))
        if text and path.is_file():
            try:
                decode_utf8(path.read_bytes(), f"{self.file}: {key}: {path}")
            except OSError:
                pass  # the parser reports an unreadable file
        return path


def _kind(v: Any) -> str:
    if isinstance(v, bool):
        return f"the boolean {str(v).lower()}"
    if isinstance(v, (int, float)):
        return f"the number {v}"
    if isinstance(v, str):
        return f"the string {v!r}"
    if isinstance(v, list):
        return f"a list of {len(v)} items"
    if isinstance(v, dict):
        return "an object"
    return "null" if v is None else type(v).__name__


def check_image_size(width: int, height: int, checker: _Checker | None = None, key: str = "camera") -> None:
    """Refuse an image whose film would not fit in memory (an estimate, before anything is allocated)."""
    c = checker or _Checker("settings")
    need = width * height * BYTES_PER_PIXEL
    have = _memory_bytes()
    if width * height >= 2**31 or (have and need > have // 2):
        c.fail(f"{key}.width", f"a {width}x{height} image needs about {need / 2**30:.3g} GiB for its film"
               + (f", more than half of this machine's {have / 2**30:.3g} GiB" if have else ""))


def _memory_bytes() -> int:
    """Physical memory in bytes (0 where the system does not say)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 0


def _join(key: str, k: str) -> str:
    return f"{key}.{k}" if key else k




def parse_scene(data: Any, path: str | Path = "<scene>", mesh_folder: str | Path | None = None) -> Scene:
    """Validate an already-parsed scene description.

    ``path`` names it in errors; OBJ paths are resolved in its folder and must
    stay inside it (or inside ``mesh_folder`` when given).
    """
    p = Path(path)
    c = _Checker(str(p))
    top = c.obj(data, "", ("camera",), ("integrator", "materials", "shapes", "environment", "lights"))
    camera = _camera(c, top["camera"], "camera")
    integ = _integrator(c, top.get("integrator", {}), "integrator")
    roots = [p.parent] + ([Path(mesh_folder)] if mesh_folder is not None else [])
    materials, index = _materials(c, top.get("materials", {}), "materials", roots)
    raw_shapes = top.get("shapes", [])
    if not isinstance(raw_shapes, list):
        c.fail("shapes", f"expected a list of shapes, got {_kind(raw_shapes)}")
    shape_list = [_shape(c, s, f"shapes[{i}]", index, roots) for i, s in enumerate(raw_shapes)]
    env, env_map = np.zeros(3), None
    if "environment" in top:
        e = top["environment"]
        if not isinstance(e, dict) or "type" not in e:
            c.obj(e, "environment", ("type",))
        if c.string(e["type"], "environment.type", ("constant", "envmap")) == "constant":
            e = c.obj(e, "environment", ("type", "radiance"))
            env = c.rgb(e["radiance"], "environment.radiance")
        else:
            env_map = _envmap(c, e, "environment", roots)
    if not isinstance(top.get("lights", []), list):
        c.fail("lights", f"expected a list of lights, got {_kind(top['lights'])}")
    lights = parse_lights(c, top["lights"], "lights", GEOMETRY_LIMIT) if "lights" in top else []
    return Scene(p, camera, materials, shape_list, env, **integ, lights=lights, env_map=env_map)


def _envmap(c: _Checker, v: dict, key: str, roots: list[Path]) -> EnvMap | None:
    """An ``{"type": "envmap", "filename", "scale", "transform"}`` environment (None when it is all black)."""
    o = c.obj(v, key, ("type", "filename"), ("scale", "transform"))
    path = c.mesh_file(c.string(o["filename"], f"{key}.filename"), f"{key}.filename", roots, text=False)
    if not path.is_file():
        c.fail(f"{key}.filename", f"{o['filename']!r} not found (looked for {path})")
    scale = c.number(o.get("scale", 1.0), f"{key}.scale", 0.0, RGB_LIMIT)
    m = _transform(c, o.get("transform", []), f"{key}.transform")
    check_rotation(m, f"{c.file}: {key}.transform")
    env = EnvMap(load_envmap_image(path, f"{c.file}: {key}.filename"), scale, m, str(o["filename"]))
    return None if env.black else env


def _camera(c: _Checker, v: Any, key: str) -> Camera:
    o = c.obj(v, key, ("origin", "target", "fov", "width", "height"), ("up", "aperture_radius", "focus_distance", "filter", "crop",
                                                                   "near_clip", "far_clip"))
    origin = c.vector(o["origin"], f"{key}.origin", limit=GEOMETRY_LIMIT)
    target = c.vector(o["target"], f"{key}.target", limit=GEOMETRY_LIMIT)
    up = c.vector(o.get("up", [0, 1, 0]), f"{key}.up", limit=GEOMETRY_LIMIT)
    fov = c.number(o["fov"], f"{key}.fov", 0.0, 180.0, lo_open=True, hi_open=True)
    width = c.integer(o["width"], f"{key}.width", 1, MAX_IMAGE_SIDE)
    height = c.integer(o["height"], f"{key}.height", 1, MAX_IMAGE_SIDE)
    check_image_size(width, height, c, key)
    fwd = target - origin
    if np.linalg.norm(fwd) == 0.0:
        c.fail(f"{key}.target", "the target coincides with the origin")
    if np.linalg.norm(np.cross(fwd, up)) <= 1e-9 * np.linalg.norm(fwd) * np.linalg.norm(up):
        c.fail(f"{key}.up", "the up vector is zero or parallel to the viewing direction")
    aperture = c.number(o.get("aperture_radius", 0.0), f"{key}.aperture_radius", 0.0, GEOMETRY_LIMIT)
    focus = None
    if "focus_distance" in o:
        focus = c.number(o["focus_distance"], f"{key}.focus_distance", 0.0, GEOMETRY_LIMIT, lo_open=True)
    pf = parse_filter(o["filter"], f"{key}.filter") if "filter" in o else BOX
    crop = _crop(c, o["crop"], f"{key}.crop", width, height) if "crop" in o else None
    near = c.number(o.get("near_clip", 0.0), f"{key}.near_clip", 0.0, GEOMETRY_LIMIT)
    far = None
    if "far_clip" in o:
        far = c.number(o["far_clip"], f"{key}.far_clip", near, GEOMETRY_LIMIT, lo_open=True)
    return Camera(origin, target, up, fov, width, height, aperture, focus, pf, crop, near, far)


def _crop(c: _Checker, v: Any, key: str, width: int, height: int) -> tuple[int, int, int, int] | None:
    """``camera.crop``: ``{"offset": [x, y], "size": [w, h]}`` inside the width x height film."""
    o = c.obj(v, key, ("offset", "size"), ())
    off, size = o["offset"], o["size"]
    for name, pair in (("offset", off), ("size", size)):
        if not isinstance(pair, list) or len(pair) != 2:
            c.fail(f"{key}.{name}", f"expected [x, y], got {pair!r}")
    ox = c.integer(off[0], f"{key}.offset[0]", 0, width - 1)
    oy = c.integer(off[1], f"{key}.offset[1]", 0, height - 1)
    cw = c.integer(size[0], f"{key}.size[0]", 1, width - ox)
    ch = c.integer(size[1], f"{key}.size[1]", 1, height - oy)
    return None if (ox, oy, cw, ch) == (0, 0, width, height) else (ox, oy, cw, ch)


def _integrator(c: _Checker, v: Any, key: str) -> dict:
    o = c.obj(v, key, (), ("type", "max_depth", "rr_depth", "spp", "light_sampler", "sampler", "batches"))
    settings = check_integrator_settings(
        o.get("type", DEFAULT_INTEGRATOR), o.get("max_depth", DEFAULT_MAX_DEPTH),
        o.get("rr_depth", DEFAULT_RR_DEPTH), o.get("spp", DEFAULT_SPP), c, key,
        light_sampler=o.get("light_sampler", DEFAULT_LIGHT_SAMPLER),
    )
    settings["sampler"] = c.string(o.get("sampler", DEFAULT_RENDER_SAMPLER), f"{key}.sampler", RENDER_SAMPLERS)
    if settings["sampler"] == "sobol" and settings["integrator"] == "lt":
        # a file that asks for both contradicts itself (a --integrator lt override only declines the
        # scene's sobol: mcocl/render/api.py)
        c.fail(f"{key}.sampler", f"\"sobol\" works with path, nee, mis and bdpt, not {settings['integrator']!r}")
    if "batches" in o:
        # sobol's independent scramblings per pixel (mcocl/render/sobol_film.py): at least 2 for a variance;
        # with auto they choose sobol, which every integrator but lt has (as the batches keyword does)
        if settings["sampler"] == "auto" and settings["integrator"] != "lt":
            settings["sampler"] = "sobol"
        if settings["sampler"] != "sobol":
            c.fail(f"{key}.batches", "applies to the sobol sampler only, which works with path, nee, mis and "
                   f"bdpt; here the sampler is {settings['sampler']!r} and the integrator "
                   f"{settings['integrator']!r}")
        settings["batches"] = c.integer(o["batches"], f"{key}.batches", 2, MAX_SPP)
    return settings


def check_integrator_settings(integrator: Any, max_depth: Any, rr_depth: Any, spp: Any,
                              checker: _Checker | None = None, key: str = "integrator",
                              light_sampler: Any = DEFAULT_LIGHT_SAMPLER) -> dict:
    """Validate integrator settings (from a file or from command-line overrides).

    ``max_depth`` follows Mitsuba 3: -1 unbounded, 1 emitters seen directly,
    2 direct light only; ``rr_depth`` (>= 1) is the depth from which Russian
    roulette may stop a path; ``light_sampler`` one of :data:`LIGHT_SAMPLERS`.
    """
    c = checker or _Checker("settings")
    return {
        "integrator": c.string(integrator, f"{key}.type", INTEGRATORS),
        "max_depth": c.integer(max_depth, f"{key}.max_depth", -1, MAX_DEPTH_LIMIT),
        "rr_depth": c.integer(rr_depth, f"{key}.rr_depth", 1, MAX_DEPTH_LIMIT),
        "spp": c.integer(spp, f"{key}.spp", 1, MAX_SPP),
        "light_sampler": c.string(light_sampler, f"{key}.light_sampler", LIGHT_SAMPLERS),
    }


def _materials(c: _Checker, v: Any, key: str, roots: list[Path]) -> tuple[list[Material], dict[str, int]]:
    if not isinstance(v, dict):
        c.fail(key, f"expected an object mapping names to materials, got {_kind(v)}")
    out: list[Material] = []
    index: dict[str, int] = {}
    for name, m in v.items():
        k = f"{key}.{name}"
        if name == "comment":
            continue
        if not isinstance(m, dict):
            c.fail(k, f"expected a material object, got {_kind(m)}")
        kind = c.string(m.get("type"), f"{k}.type", MATERIAL_KINDS) if "type" in m else c.fail(f"{k}.type", "missing required key")
        out.append(_material(c, m, k, name, BSDFS[kind], roots))
        index[name] = len(out) - 1
    return out, index


def _material(c: _Checker, m: dict, key: str, name: str, spec: BsdfSpec, roots: list[Path]) -> Material:
    """One material of a registered BSDF: its keys validated as the registration declares them."""
    required = tuple(p.key for p in spec.params if p.default is None and not p.optional)
    o = c.obj(m, key, ("type", *required), tuple(p.key for p in spec.params if p.default is not None or p.optional))
    given: dict[str, object] = {}
    textures: dict[str, Texture] = {}
    for p in spec.params:
        if p.optional and p.key not in o:
            continue
        raw, pk = o.get(p.key, p.default), f"{key}.{p.key}"
        if isinstance(raw, dict) and not p.texturable:
            which = [f"{s.name}.{q.key}" for s in BSDFS.values() for q in s.params if q.texturable]
            c.fail(pk, f"takes no texture (keys that do: {', '.join(which)})")
        if isinstance(raw, dict):
            text = json.dumps(raw, sort_keys=True)
            tex = c.textures.get(text) or parse_texture(c, raw, pk, roots, _transform)
            textures[p.field] = c.textures[text] = tex
            raw = tex.mean().tolist() if p.kind == "rgb" else float(np.clip(tex.mean() @ LUMINANCE, p.lo, p.hi))
            if p.field == "alpha" and any(k in o for k in ("alpha_u", "alpha_v")):
                c.fail(pk, "a roughness texture takes the place of alpha_u/alpha_v: give one or the other")
        if p.kind in ("flag", "choice", "name"):
            given[p.key] = c.boolean(raw, pk) if p.kind == "flag" else c.string(raw, pk, p.choices)
            continue
        given[p.key if p.derived else p.field] = c.rgb(raw, pk) if p.kind == "rgb" else \
            c.number(raw, pk, p.lo, p.hi, lo_open=p.lo_open, hi_open=p.hi_open)
    values = record_values(spec, given)
    bad = spec.derive(values) or spec.check(values)
    if bad is not None:
        c.fail(f"{key}.{bad[0]}", bad[1])
    flags = int(values["flags"]) | spec.texture_flags(values, set(textures))  # type: ignore[call-overload]
    return Material(name, spec.name, np.array(values["rgb"], np.float64).reshape(3), alpha=float(values["alpha"]),
                    int_ior=float(values["int_ior"]), ext_ior=float(values["ext_ior"]), flags=flags,
                    alpha_second=float(values["alpha_second"]),  # type: ignore[arg-type]
                    eta_rgb=np.array(values["eta_rgb"], np.float64).reshape(3),
                    k_rgb=np.array(values["k_rgb"], np.float64).reshape(3),
                    transmittance_rgb=np.array(values["transmittance_rgb"], np.float64).reshape(3), textures=textures)


def _transform(c: _Checker, v: Any, key: str) -> np.ndarray:
    if isinstance(v, dict):
        v = [v]
    if not isinstance(v, list):
        c.fail(key, f"expected a list of operations, got {_kind(v)}")
    ops = []
    for i, op in enumerate(v):
        k = f"{key}[{i}]"
        if not isinstance(op, dict):
            c.fail(k, f"expected an object with one of translate, rotate, scale, matrix; got {_kind(op)}")
        names = [n for n in op if n != "comment"]
        if len(names) != 1:
            c.fail(k, "each operation is an object with exactly one of: translate, rotate, scale, matrix")
        c.obj(op, k, (), ("translate", "rotate", "scale", "matrix"))
        name = names[0]
        val, kk = op[name], f"{k}.{name}"
        if name == "translate":
            ops.append(tf.translate(c.vector(val, kk, limit=GEOMETRY_LIMIT)))
        elif name == "rotate":
            r = c.obj(val, kk, ("axis", "angle"))
            axis = c.vector(r["axis"], f"{kk}.axis", limit=GEOMETRY_LIMIT)
            if np.linalg.norm(axis) == 0.0:
                c.fail(f"{kk}.axis", "the rotation axis is zero")
            ops.append(tf.rotate(axis, c.number(r["angle"], f"{kk}.angle")))
        elif name == "scale":
            s = (c.vector(val, kk, limit=GEOMETRY_LIMIT) if isinstance(val, list)
                 else np.full(3, c.number(val, kk, -GEOMETRY_LIMIT, GEOMETRY_LIMIT)))
            if np.any(np.abs(s) < 1.0 / GEOMETRY_LIMIT):
                c.fail(kk, "a scale factor of zero flattens the shape")
            ops.append(tf.scale(s))
        else:
            if not isinstance(val, list) or len(val) not in (3, 4):
                c.fail(kk, "expected 4 rows of 4 numbers (or 3 rows: the affine part)")
            rows = [c.vector(r, f"{kk}[{j}]", 4, limit=GEOMETRY_LIMIT) for j, r in enumerate(val)]
            m = np.eye(4)
            m[: len(rows)] = np.array(rows)
            if len(rows) == 4 and not np.allclose(m[3], [0, 0, 0, 1]):
                c.fail(f"{kk}[3]", "the last row must be [0, 0, 0, 1] (affine transforms only)")
            if abs(np.linalg.det(m[:3, :3])) < 1e-12:
                c.fail(kk, "the matrix is singular")
            ops.append(m)
    out = tf.compose(ops)
    if not np.all(np.abs(out) <= GEOMETRY_LIMIT):
        c.fail(key, f"the composed transform has entries beyond {GEOMETRY_LIMIT:g} (float32 geometry would overflow)")
    return out


def _shape(c: _Checker, v: Any, key: str, materials: dict[str, int], roots: list[Path]) -> Shape:
    common = ("material",)
    optional = ("transform", "flip_normals", "emitter", "name")
    if not isinstance(v, dict):
        c.fail(key, f"expected a shape object, got {_kind(v)}")
    if "type" not in v:
        c.fail(f"{key}.type", "missing required key")
    kind = c.string(v["type"], f"{key}.type", SHAPE_KINDS)
    spec = SHAPES[kind]
    o = c.obj(v, key, ("type", *common), optional + spec.keys)
    mname = c.string(o["material"], f"{key}.material")
    if mname not in materials:
        known = ", ".join(materials) or "none"
        c.fail(f"{key}.material", f"unknown material {mname!r} (defined: {known})")
    m = _transform(c, o.get("transform", []), f"{key}.transform")
    shp = Shape(kind, key, materials[mname], m,
                flip_normals=c.boolean(o.get("flip_normals", False), f"{key}.flip_normals"),
                name=c.string(o.get("name", ""), f"{key}.name"))
    if "emitter" in o:
        e = c.obj(o["emitter"], f"{key}.emitter", ("type", "radiance"))
        c.string(e["type"], f"{key}.emitter.type", ("area",))
        if isinstance(e["radiance"], dict):
            # a textured emitter: the texture at the point's (u, v) (kernels/render/lights.cl); its mean
            # texel stands for it where one number is needed (the power of light choice)
            text = json.dumps(e["radiance"], sort_keys=True)
            tex = c.textures.get(text) or parse_texture(c, e["radiance"], f"{key}.emitter.radiance", roots, _transform)
            shp.radiance_texture = c.textures[text] = tex
            shp.radiance = tex.mean()
        else:
            shp.radiance = c.rgb(e["radiance"], f"{key}.emitter.radiance")
    spec.build(c, o, key, shp, roots)
    return shp


__all__ = [
    "INTEGRATORS",
    "LIGHT_SAMPLERS",
    "MATERIAL_KINDS",
    "SHAPE_KINDS",
    "Camera",
    "Material",
    "Scene",
    "Shape",
    "check_integrator_settings",
    "parse_scene",
]
