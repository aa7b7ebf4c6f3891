"""The scene as the kernels see it: one set of device tables for every consumer.

A :class:`~mcocl.render.compiled.CompiledScene` holds the scene as flat,
host-friendly arrays; :func:`scene_tables` turns it into the arrays the
OpenCL kernels read — the render megakernel (:mod:`mcocl.render.job`), the
ray-casting and primitive queries (:mod:`mcocl.render.raycast`, through
:func:`geom_args`), the light-sampling test kernels and the
benchmarks all upload these same tables, so that no consumer can see
another light-selection probability or another record layout.

The record layouts are :mod:`mcocl.layouts`' (``prim_record``,
``light_record``, ``material_record``, ``camera_record``), the C side of
which is the generated ``kernels/layouts.cl``.  The emitter-choice
probabilities are those :func:`~mcocl.render.compiled.compile_scene`
computed (:mod:`mcocl.render.emitter_choice`): exact on the uniforms' grid.
"""

from __future__ import annotations

import hashlib
import math

import numpy as np

from ..layouts import LIGHT_RECORD, PRIM_RECORD, RENDER_PARAMS, LightShape
from .bvh_leaves import device_geometry
from .caster_guiding import CASTER_REACH, CASTER_SHARE, caster_rows
from .compiled import CompiledScene
from .delta_lights import delta_records
from .envmap import envmap_tables
from .light_bvh import build_light_bvh

# What the render kernel reads for the light BVH in builds that do not use it (OpenCL has no empty buffers).
LIGHT_BVH_ABSENT = {"light_bvh": np.zeros((1, 4), np.float32), "light_trail": np.zeros(1, np.uint32)}


# Triangles per chunk of prim_records' float64 work: for 10^6 triangles its temporaries would be 200 MB at once;
# 2^14 keeps them (about 3 MB) below what the tables add next, so the tables' peak is the tables themselves.
_RECORD_CHUNK = 1 << 14


def _as_quads(rec: np.ndarray, width: int) -> np.ndarray:
    """A record array as float32 rows of ``width`` (the float4 tables the kernels gather from)."""
    return np.ascontiguousarray(rec).view(np.float32).reshape(-1, width)


def light_tables(cs: CompiledScene) -> dict[str, np.ndarray | float | int]:
    """The emitter-choice tables of kernels/render/lights.cl.

    ``prim_pmf`` (float32, one per primitive): the compiled scene's
    ``light_pmf`` scattered onto primitive ids (0 for primitives that do not
    emit); ``env_threshold``/``env_pmf``: the environment's choice;
    ``light_top``: the largest power of two <= the number of lights (the
    first step of the kernel's binary search over the L light primitives and
    D delta lights; 0 with no light).
    """
    nl = cs.num_lights
    prim_pmf = np.zeros(max(cs.num_triangles + cs.num_spheres, 1), np.float32)
    if nl:
        prim_pmf[cs.light_prims] = cs.light_pmf[:nl]
    nc = cs.num_choices
    top = 1 << (nc.bit_length() - 1) if nc else 0
    return {"prim_pmf": prim_pmf, "env_threshold": float(cs.env_threshold), "env_pmf": float(cs.env_pmf),
            "light_top": top}


