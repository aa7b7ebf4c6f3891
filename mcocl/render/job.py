"""The render job: the path-tracing megakernel over blocks of samples per pixel.

A *block* is ``spp_per_block`` consecutive samples of **every** pixel: block b
holds samples ``b * spp_per_block ..`` (capped at ``spp_limit``) of the whole
image, and its statistics are an (H, W, STATS) array of per-pixel sums (see
:mod:`mcocl.render.film`).  The accumulator folds blocks in block order, so
the image is bit-identical however the scheduler groups blocks into launches,
devices or resumed runs.  Sample (pixel, s) always uses the random numbers of
index ``s * W * H + pixel`` (kernels/render/integrator.cl), so the image does
not depend on ``spp_per_block`` either, up to the order of float additions.

Inside a launch, one work-item renders one tile of ``tile_pixels``
consecutive pixels for one block, LANES paths at a time.

:class:`RenderJob` is plain picklable data (arrays and numbers, no OpenCL
objects), so it can be shipped to other devices or Dask workers;
:class:`RenderRunner` is the job built on one device.
"""

from __future__ import annotations

import hashlib
import math
import time
from dataclasses import dataclass, field

import numpy as np
import pyopencl as cl

from .. import runtime
from ..rng import GRID_CELLS
from .compiled import LUMINANCE, CompiledScene
from .film import STATS

INTEGRATOR_CODES = {"path": 0, "nee": 1, "mis": 2}
KERNEL_FILE = "render/integrator.cl"
UNBOUNDED_SPP = 0xFFFFFFFF
GRID = GRID_CELLS  # the uniforms' grid (kernels/rng/uniform.cl): u = (m + 1/2) / 2^23
# Blocks are sized to about this many paths, so that the host's share of the
# work stays small: folding one block's (H, W, STATS) float64 film costs the
# host about 16 ms for 256 x 256 pixels (measured), 2 % of the ~0.3 s two
# cores take for 2^20 paths (9 % with blocks of 2^18 paths).
PATHS_PER_BLOCK = 1 << 20
TILE_PIXELS = 64
# The scene arrays the render kernel takes, in its argument order.
KERNEL_BUFFERS = ("camera", "bvh_nodes", "bvh_prims", "tri_vertices", "spheres", "sphere_flip", "prim_rec",
                  "materials", "emitter_radiance", "light_rec", "light_cdf")


def _cells_below(x: np.ndarray) -> np.ndarray:
    """How many grid uniforms u_m = (m + 1/2) / 2^23 are < x (exact for float32 x)."""
    c = np.ceil(np.asarray(x, np.float64) * GRID - 0.5)
    return np.clip(c, 0, GRID)


def light_tables(cs: CompiledScene) -> dict[str, np.ndarray | float | int]:
    """The emitter-choice tables of the kernel (kernels/render/lights.cl) from a compiled scene.

    The choice is proportional to power: area lights by ``light_cdf``; the
    constant environment by its power pi * luminance * 4 pi R^2 (the flux it
    sends into the scene's bounding sphere of radius R).  Probabilities are
    exact on the uniforms' grid: ``prim_pmf`` is the share of grid cells that
    CDF inversion maps to each primitive, ``env_pmf`` the share below
    ``env_threshold``.
    """
    ntotal = cs.num_triangles + cs.num_spheres
    nl = cs.num_lights
    cdf = np.asarray(cs.light_cdf, np.float32)
    prim_pmf = np.zeros(max(ntotal, 1), np.float32)
    p_area = 0.0
    if nl:
        below = _cells_below(cdf[:nl])
        upper = np.append(below[1:], GRID)
        prim_pmf[cs.light_prims] = ((upper - below) / GRID).astype(np.float32)
        emit = cs.shape_emitter[cs.prim_shape[cs.light_prims]]
        lum = cs.emitter_radiance[emit, :3].astype(np.float64) @ LUMINANCE
        p_area = float(np.sum(lum * cs.light_area.astype(np.float64) * math.pi))
    env = cs.env_radiance[:3].astype(np.float64)
    p_env = 0.0
    if np.any(env > 0):
        lo, hi = cs.bounds.astype(np.float64)
        radius = 0.5 * float(np.linalg.norm(hi - lo))
        p_env = math.pi * float(env @ LUMINANCE) * 4.0 * math.pi * max(radius, 1e-3) ** 2
    if p_env > 0 and p_area > 0:
        threshold = np.float32(p_env / (p_env + p_area))
    elif p_env > 0:
        threshold = np.float32(1.0)
    else:
        threshold = np.float32(0.0)
    env_pmf = float(_cells_below(threshold)) / GRID
    top = 1 << (nl.bit_length() - 1) if nl else 0
    return {"prim_pmf": prim_pmf, "env_threshold": float(threshold), "env_pmf": env_pmf, "light_top": top}


