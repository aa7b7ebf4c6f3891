"""The integration job: a compiled estimator over blocks of sample indices.

:class:`IntegrationJob` holds everything needed to build the kernel on any
device (plain data: text, numbers, arrays, so it can be pickled and shipped
to another process); :class:`IntegrationRunner` is the job bound to one device.

The statistics folded by the accumulator, one row per scheduler block (one
kernel block for the independent sampler, one whole design otherwise):

====  ===========================================================
col   meaning
====  ===========================================================
0     valid finite samples
1     non-finite samples (NaN/Inf, kept out of every sum)
2     sum (v - shift)
3     sum (v - shift)^2 (stratified: sum over pairs (v1 - v2)^2)
4     stratum pairs (stratified)
5     designs (nrooks)
6     sum over designs of the design mean - shift (nrooks)
7     sum over designs of (design mean - shift)^2 (nrooks)
8     sum |v| (sets the float32 rounding floor of the standard error)
====  ===========================================================
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import pyopencl as cl

from .. import runtime
from ..usercode import UserFunction
from .codegen import EstimatorCode
from .design import Design
from .samplers import spec_of

KERNEL_STATS = 6
ROW = 9
# Integrands are evaluated in float32: their values carry a rounding error of
# about one ulp, partly systematic (OpenCL allows exp/log 3 ulp), which no
# amount of sampling removes.  The reported variance therefore adds, in
# quadrature, 2^-24 (half a float ulp, the error of one correctly rounded
# operation) times the mean |v|; measured rounding biases of smooth integrands
# were 0.2-0.4 ulp.
ROUNDING_FLOOR = 2.0**-24
# The same for precision="double" (Design.double): half a double ulp.
ROUNDING_FLOOR_DOUBLE = 2.0**-53


@dataclass
class IntegrationJob:
    """A compiled-on-demand integration estimator (device independent)."""

    code: EstimatorCode
    dim: int
    design: Design
    seed: int
    unit_limit: int
    lanes: int | None = None
    shift: float = 0.0

    stat_shape: tuple[int, ...] = (ROW,)

    @property
    def users(self) -> tuple[UserFunction, ...]:
        """The user snippets in the program."""
        return self.code.users

    def runner(self, ctx: runtime.DeviceContext) -> IntegrationRunner:
        """Build for ``ctx`` (see :class:`IntegrationRunner`)."""
        return IntegrationRunner(self, ctx)


class IntegrationRunner:
    """An :class:`IntegrationJob` built for one device."""

    def __init__(self, job: IntegrationJob, ctx: runtime.DeviceContext) -> None:
        self.job = job
        self.ctx = ctx
        t0 = time.perf_counter()
        self.program = runtime.build_user_program(
            ctx,
            job.code.includes,
            job.code.generated,
            job.code.users,
            tail=["integrate/integrate.cl"],
            options=spec_of(job.design).defines(job.design, job.dim, job.code.points),
            what="integrand",
            lanes=job.lanes,
        )
        self.build_seconds = time.perf_counter() - t0
        self.kernel = runtime.kernel(self.program.program, "integrate_blocks")
        mf = cl.mem_flags
        self.tables = cl.Buffer(ctx.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=job.code.tables)

    @property
    def lanes(self) -> int:
        """The lane width actually built."""
        return self.program.lanes

    def sampler_args(self, nkblocks: int) -> tuple[cl.Buffer, ...]:
        """Kernel arguments after ``out`` that only the sampler's branch of the kernel takes (none by default)."""
        return ()

    def _launch(self, first_kblock: int, nkblocks: int, shift: float,
                extra: tuple[cl.Buffer, ...] | None = None) -> tuple[cl.Event, np.ndarray]:
        out = np.empty((nkblocks, KERNEL_STATS), dtype=np.float64)
        buf = cl.Buffer(self.ctx.context, cl.mem_flags.WRITE_ONLY, out.nbytes)
        gsize, lsize = self.ctx.work_size(nkblocks)
        self.kernel(
            self.ctx.queue, gsize, lsize,
            np.uint64(first_kblock), np.uint64(nkblocks), np.uint64(self.job.unit_limit), np.uint64(self.job.seed),
            np.float64(shift), self.tables, buf, *(self.sampler_args(nkblocks) if extra is None else extra),
        )
        ev = cl.enqueue_copy(self.ctx.queue, out, buf, is_blocking=False)
        return ev, out

    def pilot_shift(self) -> float:
        """The mean of block 0 computed with shift 0: a deterministic shift for the sums."""
        ev, out = self._launch(0, 1, 0.0)
        ev.wait()
        n, _, s1 = out[0, 0], out[0, 1], out[0, 2]
        return float(np.float32(s1 / n)) if n > 0 and math.isfinite(s1 / n) else 0.0

    def enqueue(self, first_block: int, nblocks: int) -> tuple[cl.Event, np.ndarray, int]:
        """Launch scheduler blocks ``first_block ..`` (each ``granule_blocks`` kernel blocks)."""
        g = self.job.design.granule_blocks
        ev, out = self._launch(first_block * g, nblocks * g, self.job.shift)
        return ev, out, nblocks

    def collect(self, handle: tuple[cl.Event, np.ndarray, int]) -> np.ndarray:
        """Wait for a launch and reduce its kernel blocks to accumulator rows."""
        ev, out, nblocks = handle
        ev.wait()
        return reduce_blocks(out, nblocks, self.job.design)


def reduce_blocks(out: np.ndarray, nblocks: int, design: Design) -> np.ndarray:
    """Kernel-block statistics -> accumulator rows (one per scheduler block)."""
    g = design.granule_blocks
    k = out.reshape(nblocks, g, KERNEL_STATS)
    # within a design, add kernel blocks sequentially (fixed order)
    per = np.add.accumulate(k, axis=1)[:, -1, :] if g > 1 else k[:, 0, :]
    rows = np.zeros((nblocks, ROW), dtype=np.float64)
    rows[:, :5] = per[:, :5]
    rows[:, 8] = per[:, 5]
    spec_of(design).fill_rows(per, rows)
    return rows


def estimate_from_totals(t: np.ndarray, design: Design, shift: float) -> tuple[float, float, float]:
    """(estimate, variance of the estimate, samples used) from accumulator totals.

    The sampler's spec gives the estimate and its variance
    (:meth:`mcocl.integration.samplers.SamplerSpec.statistics`); each variance
    gets (ROUNDING_FLOOR * mean |v|)^2 added: the float32 evaluation floor.
    """
    est, var, n = spec_of(design).statistics(t, shift)
    if math.isfinite(var):
        var = var + rounding_floor(t, design) ** 2
    return est, var, n


def rounding_floor(t: np.ndarray, design: Design | None = None) -> float:
    """The rounding term of the standard error: ROUNDING_FLOOR (float32) or
    ROUNDING_FLOOR_DOUBLE (``design.double``) times the mean |v|."""
    unit = ROUNDING_FLOOR_DOUBLE if design is not None and design.double else ROUNDING_FLOOR
    return unit * t[8] / t[0] if t[0] > 0 else 0.0