def prim_records(cs: CompiledScene, prim_pmf: np.ndarray) -> np.ndarray:
    """One :data:`~mcocl.layouts.PRIM_RECORD` per primitive for the shading of a hit, as float32 (N, 8)."""
    nt, ns = cs.num_triangles, cs.num_spheres
    rec = np.zeros(max(nt + ns, 1), PRIM_RECORD.dtype())
    for s in range(0, nt, _RECORD_CHUNK):  # row by row the same numbers; float64 temporaries of a chunk only
        v = cs.tri_vertices[s:s + _RECORD_CHUNK, :, :3].astype(np.float64)
        cr = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
        length = np.linalg.norm(cr, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            rec["normal"][s:s + len(v)] = np.where(length[:, None] > 0, cr / length[:, None], 0.0)
        rec["area"][s:s + len(v)] = 0.5 * length
    if ns:
        rec["area"][nt:nt + ns] = 4.0 * math.pi * cs.spheres[:, 3].astype(np.float64) ** 2
        rec["inward"][nt:nt + ns] = cs.sphere_flip.astype(np.float32)
    for s in range(0, nt + ns, _RECORD_CHUNK):  # likewise: no int64 table of every primitive's shape
        shape = np.asarray(cs.prim_shape[s:s + _RECORD_CHUNK], np.int64)
        rec["material"][s:s + len(shape)] = cs.shape_material[shape]
        rec["emitter"][s:s + len(shape)] = cs.shape_emitter[shape]
    rec["pmf"][:nt + ns] = prim_pmf[:nt + ns]
    return _as_quads(rec, PRIM_RECORD.itemsize // 4)


def light_records(cs: CompiledScene, prim_pmf: np.ndarray) -> np.ndarray:
    """One :data:`~mcocl.layouts.LIGHT_RECORD` per light primitive for light sampling, then one per
    point, spot and directional light (:mod:`mcocl.render.delta_lights`), as float32 (4 (L + D), 4)."""
    nl, nt = cs.num_lights, cs.num_triangles
    rec = np.zeros(max(nl + cs.num_delta, 1), LIGHT_RECORD.dtype())
    if cs.num_delta:
        rec[nl:] = delta_records(cs.delta_lights, cs.light_pmf[nl:])
    if nl:
        lr = rec[:nl]
        prims = np.asarray(cs.light_prims, np.int64)
        emit = cs.shape_emitter[cs.prim_shape[prims]]
        lr["radiance"] = cs.emitter_radiance[emit, :3]
        lr["prim"] = prims.astype(np.uint32)
        lr["pmf"] = prim_pmf[prims]
        tri = prims < nt
        v = cs.tri_vertices[prims[tri], :, :3].astype(np.float64)
        t = lr[tri]
        t["base"] = v[:, 0]
        t["edge1"] = v[:, 1] - v[:, 0]
        t["edge2"] = v[:, 2] - v[:, 0]
        t["area"] = 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)
        t["shape"] = float(LightShape.TRIANGLE)
        lr[tri] = t
        s = prims[~tri] - nt
        c = cs.spheres[s].astype(np.float64)
        sp = lr[~tri]
        sp["base"] = c[:, :3]
        sp["area"] = 4.0 * math.pi * c[:, 3] ** 2
        sp["edge1"][:, 0] = c[:, 3]
        sp["shape"] = np.where(cs.sphere_flip[s] != 0, float(LightShape.SPHERE_INWARD), float(LightShape.SPHERE))
        lr[~tri] = sp
    return _as_quads(rec, 4)


def bvh_tables(cs: CompiledScene) -> tuple[np.ndarray, np.ndarray]:
    """The ``bvh_nodes`` table and ``tri_rows`` (:func:`~mcocl.render.bvh_leaves.device_geometry`): those
    compile_scene made (the scene's own, no copy) unless the scene's arrays were replaced since."""
    held = getattr(cs, "device_bvh", None)
    if held is not None and held.made_from(cs.bvh_nodes, cs.bvh_prims, cs.tri_vertices, cs.spheres):
        return held.table, held.tri_rows
    return device_geometry(cs.bvh_nodes, cs.bvh_prims, cs.tri_vertices, cs.spheres)


def scene_tables(cs: CompiledScene) -> dict[str, np.ndarray]:
    """Every array a kernel reads, as plain NumPy arrays (never empty: OpenCL has no empty buffers).

    The tables of ``SCENE_GEOM_PARAMS`` (``bvh_nodes``: the tree followed by
    its leaves' primitives in leaf order, :mod:`mcocl.render.bvh_leaves`, whose records hold the
    primitive ids; ``tri_rows``: where each triangle's record lies in ``bvh_nodes``, the kernels'
    one copy of the triangles; ``spheres``, ``sphere_flip``, ``geometry_counts``), the
    shading and light records, the materials, the emitter choice
    (``light_cdf``, ``prim_pmf``, ``light_scalars`` = (L, light_top),
    ``env_choice`` = (env_threshold, env_pmf)) and the environment ``env``;
    with ``light_sampler`` ``"bvh"`` also the light BVH (``light_bvh``
    nodes, ``light_trail`` per primitive; :mod:`mcocl.render.light_bvh`); with caustic casters
    their rows ``casters`` (:mod:`mcocl.render.caster_guiding`).
    """
    def nonempty(a: np.ndarray, dtype: type, width: int = 4) -> np.ndarray:
        a = np.ascontiguousarray(a, dtype=dtype)
        return a if a.size else np.zeros(width, dtype)

    nodes, tri_rows = bvh_tables(cs)
    lt = light_tables(cs)
    tables = {
        "camera": nonempty(cs.camera, np.float32),
        "bvh_nodes": nonempty(nodes, np.float32),
        "tri_rows": nonempty(tri_rows, np.uint32),
        "spheres": nonempty(cs.spheres, np.float32),
        "sphere_flip": nonempty(cs.sphere_flip, np.uint32),
        "prim_rec": prim_records(cs, lt["prim_pmf"]),
        "materials": nonempty(cs.materials, np.float32, 8),
        "emitter_radiance": nonempty(cs.emitter_radiance, np.float32),
        "light_rec": light_records(cs, lt["prim_pmf"]),
        "light_cdf": nonempty(cs.light_cdf, np.float32),
        "prim_pmf": nonempty(lt["prim_pmf"], np.float32),
        "env": np.array(cs.env_radiance[:4], np.float32),
        "light_scalars": np.array([cs.num_choices, lt["light_top"]], np.uint32),
        "env_choice": np.array([lt["env_threshold"], lt["env_pmf"]], np.float32),
        "geometry_counts": np.array([cs.num_triangles, cs.num_spheres], np.uint32),
    }
    if getattr(cs, "normal_table", None) is not None:  # only then: other scenes keep their tables digest
        tables["vertex_normals"] = np.ascontiguousarray(cs.normal_table, np.float32)
    if getattr(cs, "textures", None) is not None:  # likewise (render/texture_table.py)
        tables["textures"] = np.ascontiguousarray(cs.textures, np.float32)
    if cs.env_map is not None:
        tables["env_map"], tables["env_cdf"] = envmap_tables(cs.env_map)
    else:
        tables["env_map"], tables["env_cdf"] = np.zeros((1, 4), np.float32), np.zeros(1, np.uint32)
    casters = caster_rows(cs)
    if len(casters):  # only then: other scenes keep their tables digest
        tables["casters"] = casters
    if cs.light_sampler == "bvh":
        tree = build_light_bvh(cs)
        tables["light_bvh"], tables["light_trail"] = tree.nodes, tree.trail
    return tables


def scene_params(tables: dict[str, np.ndarray]) -> np.ndarray:
    """A ``render_params`` (mcocl/layouts.py) with the scene's fields filled from :func:`scene_tables`.

    The geometry counts, the emitter choice and the environment; the render
    job adds its launch fields (:meth:`mcocl.render.job.RenderJob.params`),
    the light test kernels use it as it is.
    """
    p = np.zeros((), RENDER_PARAMS.dtype())
    p["ntris"], p["nspheres"] = tables["geometry_counts"]
    p["nlights"], p["light_top"] = tables["light_scalars"]
    p["env_threshold"], p["env_pmf"] = tables["env_choice"]
    p["env_radiance"] = tables["env"]
    p["bdpt_only_s"] = p["bdpt_only_t"] = -1  # every strategy (the render job may pick one)
    p["bdpt_power_mis"] = 1  # the power heuristic, bdpt's default
    p["far_clip"] = np.inf  # no clip planes (near_clip 0): the render job sets the camera's
    casters = tables.get("casters")
    if casters is not None and len(casters):  # (render/caster_guiding.py; read by -DCASTER_GUIDING builds)
        rows = np.asarray(casters, np.float32)
        p["ncasters"] = len(rows)
        p["casters"][:4 * len(rows)] = rows[:, :4].reshape(-1)
        p["caster_axes"][:4 * len(rows)] = rows[:, 4:].reshape(-1)
        p["caster_share"] = CASTER_SHARE
        p["caster_reach"] = CASTER_REACH
    return p


def scene_buffers(cs: CompiledScene, ctx) -> dict:
    """One read-only pyopencl Buffer per array of :func:`scene_tables`, cached on ``cs`` per context."""
    from .table_buffers import table_buffer

    key = ctx.context.int_ptr
    with cs.buffer_lock:
        bufs = cs.buffer_cache.get(key)
        if bufs is None:
            # over the tables themselves where the device shares host memory (render/table_buffers.py)
            bufs = {name: table_buffer(ctx.context, ctx.device, a) for name, a in scene_tables(cs).items()}
            cs.buffer_cache[key] = bufs
        return bufs


def geom_args(cs: CompiledScene, ctx) -> list:
    """The kernel arguments of ``SCENE_GEOM_PARAMS`` (nodes, triangle rows, spheres, flips, T, S)."""
    b = scene_buffers(cs, ctx)
    return [b["bvh_nodes"], b["tri_rows"], b["spheres"], b["sphere_flip"],
            np.uint32(cs.num_triangles), np.uint32(cs.num_spheres)]


def tables_digest(tables: dict[str, np.ndarray]) -> str:
    """A short hash of the scene tables: a checkpoint must belong to the same scene."""
    h = hashlib.sha256()
    for name in sorted(tables):
        a = np.ascontiguousarray(tables[name])
        h.update(name.encode())
        h.update(str(a.dtype).encode())
        h.update(str(a.shape).encode())
        h.update(a.reshape(-1).view(np.uint8))  # the bytes in place: no copy of a 100 MB table
    return h.hexdigest()[:16]


__all__ = ["LIGHT_BVH_ABSENT", "bvh_tables", "geom_args", "light_records", "light_tables", "prim_records", "scene_buffers", "scene_params",
           "scene_tables", "tables_digest"]
