"""The compiled scene: flat, C-contiguous arrays that the render kernels read.

This module is the contract between the scene half (loading, geometry, BVH)
and the integrator half (camera, BSDFs, lights, megakernel) of the renderer.

Arrays of :class:`CompiledScene` (all C-contiguous):

- ``width``, ``height``: image size in pixels.
- ``camera``: float32 (4, 4), rows ``origin, right, up, forward``; the w of
  ``origin`` is the thin lens's aperture radius (0: a pinhole), the w of
  ``right`` its focus distance (0 for a pinhole), the others 0.
  A film point (sx, sy) in pixels (sx in [0, W), sy in [0, H), row 0 = top of
  the image, column 0 = left) looks along
  ``normalize(forward + ndc_x·right + ndc_y·up)`` with ``ndc_x = 2·sx/W − 1``,
  ``ndc_y = 1 − 2·sy/H``; ``right``/``up`` are pre-scaled by tan(fov/2) and the
  aspect ratio so that ``fov`` is the full angle on the smaller image axis.
  ``forward`` is a unit vector; right = forward × up (world), so at the
  Cornell camera (0, 0, 3.9) → origin, +x is on the right of the image.
- ``tri_vertices``: float32 (T, 3, 3): v0, v1, v2 in world space (the kernels read
  them only through the BVH's leaf records, :mod:`mcocl.render.bvh_leaves`: no
  padding to float4, 12 bytes a triangle less on the host).
  The front side is counter-clockwise: normal = normalize(cross(v1 − v0, v2 − v0));
  mirroring transforms and ``flip_normals`` are already applied by swapping
  v1 and v2.
- ``spheres``: float32 (S, 4): centre xyz, radius (world space);
  ``sphere_flip``: uint32 (S,), 1 when the front normal points inwards.
- Primitive ids: ``p < T`` is triangle ``p``; ``p >= T`` is sphere ``p − T``.
  ``prim_shape``: uint32 (T + S,): the shape each primitive belongs to.
- ``bvh_nodes`` (float32 (1 + 4K, 4)), ``bvh_prims`` (uint32): see
  :mod:`mcocl.render.bvh`; kernels use them only through ``render/bvh.cl``.
  Degenerate triangles (zero area) are left out of the BVH: no ray hits them.
  ``bvh_nodes`` is the first rows of the kernels' BVH table, ``device_bvh``
  (:class:`mcocl.render.bvh_leaves.DeviceBVH`, made by :func:`compile_scene`),
  so its header's ``leaf_row`` is 1 + 4K, the row after it in that table.
- ``shape_material``: uint32 (num_shapes,); ``shape_emitter``: int32
  (num_shapes,), index into ``emitter_radiance`` or −1.
- ``materials``: float32 (M + T, 20), one :data:`mcocl.layouts.MATERIAL_RECORD` per row, then T rows of
  the materials' tables (roughplastic: mcocl/render/roughplastic_tables.py):
  ``[kind, r, g, b, alpha, int_ior, ext_ior, 0]`` with kind a
  :class:`mcocl.layouts.MaterialKind` code (:data:`MATERIAL_CODES` by name);
  (r, g, b) = albedo (diffuse) or specular reflectance (conductors, dielectrics).
- ``emitter_radiance``: float32 (E, 4): RGB radiance (a textured emitter's mean texel), texture id + 1 or 0
  (render/texture_table.py).
- ``light_prims``: uint32 (L,): every primitive of every emissive shape
  with non-zero area, in primitive-id order.
- ``light_cdf``: float32 (L + 1,): CDF over ``light_prims`` proportional to
  power = luminance(radiance)·area·π (luminance = 0.2126 R + 0.7152 G +
  0.0722 B), or uniform when ``light_sampler`` is ``"uniform"``;
  ``light_cdf[0] = 0``, ``light_cdf[L] = 1``.  With no light
  (or only black ones) L = 0 and ``light_cdf = [0]``.
- ``light_power``: float64 (L,): the power of each light primitive.
- ``delta_lights``: the scene's point, spot and directional lights
  (:mod:`mcocl.render.delta_lights`), D of them; ``delta_power`` float64
  (D,) their choice powers.  With D > 0, ``light_cdf`` and ``light_pmf``
  run over the L light primitives and then the D delta lights (L + D
  entries; the kernel's light records follow the same order).
- ``light_sampler``: ``"power"``, ``"uniform"`` or ``"bvh"``, what the
  scene's ``"auto"`` resolves to (``resolve_light_sampler`` of
  :mod:`mcocl.render.emitter_choice`; the BVH's tables come from
  :mod:`mcocl.render.light_bvh`).
- ``light_pmf``: float32 (L,): the exact probability with which CDF inversion
  picks light i when an area light is chosen — the share of the uniforms' 2^23
  grid cells mapped to it (:mod:`mcocl.render.emitter_choice`), which the
  kernel's records carry too (extension of the contract).
- ``env_threshold``, ``env_pmf`` (properties: they follow ``integrator``,
  :func:`mcocl.render.emitter_choice.environment_choice`): light sampling
  picks the constant environment when a uniform is below ``env_threshold``,
  i.e. with exact probability ``env_pmf``, else an area light (probability
  ``(1 − env_pmf)·light_pmf[i]``); ``env_share``, when set, overrides the
  rule (for measurements).
- ``prim_light``: int32 (T + S,): index of a primitive in ``light_prims``,
  −1 if it is not a light (for the MIS weight of an emitter hit by BSDF
  sampling). (extension of the contract)
- ``light_area``: float32 (L,): surface area of each light primitive.
- ``env_radiance``: float32 (4,): RGB of the constant environment, 0 (all
  zero = no environment); (1, 1, 1, 1) with an environment map.
- ``env_map``: the :class:`~mcocl.render.envmap.EnvMap` or None; its device
  tables come from :func:`mcocl.render.envmap.envmap_tables`.
- ``integrator`` (str), ``max_depth``, ``rr_depth``, ``spp`` (int): Mitsuba 3
  conventions (max_depth −1 unbounded, 1 emitters seen directly, 2 direct
  light only).
- ``bounds``: float32 (2, 3) world box of all geometry (zeros when empty).
- ``source``: the scene file.

What the kernels read is derived from these arrays in one place,
:mod:`mcocl.render.device_scene` (``scene_tables``; ``scene_buffers`` uploads
them, cached per context in ``buffer_cache``; ``geom_args`` gives the seven
kernel arguments declared by ``SCENE_GEOM_PARAMS`` in ``render/intersect.cl``).
"""

