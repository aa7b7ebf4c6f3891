"""The splatting film: images of estimators that add to any pixel (light tracing).

A light path lands in whichever pixel its camera connection hits, so the
gather film of :mod:`mcocl.render.film` (each work-item owns its pixels) does
not apply, and float atomics would add in an arbitrary order.  Instead:

- a block of the job (``spp_per_block * W * H`` light paths) is cut into
  ``groups`` contiguous ranges of paths, a job constant
  (:func:`splat_groups`, from the image size only);
- each (block, group) work-item splats into its *own* image of
  ``SPLAT_COLUMNS`` numbers per pixel (kernels/render/lt.cl, ``lt_trace``),
  in the order its paths produce the splats: no other work-item writes there;
- ``lt_fold_groups`` sums a block's group images in group order and turns
  the block into one **batch**: for every pixel the batch mean
  ``Y_b = (sum of the block's splats) / (light paths in the block)``, stored
  as one "sample" of the gather film's columns (sum Y_b, sum Y_b^2, count 1);
- the :class:`~mcocl.accumulate.Accumulator` folds blocks in block order.

So the image is bit-identical for a seed and a block size, however blocks are
spread over launches, devices, sub-devices, Dask workers or resumed runs.

The variance.  The splats a pixel receives are not independent samples of
that pixel (one light path splats into several pixels, most light paths into
none), so a per-splat variance would be wrong.  The batches are independent:
with B batches, :func:`mcocl.render.film.film_image` gives the mean of the
Y_b and the variance of that mean, var(Y_b) / B (the lecture's secondary
estimator with the batch as the primary one).  ``count`` is then the number
of batches, and ``target_error`` halting works on this variance unchanged.
The mean of the batch means equals the mean over all paths when the blocks
are equally long (a last partial block is an unbiased batch of its own).

Memory: a launch holds ``nblocks * groups`` group images; :data:`SCRATCH_BYTES`
bounds it, and a runner splits a chunk of blocks into launches that fit.
"""

from __future__ import annotations

import time

import numpy as np
import pyopencl as cl

from .. import runtime
from .film import STATS
from .shading_normals import VERTEX_NORMALS_ABSENT
from .sobol_film import DEFAULT_BATCHES, RENDER_TABLE_DIMS, sobol_spp_per_block
from .table_buffers import table_buffer
from .texture_table import TEXTURES_ABSENT

KERNEL_FILE = "render/lt.cl"
# Per splatting integrator: its kernel file and trace kernel (both fold with lt_fold_groups).
TRACE_KERNELS = {"lt": (KERNEL_FILE, "lt_trace"), "bdpt": ("render/bdpt.cl", "bdpt_trace")}
SPLAT_COLUMNS = 4  # R, G, B sums and the count of non-finite splats (kernels/render/lt.cl)
MAX_GROUPS = 64
# The group images of one launch stay under this size (float64 columns).
SCRATCH_BYTES = 64 << 20
# A render with a given spp gets at least this many batches (blocks) when spp allows.
MIN_BATCHES = 16
# bdpt: the film points of a pixel wanted in one batch (one stratified set: kernels/render/bdpt.cl),
# the batches a render of a given spp keeps at least for its variance, and the most camera samples
# one work-item (path group) of a block may trace, which bounds a block's time (see README, bdpt).
STRATA_SPP = 16
MIN_STRATA_BATCHES = 8
BDPT_GROUP_PATHS = 1 << 20


# bdpt's sobol build: log2 of the points of one scrambling, which bounds a block's samples (W H
# spp_per_block) under the batch-wide scrambling of the light subpaths (kernels/render/bdpt.cl,
# "Quasi-Monte Carlo"); one value, so that every image size and batch shares one build.
BDPT_SOBOL_LOG2_POINTS = 24
BDPT_SOBOL_BLOCK = 1 << BDPT_SOBOL_LOG2_POINTS


def bdpt_sobol_defines() -> list[str]:
    """The build options of bdpt's sobol back end (kernels/render/bdpt.cl, "Quasi-Monte Carlo")."""
    return ["-DSAMPLER_BACKEND=SAMPLER_BACKEND_SOBOL", f"-DSOBOL_LOG2_POINTS={BDPT_SOBOL_LOG2_POINTS}",
            f"-DSOBOL_TABLE_DIMS={RENDER_TABLE_DIMS}"]


def group_image_bytes(width: int, height: int) -> int:
    """Bytes of one group image (float64 columns, whatever the device's film type)."""
    return width * height * SPLAT_COLUMNS * 8