def prim_records(cs: CompiledScene, prim_pmf: np.ndarray) -> np.ndarray:
    """One record of 8 floats per primitive for the shading of a hit (layout in kernels/render/prims.cl)."""
    nt, ns = cs.num_triangles, cs.num_spheres
    rec = np.zeros((max(nt + ns, 1), 8), np.float32)
    if nt:
        v = cs.tri_vertices[:, :, :3].astype(np.float64)
        cr = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
        length = np.linalg.norm(cr, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            rec[:nt, 0:3] = np.where(length[:, None] > 0, cr / length[:, None], 0.0)
        rec[:nt, 3] = 0.5 * length
    if ns:
        rec[nt:nt + ns, 3] = 4.0 * math.pi * cs.spheres[:, 3].astype(np.float64) ** 2
        rec[nt:nt + ns, 7] = cs.sphere_flip.astype(np.float32)
    if nt + ns:
        shape = np.asarray(cs.prim_shape, np.int64)
        rec[:nt + ns, 4] = cs.shape_material[shape].astype(np.uint32).view(np.float32)
        rec[:nt + ns, 5] = cs.shape_emitter[shape].astype(np.int32).view(np.float32)
        rec[:nt + ns, 6] = prim_pmf[:nt + ns]
    return rec


def light_records(cs: CompiledScene, prim_pmf: np.ndarray) -> np.ndarray:
    """Four float4 per light primitive for light sampling (layout in kernels/render/lights.cl)."""
    nl, nt = cs.num_lights, cs.num_triangles
    rec = np.zeros((max(nl, 1), 4, 4), np.float32)
    if nl:
        prims = np.asarray(cs.light_prims, np.int64)
        emit = cs.shape_emitter[cs.prim_shape[prims]]
        rec[:nl, 3, :3] = cs.emitter_radiance[emit, :3]
        rec[:nl, 3, 3] = prims.astype(np.uint32).view(np.float32)
        rec[:nl, 2, 3] = prim_pmf[prims]
        tri = prims < nt
        v = cs.tri_vertices[prims[tri], :, :3].astype(np.float64)
        rec[:nl][tri, 0, :3] = v[:, 0]
        rec[:nl][tri, 1, :3] = v[:, 1] - v[:, 0]
        rec[:nl][tri, 2, :3] = v[:, 2] - v[:, 0]
        rec[:nl][tri, 0, 3] = 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)
        s = prims[~tri] - nt
        c = cs.spheres[s].astype(np.float64)
        rec[:nl][~tri, 0, :3] = c[:, :3]
        rec[:nl][~tri, 0, 3] = 4.0 * math.pi * c[:, 3] ** 2
        rec[:nl][~tri, 1, 0] = c[:, 3]
        rec[:nl][~tri, 1, 3] = np.where(cs.sphere_flip[s] != 0, 2.0, 1.0)
    return rec.reshape(-1, 4)


def scene_tables(cs: CompiledScene) -> dict[str, np.ndarray]:
    """Every array the kernel reads, as plain NumPy arrays (never empty: OpenCL has no empty buffers)."""
    def nonempty(a: np.ndarray, dtype: type, width: int = 4) -> np.ndarray:
        a = np.ascontiguousarray(a, dtype=dtype)
        return a if a.size else np.zeros(width, dtype)

    lt = light_tables(cs)
    return {
        "camera": nonempty(cs.camera, np.float32),
        "bvh_nodes": nonempty(cs.bvh_nodes, np.float32),
        "bvh_prims": nonempty(cs.bvh_prims, np.uint32),
        "tri_vertices": nonempty(cs.tri_vertices, np.float32),
        "spheres": nonempty(cs.spheres, np.float32),
        "sphere_flip": nonempty(cs.sphere_flip, np.uint32),
        "prim_rec": prim_records(cs, lt["prim_pmf"]),
        "materials": nonempty(cs.materials, np.float32, 8),
        "emitter_radiance": nonempty(cs.emitter_radiance, np.float32),
        "light_rec": light_records(cs, lt["prim_pmf"]),
        "light_cdf": nonempty(cs.light_cdf, np.float32),
        "prim_pmf": nonempty(lt["prim_pmf"], np.float32),
        "env": np.array([*cs.env_radiance[:3], 0.0], np.float32),
        "light_scalars": np.array([cs.num_lights, lt["light_top"]], np.uint32),
        "env_choice": np.array([lt["env_threshold"], lt["env_pmf"]], np.float32),
        "geometry_counts": np.array([cs.num_triangles, cs.num_spheres], np.uint32),
    }


def tables_digest(tables: dict[str, np.ndarray]) -> str:
    """A short hash of the scene tables: a checkpoint must belong to the same scene."""
    h = hashlib.sha256()
    for name in sorted(tables):
        a = np.ascontiguousarray(tables[name])
        h.update(name.encode())
        h.update(str(a.dtype).encode())
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()[:16]