from __future__ import annotations

import dataclasses
import math
import threading
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..bsdf_registry import RECORD_FIELDS
from ..errors import InputError
from ..host_memory import release_free_heap
from ..layouts import CAMERA_RECORD, MATERIAL_RECORD, MaterialKind
from . import transform as tf
from .bvh import BVH, C_TRAV, build_bvh
from .bvh_leaves import DeviceBVH, adopt_bvh
from .delta_lights import delta_power
from .emitter_choice import LUMINANCE, bounding_sphere, environment_choice, light_choice, resolve_light_sampler
from .envmap import EnvMap
from .pixel_filter import BOX, PixelFilter
from .roughplastic_tables import append_tables
from .scene import Scene, check_integrator_settings
from .scene_file import load_scene
from .shading_normals import corner_normals, vertex_normal_table
from .shape_registry import SHAPES
from .texture_table import emitter_texture_code, scene_textures, texture_table

# Primitives up to which compile_scene builds the binned SAH tree (see there).
BINNED_UP_TO = 200_000

MATERIAL_CODES = {kind.name.lower(): int(kind) for kind in MaterialKind}


@dataclass
class CompiledScene:
    """A scene as flat arrays for the kernels (see the module docstring for every field)."""

    width: int
    height: int
    camera: np.ndarray
    tri_vertices: np.ndarray
    spheres: np.ndarray
    sphere_flip: np.ndarray
    prim_shape: np.ndarray
    bvh_nodes: np.ndarray
    bvh_prims: np.ndarray
    shape_material: np.ndarray
    shape_emitter: np.ndarray
    materials: np.ndarray
    emitter_radiance: np.ndarray
    light_prims: np.ndarray
    light_cdf: np.ndarray
    light_pmf: np.ndarray
    prim_light: np.ndarray
    light_area: np.ndarray
    env_radiance: np.ndarray
    integrator: str
    max_depth: int
    rr_depth: int
    spp: int
    bounds: np.ndarray
    source: Path | None = None
    env_share: float | None = None
    light_power: np.ndarray = field(default_factory=lambda: np.zeros(0))
    light_sampler: str = "power"
    delta_lights: list = field(default_factory=list)
    delta_power: np.ndarray = field(default_factory=lambda: np.zeros(0))
    env_map: EnvMap | None = None
    sampler: str = "auto"  # integrator.sampler (mcocl/render/sobol_film.py; auto: mcocl/render/sampler_choice.py)
    batches: int | None = None  # integrator.batches: sobol's batches per pixel (None: the default)
    pixel_filter: PixelFilter = BOX  # the camera's reconstruction filter (mcocl/render/pixel_filter.py)
    # the indexed vertex normals of the triangles that shade smoothly (T + V, 4), None if none does: the kernels'
    # vertex_normals table (render/shading_normals.py; the property vertex_normals gives them per corner)
    normal_table: np.ndarray | None = None
    # the one table of the scene's textures and surface UVs, None if no material is textured (render/texture_table.py)
    textures: np.ndarray | None = None
    near_clip: float = 0.0  # camera.near_clip (kernels/render/camera.cl, camera_clip_origin)
    far_clip: float | None = None  # camera.far_clip (kernels/render/camera.cl, camera_beyond_far_clip)
    shape_names: list[str] = field(default_factory=list)
    bvh_stats: dict = field(default_factory=dict)
    # The kernels' BVH table, made by compile_scene from the builder's tree, of which bvh_nodes is a view
    # (render/bvh_leaves.py; device_scene.scene_tables makes it again for a scene whose arrays were replaced).
    device_bvh: DeviceBVH | None = field(default=None, repr=False, compare=False)
    # Device buffers of mcocl.render.device_scene.scene_buffers, per OpenCL context.
    buffer_cache: dict = field(default_factory=dict, repr=False, compare=False)
    buffer_lock: threading.Lock = field(default_factory=threading.Lock, repr=False, compare=False)

    @property
    def vertex_normals(self) -> np.ndarray | None:
        """(T, 3, 4) corner normals of the triangles (w 1 where a triangle shades smoothly, zeros where not),
        None if none does: ``normal_table`` expanded (:func:`~mcocl.render.shading_normals.corner_normals`)."""
        return corner_normals(self.normal_table, self.num_triangles)

    @property
    def num_triangles(self) -> int:
        """T, the number of triangles."""
        return int(self.tri_vertices.shape[0])

    @property
    def num_spheres(self) -> int:
        """S, the number of spheres."""
        return int(self.spheres.shape[0])

    @property
    def num_lights(self) -> int:
        """L, the number of emissive primitives."""
        return int(self.light_prims.shape[0])

    @property
    def num_delta(self) -> int:
        """D, the number of point, spot and directional lights."""
        return len(self.delta_lights)

    @property
    def num_choices(self) -> int:
        """L + D, the entries of the light-choice table (the kernel's light records)."""
        return self.num_lights + self.num_delta

    @property
    def env_threshold(self) -> float:
        """Light sampling chooses the environment when a uniform is below this (see ``env_pmf``)."""
        return environment_choice(self.env_radiance, self.num_choices > 0, self.integrator, self.env_share,
                                  self.env_map is not None)[0]

    @property
    def env_pmf(self) -> float:
        """The exact probability that light sampling chooses the environment (:mod:`.emitter_choice`)."""
        return environment_choice(self.env_radiance, self.num_choices > 0, self.integrator, self.env_share,
                                  self.env_map is not None)[1]

    def without_primitives(self) -> CompiledScene:
        """A copy without the per-primitive arrays (empty ones, or None, in their place): the settings, camera,
        bounds, materials and lights' scalars only.

        :func:`mcocl.render.render` keeps only this of a scene it compiled itself once the device tables are
        built from it, so that the triangles, the shading normals' and the primitive maps' host arrays (60 MB for
        10^6 triangles, bench/scene_memory.py) are not held through the render: the tables have what the
        kernels need.  No table can be built from the copy.
        """
        return dataclasses.replace(
            self, tri_vertices=np.zeros((0, 3, 3), np.float32), prim_shape=np.zeros(0, np.uint32),
            prim_light=np.zeros(0, np.int32), bvh_nodes=np.zeros((0, 4), np.float32), bvh_prims=np.zeros(0, np.uint32),
            normal_table=None, textures=None, device_bvh=None, buffer_cache={}, buffer_lock=threading.Lock())

    def with_settings(self, integrator: str | None = None, max_depth: int | None = None,
                      rr_depth: int | None = None, spp: int | None = None,
                      light_sampler: str | None = None) -> CompiledScene:
        """Override the integrator settings in place (validated); returns ``self``.

        A new ``light_sampler`` recomputes the area-light choice (``light_cdf``,
        ``light_pmf``) from ``light_power``.

        Raises:
            InputError: a setting is invalid (e.g. integrator 'foo', spp 0).
        """
        s = check_integrator_settings(
            self.integrator if integrator is None else integrator,
            self.max_depth if max_depth is None else max_depth,
            self.rr_depth if rr_depth is None else rr_depth,
            self.spp if spp is None else spp,
            key="settings",
            light_sampler=self.light_sampler if light_sampler is None else light_sampler,
        )
        s["light_sampler"] = resolve_light_sampler(s["light_sampler"], self.num_lights, len(self.delta_lights))
        self.integrator, self.max_depth, self.rr_depth, self.spp = (
            s["integrator"], s["max_depth"], s["rr_depth"], s["spp"])
        directional = [li for li in self.delta_lights if li.kind == "directional"]
        if s["light_sampler"] == "bvh" and directional:
            raise InputError(f"light_sampler 'bvh': the scene has a directional light ({directional[0].key}); "
                             f"the light BVH holds lights at finite positions only (use 'power' or 'uniform')")
        if s["light_sampler"] != self.light_sampler:
            self.light_sampler = s["light_sampler"]
            if self.num_choices:
                self.light_cdf, self.light_pmf = light_choice(np.concatenate([self.light_power, self.delta_power]),
                                                              self.light_sampler)
            with self.buffer_lock:
                self.buffer_cache.clear()
        return self