def splat_groups(width: int, height: int) -> int:
    """Work-items per block: a power of two, at most MAX_GROUPS, whose images fill at most a quarter of SCRATCH_BYTES.

    It depends on the image size alone, so that the image does not depend on the device.
    """
    fit = max(1, (SCRATCH_BYTES // 4) // group_image_bytes(width, height))
    return min(MAX_GROUPS, 1 << (fit.bit_length() - 1))


def blocks_per_launch(width: int, height: int, groups: int) -> int:
    """Blocks whose group images fit SCRATCH_BYTES together (at least 1)."""
    return max(1, SCRATCH_BYTES // (groups * group_image_bytes(width, height)))


def splat_spp_per_block(default: int, spp: int | None, integrator: str = "lt", width: int = 1,
                        height: int = 1, sampler: str = "independent", batches: int = DEFAULT_BATCHES) -> int:
    """Samples per pixel of a block for a splatting render of ``width`` x ``height`` pixels.

    ``lt``: at most ``default``, and small enough that a render of ``spp`` has at least
    MIN_BATCHES batches when it can.  ``bdpt``: at least that, and at least STRATA_SPP (a
    power of two) when its block stays within BDPT_GROUP_PATHS camera samples per work-item and a
    render of ``spp`` keeps MIN_STRATA_BATCHES batches: a batch's film points of a pixel are one
    stratified set (kernels/render/bdpt.cl, "Film positions"), and the more a batch holds the
    more they help.

    ``bdpt`` with the ``sobol`` sampler: every dimension of a batch's samples of a pixel is one
    randomised net (kernels/render/bdpt.cl, "Quasi-Monte Carlo"), whose gain grows with its
    points, so batches are as mis's sobol batches: ``batches`` (default
    :data:`~mcocl.render.sobol_film.DEFAULT_BATCHES`) of ceil(spp / batches) samples, at most
    ``default`` (the default block of about 2^20 paths, which bounds a block's time), and
    ``default`` under time or noise halting (``spp`` None)."""
    if integrator == "bdpt" and sampler == "sobol":
        return sobol_spp_per_block(default, spp, batches, bounded_by_spp=False)
    base = default if spp is None else max(1, min(default, spp // MIN_BATCHES))
    if integrator != "bdpt":
        return base
    npix = max(width * height, 1)
    want = min(STRATA_SPP, max(1, BDPT_GROUP_PATHS * splat_groups(width, height) // npix))
    if spp is not None:
        want = min(want, max(1, spp // MIN_STRATA_BATCHES))
    return max(base, 1 << (want.bit_length() - 1))


class SplatRunner:
    """A splatting render job (``job.integrator`` ``lt`` or ``bdpt``) built on one device.

    ``buffer_names``: the scene tables the kernel takes after its
    ``render_params``, in order (mcocl.render.job.KERNEL_BUFFERS).

    ``enqueue`` runs ``lt_trace`` and ``lt_fold_groups`` over the blocks asked
    for, in launches of at most :func:`blocks_per_launch` blocks that share one
    scratch buffer (the queue is in order), and copies the batches back.
    """

    def __init__(self, job, ctx: runtime.DeviceContext, buffer_names: tuple[str, ...]) -> None:
        self.job = job
        self.ctx = ctx
        self.lanes = int(job.lanes) if job.lanes is not None else ctx.lanes
        t0 = time.perf_counter()
        kernel_file, trace_name = TRACE_KERNELS[job.integrator]
        src = runtime.compose([kernel_file])
        self.film_dtype = np.float64 if ctx.fp64 else np.float32
        options = job.options(self.lanes) + (["-DFILM_DOUBLE"] if ctx.fp64 else [])
        self.program = runtime.build(ctx, src, options, what=f"{job.integrator} kernel")
        self.build_seconds = time.perf_counter() - t0
        self.trace = runtime.kernel(self.program, trace_name)
        self.fold = runtime.kernel(self.program, "lt_fold_groups")
        self.buffer_names = buffer_names
        mf = cl.mem_flags
        tables = {**VERTEX_NORMALS_ABSENT, **TEXTURES_ABSENT, **job.tables}
        self.buffers = {name: table_buffer(ctx.context, ctx.device, tables[name]) for name in buffer_names}
        self.per_launch = blocks_per_launch(job.width, job.height, job.ntiles)
        item = np.dtype(self.film_dtype).itemsize
        self.scratch = cl.Buffer(ctx.context, mf.READ_WRITE,
                                 self.per_launch * job.ntiles * job.width * job.height * SPLAT_COLUMNS * item)
        self.bsphere = np.asarray(job.bounding_sphere, np.float32).reshape(4)

    def enqueue(self, first_block: int, nblocks: int) -> tuple[cl.Event, np.ndarray, int]:
        """Launch blocks ``first_block .. first_block + nblocks - 1``; the copy back is non-blocking."""
        job = self.job
        npix = job.width * job.height
        out = np.empty((nblocks, job.height, job.width, STATS), self.film_dtype)
        buf = cl.Buffer(self.ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
        for start in range(0, nblocks, self.per_launch):
            n = min(self.per_launch, nblocks - start)
            params = job.params(first_block + start, n)
            g, lsz = self.ctx.work_size(n * job.ntiles)
            self.trace(self.ctx.queue, g, lsz, params, *(self.buffers[k] for k in self.buffer_names),
                       self.bsphere, self.scratch)
            g, lsz = self.ctx.work_size(n * npix)
            self.fold(self.ctx.queue, g, lsz, params, self.scratch, np.uint32(start), buf)
        ev = cl.enqueue_copy(self.ctx.queue, out, buf, is_blocking=False)
        return ev, out, nblocks

    def collect(self, handle: tuple[cl.Event, np.ndarray, int]) -> np.ndarray:
        """Wait for a launch; its (nblocks, H, W, STATS) batch statistics."""
        ev, out, _ = handle
        ev.wait()
        return out


__all__ = ["BDPT_GROUP_PATHS", "BDPT_SOBOL_BLOCK", "BDPT_SOBOL_LOG2_POINTS", "bdpt_sobol_defines", "KERNEL_FILE", "MIN_BATCHES", "MIN_STRATA_BATCHES", "SCRATCH_BYTES", "STRATA_SPP", "SPLAT_COLUMNS", "TRACE_KERNELS", "SplatRunner", "blocks_per_launch",
           "splat_groups", "splat_spp_per_block"]