def default_spp_per_block(width: int, height: int) -> int:
    """A power of two close to PATHS_PER_BLOCK / pixels (at least 1, at most 64)."""
    want = max(1, PATHS_PER_BLOCK // max(width * height, 1))
    return min(1 << (want.bit_length() - 1), 64)


@dataclass
class RenderJob:
    """A render as plain data: scene tables, settings and the block layout.

    Attributes:
        tables: the kernel's arrays (:func:`scene_tables`).
        width, height: image size.
        integrator: ``path``, ``nee`` or ``mis``.
        max_depth, rr_depth: Mitsuba 3's conventions (max_depth -1: unbounded).
        seed: 64-bit seed.
        spp_per_block: samples per pixel in one block.
        spp_limit: samples per pixel in all (the last block may be partial);
            :data:`UNBOUNDED_SPP` for time or noise halting.
        lanes: vector width of the build (None: the device's).
        tile_pixels: pixels of one work-item.
    """

    tables: dict[str, np.ndarray]
    width: int
    height: int
    integrator: str
    max_depth: int
    rr_depth: int
    seed: int
    spp_per_block: int
    spp_limit: int = UNBOUNDED_SPP
    lanes: int | None = None
    tile_pixels: int = TILE_PIXELS
    stat_shape: tuple[int, ...] = field(default=(0, 0, STATS))

    def __post_init__(self) -> None:
        self.stat_shape = (self.height, self.width, STATS)

    @property
    def ntiles(self) -> int:
        """Work-items per block."""
        return -(-self.width * self.height // self.tile_pixels)

    def options(self, lanes: int) -> list[str]:
        """The build's -D options."""
        return [f"-DLANES={lanes}", f"-DINTEGRATOR={INTEGRATOR_CODES[self.integrator]}"]

    def spp_done(self, blocks: int) -> int:
        """Samples per pixel contained in the first ``blocks`` blocks."""
        return int(min(blocks * self.spp_per_block, self.spp_limit))

    def runner(self, ctx: runtime.DeviceContext) -> RenderRunner:
        """Build for ``ctx`` (see :class:`RenderRunner`)."""
        return RenderRunner(self, ctx)


class RenderRunner:
    """A :class:`RenderJob` built on one device: the program and the scene buffers."""

    def __init__(self, job: RenderJob, ctx: runtime.DeviceContext) -> None:
        self.job = job
        self.ctx = ctx
        self.lanes = int(job.lanes) if job.lanes is not None else ctx.lanes
        t0 = time.perf_counter()
        src = runtime.compose([KERNEL_FILE])
        self.film_dtype = np.float64 if ctx.fp64 else np.float32
        options = job.options(self.lanes) + (["-DFILM_DOUBLE"] if ctx.fp64 else [])
        self.program = runtime.build(ctx, src, options, what="render kernel")
        self.build_seconds = time.perf_counter() - t0
        self.kernel = runtime.kernel(self.program, "render_blocks")
        mf = cl.mem_flags
        t = job.tables
        self.buffers = {
            name: cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(t[name]))
            for name in KERNEL_BUFFERS
        }

    def enqueue(self, first_block: int, nblocks: int) -> tuple[cl.Event, np.ndarray, int]:
        """Launch blocks ``first_block .. first_block + nblocks - 1``; the copy back is non-blocking."""
        job = self.job
        out = np.empty((nblocks, job.height, job.width, STATS), self.film_dtype)
        buf = cl.Buffer(self.ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
        b = self.buffers
        t = job.tables
        nl, top = (int(x) for x in t["light_scalars"])
        thr, env_pmf = (float(x) for x in t["env_choice"])
        ntris, nsph = (int(x) for x in t["geometry_counts"])
        g, lsz = self.ctx.work_size(nblocks * job.ntiles)
        self.kernel(
            self.ctx.queue, g, lsz,
            np.uint64(first_block), np.uint32(nblocks), np.uint32(job.spp_per_block), np.uint32(job.spp_limit),
            np.uint32(job.width), np.uint32(job.height), np.uint32(job.tile_pixels), np.uint32(job.ntiles),
            np.uint64(job.seed), np.int32(job.max_depth), np.uint32(job.rr_depth),
            b["camera"], b["bvh_nodes"], b["bvh_prims"], b["tri_vertices"], b["spheres"], b["sphere_flip"],
            np.uint32(ntris), np.uint32(nsph),
            b["prim_rec"], b["materials"], b["emitter_radiance"], b["light_rec"], b["light_cdf"],
            np.uint32(nl), np.uint32(top), np.float32(thr), np.float32(env_pmf), t["env"],
            buf,
        )
        ev = cl.enqueue_copy(self.ctx.queue, out, buf, is_blocking=False)
        return ev, out, nblocks

    def collect(self, handle: tuple[cl.Event, np.ndarray, int]) -> np.ndarray:
        """Wait for a launch; its (nblocks, H, W, STATS) statistics."""
        ev, out, _ = handle
        ev.wait()
        return out


__all__ = ["INTEGRATOR_CODES", "KERNEL_BUFFERS", "UNBOUNDED_SPP", "RenderJob", "RenderRunner",
           "default_spp_per_block", "light_records", "light_tables", "prim_records", "scene_tables", "tables_digest"]