def camera_matrix(origin: np.ndarray, target: np.ndarray, up: np.ndarray, fov: float,
                  width: int, height: int, aperture_radius: float = 0.0,
                  focus_distance: float | None = None,
                  crop: tuple[int, int, int, int] | None = None) -> np.ndarray:
    """The (4, 4) float32 camera rows ``origin, right, up, forward`` of the contract.

    A thin lens (``aperture_radius`` > 0) focuses at ``focus_distance`` along
    ``forward`` (None: the distance from ``origin`` to ``target``).  ``crop``
    (offset x, offset y, width, height in pixels of the ``width`` x ``height``
    film) renders that window: ``right``/``up`` span the crop and
    crop_shift_x/y place its centre (kernels/render/camera.cl).
    """
    fwd = np.asarray(target, np.float64) - origin
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, fwd)
    t = math.tan(math.radians(fov) / 2.0)
    # fov spans the smaller axis; the other axis extends by the aspect ratio.
    sx, sy = (t * width / height, t) if width >= height else (t, t * height / width)
    cam = np.zeros(1, CAMERA_RECORD.dtype())
    if crop is not None:
        ox, oy, cw, ch = crop
        # full-film ndc = crop ndc * (cw / W) + (2 ox + cw) / W - 1 (rows count downwards: 1 - (2 oy + ch) / H)
        sx, sy = sx * cw / width, sy * ch / height
        cam["crop_shift_x"] = ((2.0 * ox + cw) / width - 1.0) * width / cw
        cam["crop_shift_y"] = (1.0 - (2.0 * oy + ch) / height) * height / ch
    cam["origin"], cam["right"], cam["up"], cam["forward"] = origin, right * sx, true_up * sy, fwd
    if aperture_radius > 0.0:
        dist = float(np.linalg.norm(np.asarray(target, np.float64) - origin))
        cam["aperture_radius"] = aperture_radius
        cam["focus_distance"] = dist if focus_distance is None else focus_distance
    return cam.view(np.float32).reshape(4, 4)


