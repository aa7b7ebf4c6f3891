"""The walk job: blocks of random walks for every query point.

:class:`WalkJob` is plain data (text, numbers, arrays: picklable, device
independent); :class:`WalkRunner` is the job built for one device.  A
scheduler block is ``walks_per_block`` walks for *every* query point; its
statistics (``kernels/walks/walk.cl``) have shape ``(nq, STATS)``:

====  ==============================================
col   meaning
====  ==============================================
0     finite walks
1     non-finite walks (NaN/Inf, kept out of every sum)
2     sum (v - shift)
3     sum (v - shift)^2
4     sum of walk lengths (moves), all walks
5     guard hits (walks stopped at max_walk_length or a weight beyond 1e30)
====  ==============================================
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import pyopencl as cl

from .. import runtime
from ..accumulate import mean_and_variance
from ..layouts import WALK_PARAMS
from .codegen import WalkCode
from .sobol_walks import walk_batches, walk_sobol_defines
from .tabulate import TableGrid, WalkTables, build_tables

STATS = 6
WALKS_PER_BLOCK = 4096

# Built tables by (program, grid, kernel table?, source table?); a program is
# cached by the runtime for the life of the process, so its handle identifies
# K and g on one device.  Repeated solves of one problem (other seeds, more
# walks) tabulate once.
_TABLE_CACHE: dict[tuple[int, TableGrid, bool, bool], WalkTables] = {}
_TABLE_CACHE_SIZE = 16


@dataclass
class WalkJob:
    """Random walks for every query point, compiled on demand (device independent).

    Attributes:
        code: the generated program text and user snippets.
        queries: ``(nq, dim)`` float32 query points.
        seed: 64-bit seed.
        walk_limit: walks per query point (the last block may be partial).
        survival: roulette survival probability; <= 0 means min(1, |weight|).
        depth: moves of the truncated estimator.
        max_len: the walk-length guard.
        tables: tabulated densities (set by the API after tabulation).
        shifts: per query point, subtracted before summing (set after the pilot).
        lanes: vector width override (None: the device's default, 8 with AVX2).
    """

    code: WalkCode
    queries: np.ndarray
    seed: int
    walk_limit: int
    survival: float = 0.0
    depth: int = 0
    max_len: int = 10_000
    tables: WalkTables | None = None
    shifts: np.ndarray | None = None
    lanes: int | None = None
    walks_per_block: int = WALKS_PER_BLOCK
    sampler: str = "independent"
    stat_shape: tuple[int, ...] = field(init=False)

    def __post_init__(self) -> None:
        self.queries = np.ascontiguousarray(self.queries, dtype=np.float32)
        self.stat_shape = (len(self.queries), STATS)

    @property
    def nq(self) -> int:
        """Number of query points."""
        return len(self.queries)

    @property
    def dim(self) -> int:
        """Dimension of the domain."""
        return int(self.queries.shape[1])

    @property
    def max_blocks(self) -> int:
        """Blocks that cover ``walk_limit`` walks per query point."""
        return -(-self.walk_limit // self.walks_per_block)

    def runner(self, ctx: runtime.DeviceContext) -> WalkRunner:
        """Build for ``ctx`` (see :class:`WalkRunner`)."""
        return WalkRunner(self, ctx)


def walk_params(job: WalkJob, first_block: int, nwork: int) -> np.ndarray:
    """The ``walk_params`` record (mcocl/layouts.py) of a launch of ``nwork`` work-items from ``first_block``."""
    p = np.zeros((), WALK_PARAMS.dtype())
    p["first_block"], p["walk_limit"], p["seed"] = first_block, job.walk_limit, job.seed
    p["nwork"], p["nq"], p["wpb"] = nwork, job.nq, job.walks_per_block
    p["survival"], p["depth"], p["max_len"] = job.survival, job.depth, job.max_len
    return p


class WalkRunner:
    """A :class:`WalkJob` built for one device."""

    def __init__(self, job: WalkJob, ctx: runtime.DeviceContext) -> None:
        self.job = job
        self.ctx = ctx
        t0 = time.perf_counter()
        self.program = runtime.build_user_program(
            ctx,
            job.code.includes,
            job.code.generated,
            job.code.users,
            tail=job.code.tail,
            options=job.code.options + (walk_sobol_defines(job.walks_per_block) if job.sampler == "sobol" else []),
            what="integral equation",
            lanes=job.lanes,
        )
        self.build_seconds = time.perf_counter() - t0
        self.kernel = runtime.kernel(self.program.program, "walk_blocks")
        mf = cl.mem_flags
        self.queries = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=job.queries)
        self._tables: cl.Buffer | None = None
        self._tables_of: WalkTables | None = None
        self._empty: WalkTables | None = None

    @property
    def lanes(self) -> int:
        """The lane width actually built."""
        return self.program.lanes

    def _table_buffer(self) -> tuple[cl.Buffer, np.ndarray]:
        """The device buffer of the job's tables (empty ones without tables) and their geometry record."""
        tabs = self.job.tables
        if tabs is None:
            if self._empty is None:
                self._empty = WalkTables(np.zeros(1, np.uint32), TableGrid(self.job.dim, 1, 1))
            tabs = self._empty
        if self._tables is None or self._tables_of is not tabs:
            mf = cl.mem_flags
            self._tables = cl.Buffer(self.ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=tabs.data)
            self._tables_of = tabs
        return self._tables, tabs.geometry()

    def _launch(self, first_block: int, nblocks: int, shifts: np.ndarray) -> tuple[cl.Event, np.ndarray]:
        job = self.job
        nwork = nblocks * job.nq
        ctxt = self.ctx.context
        mf = cl.mem_flags
        out = np.empty((nblocks, job.nq, STATS), dtype=np.float64)
        bout = cl.Buffer(ctxt, mf.WRITE_ONLY, out.nbytes)
        sh = np.ascontiguousarray(shifts, dtype=np.float64)
        bshift = cl.Buffer(ctxt, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=sh)
        tab, geometry = self._table_buffer()
        gsize, lsize = self.ctx.work_size(nwork)
        self.kernel(self.ctx.queue, gsize, lsize, walk_params(job, first_block, nwork), geometry, self.queries, bshift,
                    tab, bout)
        ev = cl.enqueue_copy(self.ctx.queue, out, bout, is_blocking=False)
        return ev, out

    def pilot(self) -> np.ndarray:
        """Statistics of block 0 computed with zero shifts, ``(nq, STATS)``.

        The API derives the shifts from it (and stops early on a guard hit).
        """
        handle = self._launch(0, 1, np.zeros(self.job.nq))
        return self.collect(handle)[0]

    def enqueue(self, first_block: int, nblocks: int) -> tuple[cl.Event, np.ndarray]:
        """Launch blocks ``first_block .. first_block + nblocks - 1`` (non-blocking)."""
        shifts = self.job.shifts if self.job.shifts is not None else np.zeros(self.job.nq)
        return self._launch(first_block, nblocks, shifts)

    def collect(self, handle: tuple[cl.Event, np.ndarray]) -> np.ndarray:
        """Wait for a launch; its ``(nblocks, nq, STATS)`` statistics (one batch per block with ``sobol``)."""
        ev, out = handle
        ev.wait()
        return walk_batches(out) if self.job.sampler == "sobol" else out

    # -- tabulation and sampler checks -------------------------------------

    def tables(self, grid: TableGrid, kernel: bool, source: bool) -> WalkTables:
        """The walk's tables on ``grid``: |K(x, .)| when ``kernel``, |g| when ``source`` (remembered)."""
        key = (self.program.program.int_ptr, grid, kernel, source)
        tabs = _TABLE_CACHE.get(key)
        if tabs is None:
            kw = self.tabulate_kernel(grid) if kernel else None
            sw = self.tabulate_source(grid) if source else None
            tabs = build_tables(kw, sw, grid)
            tabs.data.setflags(write=False)
            if len(_TABLE_CACHE) >= _TABLE_CACHE_SIZE:
                _TABLE_CACHE.pop(next(iter(_TABLE_CACHE)))
            _TABLE_CACHE[key] = tabs
        return tabs

    def tabulate_kernel(self, grid: TableGrid) -> np.ndarray:
        """``(ncells, nbins)`` mean |K| per cell of x and bin of y (NaN where not finite)."""
        n = grid.ncells * grid.nbins
        out = np.empty(n, np.float32)
        buf = cl.Buffer(self.ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
        gsize, lsize = self.ctx.work_size(n)
        runtime.kernel(self.program.program, "walk_tabulate_kernel")(
            self.ctx.queue, gsize, lsize, np.uint32(grid.ncells), np.uint32(grid.nbins), np.uint32(grid.cells),
            np.uint32(grid.bins), np.uint32(grid.sub_x), np.uint32(grid.sub_y), buf,
        )
        cl.enqueue_copy(self.ctx.queue, out, buf)
        return out.reshape(grid.ncells, grid.nbins)

    def tabulate_source(self, grid: TableGrid) -> np.ndarray:
        """``(nbins,)`` mean |g| per bin of y (NaN where not finite)."""
        n = grid.nbins
        out = np.empty(n, np.float32)
        buf = cl.Buffer(self.ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
        gsize, lsize = self.ctx.work_size(n)
        runtime.kernel(self.program.program, "walk_tabulate_source")(
            self.ctx.queue, gsize, lsize, np.uint32(n), np.uint32(grid.bins), np.uint32(grid.sub_y), buf,
        )
        cl.enqueue_copy(self.ctx.queue, out, buf)
        return out

    def sample_check(self, x: np.ndarray, n: int, seed: int = 0) -> dict[str, np.ndarray]:
        """The walk's own samplers at vertex ``x``, ``n`` times (for goodness-of-fit tests).

        Returns ``y`` (n, dim) moves, ``m`` their multipliers K/p, ``q``
        survival probabilities, ``z`` (n, dim) next-event points and ``e``
        their g/p (nee only).
        """
        dim = self.job.dim
        ctxt = self.ctx.context
        mf = cl.mem_flags
        xs = np.ascontiguousarray(np.asarray(x, np.float32).reshape(dim))
        bx = cl.Buffer(ctxt, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=xs)
        res = {"y": np.empty((n, dim), np.float32), "m": np.empty(n, np.float32), "q": np.empty(n, np.float32),
               "z": np.empty((n, dim), np.float32), "e": np.empty(n, np.float32)}
        bufs = {k: cl.Buffer(ctxt, mf.WRITE_ONLY, v.nbytes) for k, v in res.items()}
        tab, geometry = self._table_buffer()
        gsize, lsize = self.ctx.work_size(-(-n // self.lanes))
        runtime.kernel(self.program.program, "walk_sample_check")(
            self.ctx.queue, gsize, lsize, np.uint32(n), np.uint64(seed), bx, tab, geometry,
            bufs["y"], bufs["m"], bufs["q"], bufs["z"], bufs["e"],
        )
        for k in res:
            cl.enqueue_copy(self.ctx.queue, res[k], bufs[k])
        return res


def estimates(totals: np.ndarray, shifts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(values, stderr) per query point from accumulator totals ``(nq, STATS)``.

    The secondary estimator of each point: mean of its walks, standard error
    sqrt(sample variance / n) (lecture: sigma_sec^2 = sigma_prim^2 / N).
    """
    vals = np.empty(len(totals))
    errs = np.empty(len(totals))
    for q, t in enumerate(totals):
        mean, var = mean_and_variance(t[0], t[2], t[3], float(shifts[q]))
        vals[q] = mean
        errs[q] = math.sqrt(var / t[0]) if t[0] > 1 and math.isfinite(var) else math.nan
    return vals, errs
