"""The render job: the path-tracing megakernel over blocks of samples per pixel.

A *block* is ``spp_per_block`` consecutive samples of **every** pixel: block b
holds samples ``b * spp_per_block ..`` (capped at ``spp_limit``) of the whole
image, and its statistics are an (H, W, STATS) array of per-pixel sums (see
:mod:`mcocl.render.film`).  The accumulator folds blocks in block order, so
the image is bit-identical however the scheduler groups blocks into launches,
devices or resumed runs.  Sample (pixel, s) always uses the random numbers of
index ``s * W * H + pixel`` (kernels/render/integrator.cl), so the image does
not depend on ``spp_per_block`` either, up to the order of float additions.
With ``sampler="sobol"`` a *batch* of ``spp_per_block`` samples is instead one
Owen scrambling per pixel (:mod:`mcocl.render.sobol_film`): the image then
depends on ``spp_per_block``.  A batch can be too many paths for one block (a
kernel launch Ctrl-C waits for, the unit of checkpoints and of sharing between
devices), so sobol cuts it into T ranges of ``block_pixels`` consecutive pixels:
block k renders range k mod T of batch k // T, with zeros elsewhere
(:func:`mcocl.render.sobol_film.sobol_block_pixels`).  The ranges of a batch
are disjoint, so their batch statistics add up to the whole batch's, and the
image does not depend on T.

Inside a launch, one work-item renders one tile of ``tile_pixels``
consecutive pixels for one block, LANES paths at a time.

Light tracing (``integrator="lt"``) has the same blocks, of as many light
paths as the block has camera samples (``spp_per_block * W * H``), on the
splatting film of :mod:`mcocl.render.splat_film`: ``ntiles`` is then the
number of path groups per block, and a block's statistics are one batch.

:class:`RenderJob` is plain picklable data (arrays and numbers, no OpenCL
objects), so it can be shipped to other devices or Dask workers;
:class:`RenderRunner` is the job built on one device.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import pyopencl as cl

from .. import runtime
from ..accumulate import RowRanges
from ..bsdf_registry import BSDFS
from ..layouts import MATERIAL_RECORD, Integrator, LightSampler
from .device_scene import (
    LIGHT_BVH_ABSENT,
    light_records,
    light_tables,
    prim_records,
    scene_params,
    scene_tables,
    tables_digest,
)
from .film import STATS
from .pixel_filter import BOX, PixelFilter
from .shading_normals import VERTEX_NORMALS_ABSENT, require_face_normals, shading_defines
from .sobol_film import block_batches, sobol_render_defines
from .splat_film import SplatRunner, bdpt_sobol_defines, splat_groups
from .table_buffers import table_buffer
from .texture_table import TEXTURES_ABSENT, texture_defines

INTEGRATOR_CODES = {kind.name.lower(): int(kind) for kind in Integrator}
LIGHT_SAMPLER_CODES = {kind.name.lower(): int(kind) for kind in LightSampler}
KERNEL_FILE = "render/integrator.cl"
UNBOUNDED_SPP = 0xFFFFFFFF
# Blocks are sized to about this many paths, so that the host's share of the
# work stays small: folding one block's (H, W, STATS) float64 film costs the
# host about 16 ms for 256 x 256 pixels (measured), 2 % of the ~0.3 s two
# cores take for 2^20 paths (9 % with blocks of 2^18 paths).
PATHS_PER_BLOCK = 1 << 20
TILE_PIXELS = 64
# The scene arrays the render kernel takes after its render_params, in its argument order.
KERNEL_BUFFERS = ("camera", "bvh_nodes", "tri_rows", "spheres", "sphere_flip", "prim_rec",
                  "materials", "emitter_radiance", "light_rec", "light_cdf", "light_bvh", "light_trail",
                  "vertex_normals", "env_map", "env_cdf", "textures")
# The integrators on the splatting film (mcocl/render/splat_film.py).
SPLAT_INTEGRATORS = ("lt", "bdpt")
# The integrators that aim part of their continuations at caustic casters (mcocl/render/caster_guiding.py).
GUIDED_INTEGRATORS = ("nee", "mis")
# The integrators with a sobol back end: the megakernel's (kernels/render/integrator.cl, RENDER_SOBOL) and
# bdpt's (kernels/render/bdpt.cl, "Quasi-Monte Carlo"); lt draws independent samples only.
SOBOL_INTEGRATORS = ("path", "nee", "mis", "bdpt")
# bdpt's MIS heuristics: the exponent beta of Veach's power heuristic (1: the balance heuristic).
MIS_BETAS = {"balance": 1, "power": 2}
# Light tracing starts its paths at emitters chosen by the power CDF: it takes no light BVH.
LT_BUFFERS = tuple(name for name in KERNEL_BUFFERS if name not in ("light_bvh", "light_trail"))


def has_smooth_transmission(materials: np.ndarray) -> bool:
    """Whether a materials table holds a BSDF that refracts through a non-delta lobe (roughdielectric).

    Column 0 of the records is the kind; the rows of tables after them
    (roughplastic's, mcocl/render/roughplastic_tables.py) hold numbers in [0, 1] there,
    below every such kind's code (asserted)."""
    codes = [s.code for s in BSDFS.values() if s.transmissive and not s.delta]
    assert min(codes) > 1
    kinds = np.asarray(materials, np.float32).reshape(-1)[::MATERIAL_RECORD.itemsize // 4]
    return bool(np.isin(kinds, codes).any())


def default_spp_per_block(width: int, height: int) -> int:
    """A power of two close to PATHS_PER_BLOCK / pixels (at least 1, at most 64)."""
    want = max(1, PATHS_PER_BLOCK // max(width * height, 1))
    return min(1 << (want.bit_length() - 1), 64)


@dataclass
class RenderJob:
    """A render as plain data: scene tables, settings and the block layout.

    Attributes:
        tables: the kernel's arrays (:func:`mcocl.render.device_scene.scene_tables`).
        width, height: image size.
        integrator: ``path``, ``nee`` or ``mis``.
        max_depth, rr_depth: Mitsuba 3's conventions (max_depth -1: unbounded).
        seed: 64-bit seed.
        spp_per_block: samples per pixel in one block.
        spp_limit: samples per pixel in all (the last block may be partial);
            :data:`UNBOUNDED_SPP` for time or noise halting.
        lanes: vector width of the build (None: the device's).
        tile_pixels: pixels of one work-item (path integrators).
        bounding_sphere: centre xyz and radius of the scene's bounding sphere
            (light tracing's environment rays start outside it).
        sampler: ``independent`` (Philox) or ``sobol`` (per-pixel Owen-scrambled
            Sobol', one scrambling per batch and pixel: :mod:`mcocl.render.sobol_film`).
        mis: ``bdpt``'s MIS heuristic, ``balance`` or ``power`` (beta 2).
        strategy: ``bdpt`` renders only strategy (s, t) when given.
        unweighted: with ``strategy``, leave out its MIS weight.
        roulette: ``bdpt``'s Russian roulette on connection shadow rays (kernels/render/bdpt.cl,
            connection_roulette); a single ``strategy`` is never rouletted.
        block_pixels: ``sobol`` only: the consecutive pixels of one block, a multiple of
            ``tile_pixels`` (0: the whole film); a batch is then :attr:`film_ranges` blocks.

    The light sampler follows the tables: those of a scene whose
    ``light_sampler`` is ``bvh`` hold the light BVH and get the BVH build;
    power and uniform differ only in ``light_cdf``.
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
    bounding_sphere: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    sampler: str = "independent"
    mis: str = "power"
    strategy: tuple[int, int] | None = None
    unweighted: bool = False
    roulette: bool = True
    pixel_filter: PixelFilter = BOX  # the reconstruction filter (mcocl/render/pixel_filter.py)
    near_clip: float = 0.0  # camera.near_clip: render_params.near_clip (kernels/render/camera.cl)
    far_clip: float | None = None  # camera.far_clip: render_params.far_clip, +inf for None (kernels/render/camera.cl)
    block_pixels: int = 0
    stat_shape: tuple[int, ...] = field(default=(0, 0, STATS))

    def __post_init__(self) -> None:
        self.stat_shape = (self.height, self.width, STATS)
        if self.block_pixels:
            # the independent sampler's block is a range of samples of every pixel (its random numbers
            # are indexed by the sample), the splatting film's a range of light paths: neither is cut
            assert self.sampler == "sobol" and not self.splats, "only sobol blocks are pixel ranges"
            assert self.block_pixels > 0 and self.block_pixels % self.tile_pixels == 0, self.block_pixels

    @property
    def film_ranges(self) -> int:
        """T: the blocks of one batch (pixel ranges of ``block_pixels``; 1 when a block is the whole film)."""
        npix = self.width * self.height
        return -(-npix // self.block_pixels) if 0 < self.block_pixels < npix else 1

    @property
    def range_pixels(self) -> int:
        """The pixels of a block's range (the last range of a film may have fewer)."""
        npix = self.width * self.height
        return self.block_pixels if 0 < self.block_pixels < npix else npix

    @property
    def splats(self) -> bool:
        """Whether the job runs on the splatting film (light tracing, bidirectional path tracing)."""
        return self.integrator in SPLAT_INTEGRATORS

    @property
    def ntiles(self) -> int:
        """Work-items per block: pixel tiles, or path groups on the splatting film."""
        if self.splats:
            return splat_groups(self.width, self.height)
        return -(-self.range_pixels // self.tile_pixels)

    def options(self, lanes: int) -> list[str]:
        """The build's -D options."""
        opts = [f"-DLANES={lanes}", f"-DINTEGRATOR={INTEGRATOR_CODES[self.integrator]}"]
        if "light_bvh" in self.tables:
            opts.append(f"-DLIGHT_SAMPLER={LIGHT_SAMPLER_CODES['bvh']}")
        if has_smooth_transmission(self.tables["materials"]):
            opts.append("-DSMOOTH_TRANSMISSION")
        if self.integrator in GUIDED_INTEGRATORS and "casters" in self.tables:
            # aim at the caustic casters (mcocl/render/caster_guiding.py); their number is a build constant
            opts.append(f"-DCASTER_GUIDING={len(self.tables['casters'])}")
        if self.sampler == "sobol":
            opts += bdpt_sobol_defines() if self.integrator == "bdpt" else sobol_render_defines(self.spp_per_block)
        if self.integrator == "bdpt":
            require_face_normals(self.tables)
        return opts + self.pixel_filter.defines() + shading_defines(self.tables) + texture_defines(self.tables)

    def params(self, first_block: int, nblocks: int) -> np.ndarray:
        """The kernel's ``render_params`` (mcocl/layouts.py) for a launch of ``nblocks`` from ``first_block``."""
        p = scene_params(self.tables)
        p["first_block"], p["seed"], p["nblocks"] = first_block, self.seed, nblocks
        p["spp_per_block"], p["spp_limit"] = self.spp_per_block, self.spp_limit
        p["width"], p["height"], p["tile_pixels"], p["ntiles"] = self.width, self.height, self.tile_pixels, self.ntiles
        p["max_depth"], p["rr_depth"] = self.max_depth, self.rr_depth
        p["bdpt_power_mis"] = int(MIS_BETAS[self.mis] == 2)
        p["bdpt_roulette"] = int(self.integrator == "bdpt" and bool(self.roulette))
        if self.integrator == "bdpt" and self.strategy is not None:
            p["bdpt_only_s"], p["bdpt_only_t"] = int(self.strategy[0]), int(self.strategy[1])
            p["bdpt_unweighted"] = int(bool(self.unweighted))
        p["near_clip"] = self.near_clip
        p["far_clip"] = np.inf if self.far_clip is None else self.far_clip
        p["filter_kind"], p["filter_radius"], p["filter_stddev"] = self.pixel_filter.launch_values()
        return p

    def spp_done(self, blocks: int) -> int:
        """Samples per pixel in the first ``blocks`` blocks, on average over the pixels (rounded down).

        Exact for whole batches; the ranges of a batch cut short by a stop count for their pixels only.
        """
        whole, part = divmod(int(blocks), self.film_ranges)
        spp = min(whole * self.spp_per_block, self.spp_limit)
        if not part:
            return int(spp)
        npix = self.width * self.height
        more = min(self.spp_per_block, self.spp_limit - spp) * min(part * self.range_pixels, npix)
        return int((spp * npix + more) // npix)

    @property
    def spp_per_pixel_block(self) -> float:
        """A block's paths over the film's pixels: the samples per pixel it adds on average."""
        return self.spp_per_block / self.film_ranges

    def runner(self, ctx: runtime.DeviceContext) -> RenderRunner | SplatRunner:
        """Build for ``ctx`` (see :class:`RenderRunner` and :class:`~mcocl.render.splat_film.SplatRunner`)."""
        return SplatRunner(self, ctx, LT_BUFFERS) if self.splats else RenderRunner(self, ctx)


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
        t = {**LIGHT_BVH_ABSENT, **VERTEX_NORMALS_ABSENT, **TEXTURES_ABSENT, **job.tables}
        self.buffers = {name: table_buffer(ctx.context, ctx.device, t[name]) for name in KERNEL_BUFFERS}

    def enqueue(self, first_block: int, nblocks: int) -> tuple[cl.Event, np.ndarray, int]:
        """Launch blocks ``first_block .. first_block + nblocks - 1``; the copy back is non-blocking.

        The handle: the copy's event, the (nblocks, range_pixels, STATS) sums and ``first_block``."""
        job = self.job
        out = np.empty((nblocks, job.range_pixels, STATS), self.film_dtype)
        buf = cl.Buffer(self.ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
        g, lsz = self.ctx.work_size(nblocks * job.ntiles)
        self.kernel(self.ctx.queue, g, lsz, job.params(first_block, nblocks),
                    *(self.buffers[name] for name in KERNEL_BUFFERS), buf)
        ev = cl.enqueue_copy(self.ctx.queue, out, buf, is_blocking=False)
        return ev, out, first_block

    def collect(self, handle: tuple[cl.Event, np.ndarray, int]) -> np.ndarray | RowRanges:
        """Wait for a launch; its (nblocks, H, W, STATS) statistics (one batch per block with ``sobol``),
        as :class:`~mcocl.accumulate.RowRanges` when blocks are pixel ranges."""
        ev, out, first = handle
        ev.wait()
        job = self.job
        if job.film_ranges == 1:
            out = out.reshape((len(out), *job.stat_shape))
            return block_batches(out) if job.sampler == "sobol" else out
        # a block of range t: its batch statistics there, zeros on the rest of the film, which the fold
        # skips (adding zeros changes no bit, so the fold is the whole batch's: mcocl/render/sobol_film.py)
        npix = job.width * job.height
        starts = tuple(block % job.film_ranges * job.range_pixels for block in range(first, first + len(out)))
        counts = tuple(min(job.range_pixels, npix - p0) for p0 in starts)
        rows = np.zeros_like(out)
        for i, n in enumerate(counts):  # only the rows a range holds (the last range of a film may be short)
            rows[i, :n] = block_batches(out[i, :n])
        return RowRanges(rows, starts, counts, tuple(job.stat_shape))


__all__ = ["INTEGRATOR_CODES", "KERNEL_BUFFERS", "LIGHT_SAMPLER_CODES", "MIS_BETAS", "SOBOL_INTEGRATORS", "SPLAT_INTEGRATORS",
           "UNBOUNDED_SPP", "RenderJob", "RenderRunner",
           "default_spp_per_block", "light_records", "light_tables", "prim_records", "scene_tables", "tables_digest"]