# Faces per block of _shape_triangles' gather (its intp copy of a block's indices: 1.5 MB).
_GATHER_FACES = 1 << 16


def _shape_triangles(shape, path, out: np.ndarray) -> None:
    """Write the world-space triangles of a mesh-like shape into ``out`` (n, 3, 3) float32.

    The front side is counter-clockwise.  The vertices are transformed in
    float64 and rounded to float32 once per vertex, then gathered per face
    straight into ``out``: the same numbers as
    rounding each gathered float64 triangle, with a fifth of the float64 work
    and no (n, 3, 3) intermediate; both steps a block at a time, so that no
    float64 table of every vertex nor intp copy of every face is made.

    Raises:
        InputError: the transform made a vertex of a face non-finite.
    """
    # a file's float32 vertices widen here, exactly (mcocl/render/ply_reader.py keeps them float32), a block
    # at a time: no float64 table of every vertex (issue 13)
    v32, finite = tf.apply_points_float32(shape.matrix, shape.vertices)
    f = shape.faces
    corners = [0, 2, 1] if tf.is_orientation_reversing(shape.matrix) != shape.flip_normals else slice(None)
    if len(f) and (f.min() < 0 or f.max() >= len(v32)):  # (the scene's parser checks this already)
        raise InputError(f"{path}: a face of shape {shape.key} indexes a vertex outside 0..{len(v32) - 1}")
    # (a non-finite vertex that no face uses is allowed: the per-face test only runs when one exists)
    if not finite.all() and not finite[f].all():
        raise InputError(f"{path}: a transform produced non-finite vertices")
    del finite
    # mode "clip" (the indices are in range): "raise" would gather into a temporary table of out's size first;
    # a block of faces at a time, since take makes an intp copy of the indices it is given (a file's uint32
    # faces: 63 MB for 2.6 * 10^6 triangles, the peak of this step, bench/load_memory.py's 33 MB serialized mesh)
    for s in range(0, len(f), _GATHER_FACES):
        # (the corners swapped block by block too: no reordered copy of every face)
        np.take(v32, f[s:s + _GATHER_FACES, corners], axis=0, out=out[s:s + _GATHER_FACES], mode="clip")


def _corner_extreme(tri: np.ndarray, op: np.ufunc) -> np.ndarray:
    """``op.reduce(tri[:, :, :3], axis=1)`` (the box corner of each triangle (T, 3, 3)), as three elementwise passes.

    The reduction over the middle axis is several times slower than
    ``op(op(v0, v1), v2)``; both give the same numbers except possibly the sign
    of a zero (which of two equal zeros a min/max returns depends on the order
    of evaluation), so rows with a zero in the result are taken from the reduction itself.
    """
    out = op(op(tri[:, 0, :3], tri[:, 1, :3]), tri[:, 2, :3])
    if not out.all():
        zero = np.unique(np.flatnonzero(out == 0) // 3)
        out[zero] = op.reduce(tri[zero, :, :3], axis=1)
    return out


def _primitive_boxes(tri: np.ndarray, good: np.ndarray, spheres: np.ndarray, op: np.ufunc) -> np.ndarray:
    """Lower (``op`` = np.minimum) or upper (np.maximum) box corners (N, 3) float32 of the BVH's primitives.

    The triangles (T, 3, 3) marked ``good``, then the spheres (S, 4); the
    boxes of float32 vertices are float32 values (no float64 round trip).
    """
    box = _corner_extreme(tri, op)
    if not good.all():
        box = box[good]
    c, r = spheres[:, :3], spheres[:, 3:]
    return np.concatenate([box, c - r if op is np.minimum else c + r])


# Triangles per chunk of compile_scene's float64 area work: its temporaries stay in cache.
_AREA_CHUNK = 1 << 15


def _triangle_areas(tri_vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Float64 area of each float32 triangle (T, 3, 3) and whether it is non-degenerate, as the kernels see it.

    Degenerate: zero area, or so thin that its normal is numerical noise (sin angle < 1e-6).
    The same float64 operations, in the same order, as ``np.cross`` and
    ``np.linalg.norm``, chunk by chunk, on flat columns: a norm's sum of three
    squares is NumPy's sequential ``(x² + y²) + z²`` (its pairwise sum adds
    fewer than eight terms in order), without a reduction call per row.
    """
    n = len(tri_vertices)
    area = np.empty(n, np.float64)
    good = np.empty(n, bool)

    def norm(x: list[np.ndarray]) -> np.ndarray:
        out = x[0] * x[0]
        out += x[1] * x[1]
        out += x[2] * x[2]
        return np.sqrt(out, out=out)

    for s in range(0, n, _AREA_CHUNK):
        t = tri_vertices[s:s + _AREA_CHUNK]
        v0 = t[:, 0, :3].astype(np.float64)
        d1, d2 = t[:, 1, :3] - v0, t[:, 2, :3] - v0
        del v0
        e1, e2 = [d1[:, a] for a in range(3)], [d2[:, a] for a in range(3)]
        cr = [e1[a] * e2[b] - e1[b] * e2[a] for a, b in ((1, 2), (2, 0), (0, 1))]
        a2 = norm(cr)
        edge_scale = norm(e1)
        edge_scale *= norm(e2)
        part = area[s:s + len(t)]
        np.multiply(a2, 0.5, out=part)
        good[s:s + len(t)] = (part > 0) & (2.0 * part > 1e-6 * edge_scale)
    return area, good


def compile_scene(scene: Scene | str | Path, *, integrator: str | None = None, max_depth: int | None = None,
                  rr_depth: int | None = None, spp: int | None = None, max_leaf: int = 8,
                  bins: int = 16, traversal_cost: float = C_TRAV, all_axes: bool = True,
                  bvh_method: str | None = None, mesh_folder: str | Path | None = None) -> CompiledScene:
    """Flatten a scene (or scene file) into a :class:`CompiledScene`; keyword settings override the file's.

    ``max_leaf``, ``bins``, ``traversal_cost``, ``all_axes`` and
    ``bvh_method`` tune the BVH build (:func:`mcocl.render.bvh.build_bvh`).
    By default scenes of up to :data:`BINNED_UP_TO` primitives get the
    all-axes binned SAH tree (0.3 s at 10^5 triangles, the cheapest trees),
    larger ones the clustered build (10^6 triangles: about 0.6 CPU-s against
    3.5 s, for trees 3-15 % costlier by the SAH on the bench's meshes).
    ``mesh_folder`` lets a scene file read OBJ files from that folder too
    (:func:`mcocl.render.scene_file.load_scene`).

    Raises:
        InputError: the scene file or an override is invalid.
    """
    if not isinstance(scene, Scene):
        scene = load_scene(scene, mesh_folder=mesh_folder)
    tri_counts, spheres, sphere_flip, sphere_shape = [], [], [], []
    for k, sh in enumerate(scene.shapes):
        if SHAPES[sh.kind].sphere:
            s = tf.uniform_scale_of(sh.matrix)
            c = tf.apply_points(sh.matrix, sh.center)
            spheres.append([*c, sh.radius * s])
            sphere_flip.append(1 if sh.flip_normals else 0)
            sphere_shape.append(k)
        else:
            tri_counts.append(len(sh.faces))
    sph64 = np.array(spheres, np.float64).reshape(-1, 4)
    ntri, nsph = sum(tri_counts), len(sph64)
    tri_vertices = np.empty((ntri, 3, 3), np.float32)
    prim_shape = np.empty(ntri + nsph, np.uint32)
    start = 0
    for k, sh in enumerate(scene.shapes):  # each shape's triangles straight into the table: no concatenated copy
        if not SHAPES[sh.kind].sphere:
            _shape_triangles(sh, scene.path, tri_vertices[start:start + len(sh.faces)])
            prim_shape[start:start + len(sh.faces)] = k
            start += len(sh.faces)
    prim_shape[ntri:] = sphere_shape
    sph32 = sph64.astype(np.float32)

    # Degeneracy as the kernels will see it (from the float32 vertices); the areas only the lights need
    # are computed again for them below (the same numbers), rather than held through the BVH build.
    good_tri = _triangle_areas(tri_vertices)[1]
    sph_area = 4.0 * math.pi * sph32[:, 3].astype(np.float64) ** 2

    # BVH over the non-degenerate primitives.
    if good_tri.all():  # the same ids, without the int64 tables
        ids = np.arange(ntri + nsph, dtype=np.uint32)
    else:
        ids = np.concatenate([np.flatnonzero(good_tri), ntri + np.arange(nsph)]).astype(np.uint32)
    num_bvh = len(ids)
    method = bvh_method or ("binned" if num_bvh <= BINNED_UP_TO else "ploc")
    # The boxes are made in the call, with no name here: build_bvh holds the only references and drops
    # them once the tree holds them (24 MB less at the peak of a 10^6-triangle build).
    bvh: BVH = build_bvh(_primitive_boxes(tri_vertices, good_tri, sph32, np.minimum),
                         _primitive_boxes(tri_vertices, good_tri, sph32, np.maximum), ids, max_leaf=max_leaf,
                         bins=bins, traversal_cost=traversal_cost, all_axes=all_axes, method=method)
    # The device's BVH table now, while the builder's tree is the one copy of it: the scene keeps the tree as
    # the table's first rows, not a second copy (33 MB for 10^6 triangles, bench/scene_memory.py), and bvh
    # gives its nodes up to the table (adopt_bvh), so that the builder's copy is freed before the leaf records
    # and the wide nodes are written (33 MB less at that step's peak).
    del ids  # the builder's ids are bvh.prims now (4 MB for 10^6 triangles)
    geometry = adopt_bvh(bvh, tri_vertices, sph32)

    # Materials and emitters.
    mats = np.zeros(len(scene.materials), MATERIAL_RECORD.dtype())
    for i, m in enumerate(scene.materials):
        mats[i]["kind"] = MATERIAL_CODES[m.kind]
        for name in RECORD_FIELDS:  # the fields a BSDF registration packs into (mcocl/bsdf_registry.py)
            mats[i][name] = getattr(m, name)
    mats = mats.view(np.float32).reshape(len(scene.materials), MATERIAL_RECORD.itemsize // 4)
    # the materials' tables after the records (roughplastic; the record's `table` field points at them)
    mats = append_tables(scene.materials, mats, MATERIAL_RECORD.dtype().fields["table"][1] // 4)
    shape_material = np.array([sh.material for sh in scene.shapes], np.uint32)
    shape_emitter = np.full(len(scene.shapes), -1, np.int32)
    radiance = []
    textures = scene_textures(scene.materials, scene.shapes)
    for k, sh in enumerate(scene.shapes):
        if sh.radiance is not None:
            shape_emitter[k] = len(radiance)
            # w: the emitter's texture id + 1, 0 when constant (render/texture_table.py)
            radiance.append([*sh.radiance, emitter_texture_code(sh.radiance_texture, textures)])
    emitter_radiance = np.array(radiance, np.float32).reshape(-1, 4)

    # Lights: every primitive of an emissive shape, chosen in proportion to its power.
    prim_emitter = shape_emitter[prim_shape] if len(prim_shape) else np.zeros(0, np.int32)
    good_prim = np.concatenate([good_tri, sph_area > 0])
    is_light = (prim_emitter >= 0) & good_prim
    light_prims = np.flatnonzero(is_light).astype(np.uint32)
    lum = emitter_radiance[:, :3].astype(np.float64) @ LUMINANCE if len(radiance) else np.zeros(0)
    light_tris = light_prims[light_prims < ntri]
    light_prim_area = np.concatenate([_triangle_areas(tri_vertices[light_tris])[0],
                                      sph_area[light_prims[len(light_tris):].astype(np.int64) - ntri]])
    power = lum[prim_emitter[light_prims]] * light_prim_area * math.pi if len(light_prims) else np.zeros(0)
    del prim_emitter, good_prim, is_light  # a table of every primitive each: not held through the normals' peak
    bounds = np.ascontiguousarray(bvh.bounds if num_bvh else np.zeros((2, 3)), np.float32)
    # Point, spot and directional lights follow the light primitives in the choice table.
    dpower = delta_power(scene.lights, bounding_sphere(bounds)[1])
    sampler = resolve_light_sampler(scene.light_sampler, len(light_prims), len(scene.lights))
    cdf, pmf = light_choice(np.concatenate([power, dpower]), sampler)
    if len(pmf) == 0:
        light_prims = np.zeros(0, np.uint32)
        power = np.zeros(0)
        dpower = np.zeros(0)
    prim_light = np.full(ntri + nsph, -1, np.int32)
    prim_light[light_prims] = np.arange(len(light_prims), dtype=np.int32)
    light_area = light_prim_area[:len(light_prims)].astype(np.float32)

    env = np.zeros(4, np.float32)
    env[:3] = scene.env_radiance
    if scene.env_map is not None:
        env[:] = 1.0  # the map's radiance (kernels/render/envmap.cl); w > 0 marks a map
    cam = scene.camera
    cs = CompiledScene(
        width=cam.crop[2] if cam.crop else cam.width, height=cam.crop[3] if cam.crop else cam.height,
        camera=camera_matrix(cam.origin, cam.target, cam.up, cam.fov, cam.width, cam.height,
                             cam.aperture_radius, cam.focus_distance, cam.crop),
        tri_vertices=geometry.tri_vertices, spheres=geometry.spheres,
        sphere_flip=np.array(sphere_flip, np.uint32), prim_shape=prim_shape,
        bvh_nodes=geometry.nodes, bvh_prims=geometry.prims, device_bvh=geometry,
        shape_material=shape_material, shape_emitter=shape_emitter, materials=mats,
        emitter_radiance=emitter_radiance, light_prims=light_prims, light_cdf=cdf, light_pmf=pmf,
        prim_light=prim_light, light_area=light_area, env_radiance=env,
        light_power=power.astype(np.float64), light_sampler=sampler, sampler=scene.sampler,
        batches=getattr(scene, "batches", None),
        delta_lights=list(scene.lights) if len(dpower) else [], delta_power=dpower, env_map=scene.env_map,
        integrator=scene.integrator, max_depth=scene.max_depth, rr_depth=scene.rr_depth, spp=scene.spp,
        bounds=bounds, source=scene.path, pixel_filter=cam.pixel_filter,
        normal_table=vertex_normal_table(scene.shapes, tri_vertices[:, :, :3]), near_clip=cam.near_clip, far_clip=cam.far_clip,
        textures=texture_table(scene.materials, scene.shapes),
        shape_names=[sh.name or sh.key for sh in scene.shapes],
        bvh_stats={"nodes": bvh.num_nodes, "leaves": bvh.num_leaves, "depth": bvh.depth,
                   "prims": int(len(bvh.prims)), "degenerate_triangles": int((~good_tri).sum())},
    )
    # the BVH build's and the shading normals' freed temporaries would stay resident with the compiled scene
    # (190 MB over the start against 147 MB for 10^6 triangles, bench/scene_memory.py's compile stage)
    release_free_heap()
    return cs.with_settings(integrator, max_depth, rr_depth, spp)


def load_compiled(path: str | Path, **overrides) -> CompiledScene:
    """Load, validate and compile a scene file (``overrides`` as for :func:`compile_scene`)."""
    return compile_scene(load_scene(path), **overrides)


__all__ = ["LUMINANCE", "MATERIAL_CODES", "CompiledScene", "camera_matrix", "compile_scene",
           "load_compiled"]
