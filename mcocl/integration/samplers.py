"""The integration samplers: one class per way of placing the uniform points.

The flat keyword ``integrate(sampler="nrooks")`` picks a spec from
:data:`SAMPLER_SPECS` once; everything that depends on the sampler asks the
spec instead of comparing names: the design size and how a sample budget is
rounded (:meth:`SamplerSpec.plan`, :meth:`SamplerSpec.granules`), the kernel's
``-D`` options, the reduction of kernel blocks to accumulator rows, the
estimate and its standard error, and what the result reports.

Adding a sampler is one class here, decorated with :func:`register`, plus its
branch of ``SAMPLER`` in ``kernels/integrate/integrate.cl``.

The accumulator row every spec reads and writes is described in
:mod:`mcocl.integration.job`.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from ..accumulate import mean_and_variance
from ..errors import InputError
from .design import MAX_AXIS_CELLS, UNBOUNDED_UNITS, Design


class SamplerSpec:
    """A sampler that runs in whole designs (the default behaviour of every method).

    Class attributes:
        name: the keyword users give (``sampler=name``); saved in checkpoints.
        kernel_code: the value of ``-DSAMPLER`` (``SAMPLER_*`` in kernels/integrate/integrate.cl).
        units_per_block: units one kernel work-item computes.
        min_designs: designs a sample budget is rounded up to at least.
        variance_method: how the reported standard error is obtained.
        precisions: the ``precision=`` values the sampler's kernel branch
            builds (``double``: integrate.cl's REAL_DOUBLE, independent units only).
    """

    name: ClassVar[str]
    kernel_code: ClassVar[int]
    units_per_block: ClassVar[int]
    min_designs: ClassVar[int] = 1
    variance_method: ClassVar[str]
    precisions: ClassVar[tuple[str, ...]] = ("single",)

    def plan(self, dim: int, points: int, samples: int | None, design_samples: int | None) -> Design:
        """The design of a run of at most ``samples`` (``None``: unbounded) evaluations."""
        raise NotImplementedError

    def plan_replicated(self, dim: int, points: int, samples: int | None, design_samples: int | None,
                        replicates: int | None) -> Design:
        """:meth:`plan` with the user's ``replicates`` (``None``: the sampler's default).

        Only a sampler made of independent replicates (sobol) takes a count.
        """
        if replicates is not None:
            raise InputError(f"replicates: sampler {self.name!r} has no replicates; they belong to sampler='sobol'")
        return self.plan(dim, points, samples, design_samples)

    def defines(self, design: Design, dim: int, points: int) -> list[str]:
        """The ``-D`` options of the kernel skeleton (kernels/integrate/integrate.cl)."""
        return [
            f"-DDIM={dim}",
            f"-DPOINTS={points}",
            f"-DSAMPLER={self.kernel_code}",
            f"-DDESIGN_UNITS={design.units}ul",
            f"-DUNITS_PER_BLOCK={self.units_per_block}",
            f"-DBLOCKS_PER_DESIGN={self.blocks_per_design(design)}ul",
            f"-DSTRATA_M={max(design.strata_m, 1)}",
            *(["-DREAL_DOUBLE=1"] if design.double else []),
            *self.extra_defines(design),
        ]

    def blocks_per_design(self, design: Design) -> int:
        """Kernel blocks one design spans."""
        return design.granule_blocks

    def extra_defines(self, design: Design) -> list[str]:
        """``-D`` options only this sampler's branch of the kernel reads."""
        return []

    def granules(self, design: Design, samples: int | None) -> tuple[int | None, int]:
        """(scheduler blocks to run, unit limit of the last one) for a sample budget.

        ``None`` blocks means unbounded (halting by time or target only).  A
        budget is rounded down to whole designs, at least ``min_designs``.
        """
        if samples is None:
            return None, design.units
        per_design = design.units * design.samples_per_unit
        return max(samples // per_design, self.min_designs), design.units

    def samples_per_block(self, design: Design) -> int:
        """Integrand evaluations in one scheduler block (what the progress bar counts)."""
        return self.units_per_block * design.samples_per_unit * design.granule_blocks

    def samples_used(self, design: Design, blocks_done: int, unit_limit: int) -> int:
        """Integrand evaluations made by ``blocks_done`` scheduler blocks."""
        return int(blocks_done * design.units * design.samples_per_unit)

    def partial_tail(self, design: Design, blocks_done: int, unit_limit: int) -> bool:
        """True when the last block done was cut short by ``unit_limit`` (designs never are)."""
        return False

    def designs_done(self, blocks_done: int) -> int:
        """Complete designs in ``blocks_done`` scheduler blocks (0 for a sampler without designs)."""
        return int(blocks_done)

    def target_ready(self, blocks_done: int, samples: float) -> bool:
        """True once the standard error is worth testing against a target (two designs give a spread)."""
        return blocks_done >= 2

    def fill_rows(self, per_block: np.ndarray, rows: np.ndarray) -> None:
        """Write the sampler's own accumulator columns from the summed kernel statistics of each block."""

    def statistics(self, t: np.ndarray, shift: float) -> tuple[float, float, float]:
        """(estimate, variance of the estimate, samples) from accumulator totals, before the rounding floor."""
        raise NotImplementedError

    def notes(self, design: Design, dim: int) -> list[str]:
        """What the result reports about the design."""
        return []

    def design_point_launch(self, size: int, dim: int) -> tuple[str, int, int, tuple[int, ...]]:
        """How kernels/sampling/design_points.cl draws one design of ``size`` for tests.

        Returns ``(kernel name, points, work-items, leading uint arguments)``.
        """
        raise InputError(f"sampler: design points exist for {', '.join(designed_samplers())}, not {self.name!r}")


SAMPLER_SPECS: dict[str, SamplerSpec] = {}


def register(cls: type[SamplerSpec]) -> type[SamplerSpec]:
    """Class decorator: make ``cls`` available as ``sampler=cls.name``."""
    SAMPLER_SPECS[cls.name] = cls()
    return cls


def sampler_spec(name: object) -> SamplerSpec:
    """The registered spec called ``name``, else an InputError listing the choices."""
    spec = SAMPLER_SPECS.get(name) if isinstance(name, str) else None
    if spec is None:
        raise InputError(f"sampler: unknown sampler {name!r}; choose one of {', '.join(SAMPLER_SPECS)}")
    return spec


def designed_samplers() -> list[str]:
    """The samplers whose designs :func:`mcocl.integration.sampling.design_points` can draw."""
    return [name for name, spec in SAMPLER_SPECS.items()
            if type(spec).design_point_launch is not SamplerSpec.design_point_launch]


def spec_of(design: Design) -> SamplerSpec:
    """The spec of the sampler a design was planned for."""
    return sampler_spec(design.sampler)


def plan(sampler: str, dim: int, points: int, samples: int | None, design_samples: int | None) -> Design:
    """Choose the design of a run (each spec's docstring gives its rules)."""
    return sampler_spec(sampler).plan(dim, points, samples, design_samples)


def total_granules(design: Design, samples: int | None) -> tuple[int | None, int]:
    """(scheduler blocks to run, unit limit of the last one) for a sample budget (``None``: unbounded)."""
    return spec_of(design).granules(design, samples)


@register
class Independent(SamplerSpec):
    """The plain secondary estimator (1/N) sum f(x_i), no design structure.

    N samples -> N // points units (a unit is one point tuple; points > 1 only
    for combined estimators).  Nothing else is rounded; any block may end a run.
    Standard error: sample variance / N (lecture: sigma_sec^2 = sigma_prim^2 / N).
    """

    name = "independent"
    kernel_code = 0
    units_per_block = 4096
    variance_method = "sample variance of the primary estimates / N"
    precisions = ("single", "double")

    def plan(self, dim: int, points: int, samples: int | None, design_samples: int | None) -> Design:
        """One unbounded design of point tuples."""
        return Design(self.name, UNBOUNDED_UNITS, points, 0, 1)

    def blocks_per_design(self, design: Design) -> int:
        """The unbounded design spans every block."""
        return max(1, -(-design.units // self.units_per_block))

    def granules(self, design: Design, samples: int | None) -> tuple[int | None, int]:
        """Blocks of ``units_per_block`` units; the last is cut at ``samples // points`` units."""
        if samples is None:
            return None, design.units
        units = max(samples // design.samples_per_unit, 1)
        return -(-units // self.units_per_block), units

    def samples_per_block(self, design: Design) -> int:
        """One kernel block per scheduler block."""
        return self.units_per_block * design.samples_per_unit

    def samples_used(self, design: Design, blocks_done: int, unit_limit: int) -> int:
        """Whole blocks, the last one cut at ``unit_limit``."""
        return int(min(blocks_done * self.units_per_block, unit_limit) * design.samples_per_unit)

    def partial_tail(self, design: Design, blocks_done: int, unit_limit: int) -> bool:
        """True when ``unit_limit`` fell inside the last block."""
        return blocks_done * self.units_per_block > unit_limit

    def designs_done(self, blocks_done: int) -> int:
        """No designs."""
        return 0

    def target_ready(self, blocks_done: int, samples: float) -> bool:
        """The sample variance is trusted from 1000 samples on."""
        return samples >= 1000

    def statistics(self, t: np.ndarray, shift: float) -> tuple[float, float, float]:
        """Sample mean; variance = sample variance / n."""
        n = t[0]
        mean, var = mean_and_variance(n, t[2], t[3], shift)
        return mean, (var / n if n > 1 else math.nan), n


@register
class Stratified(SamplerSpec):
    """Jittered stratified sampling, two samples per stratum.

    A design is H = m^dim strata with 2 samples (units) in each:
    m = floor((S / (2 points))^(1/dim)), S = ``design_samples`` (default
    min(N, 2^24), in one dimension min(N // 16, 2^24) so a budget is at least
    16 designs; 2^20 when unbounded, 2^16 in one dimension); m is capped at
    2^22 per axis (float coordinates), H at 2^31.  N is rounded down to whole
    designs, at least one.

    Standard error: the stratum pairs' variance, sum over strata of
    (v1 - v2)^2 / (4 H^2) per design (sampling/stratified.cl), and from 8
    designs on the larger of it and the spread of the design means (their
    sample variance / designs).  Both are unbiased, but the pairs' one can
    be far too small: when a discontinuity cuts few strata (one in one
    dimension), it is seen only when a stratum's two samples straddle it, so
    it is usually zero.  The spread of whole designs sees the jump whatever
    the pairs do; with fewer than 8 designs it is too noisy to be trusted.
    """

    name = "stratified"
    kernel_code = 1
    units_per_block = 2048
    variance_method = ("sum over strata of (f1 - f2)^2 / (4 H^2), two samples per stratum; from 8 designs "
                       "on the larger of it and the spread of the design means")
    MAX_STRATA = 1 << 31
    DEFAULT_DESIGN = 1 << 24
    UNBOUNDED_DESIGN = 1 << 20
    # In one dimension a jump sits in one stratum, so the pairs' variance is
    # unreliable and the run needs enough designs for their spread.
    ONE_DIM_DESIGNS = 16
    ONE_DIM_UNBOUNDED_DESIGN = 1 << 16
    SPREAD_MIN_DESIGNS = 8

    def plan(self, dim: int, points: int, samples: int | None, design_samples: int | None) -> Design:
        """m^dim strata of ``2 * points`` samples, m as in the class docstring."""
        per_unit = 2 * points
        if design_samples is None:
            if dim == 1:
                design_samples = (min(samples // self.ONE_DIM_DESIGNS, self.DEFAULT_DESIGN) if samples
                                  else self.ONE_DIM_UNBOUNDED_DESIGN)
            else:
                design_samples = min(samples, self.DEFAULT_DESIGN) if samples else self.UNBOUNDED_DESIGN
        m = _int_root(design_samples / per_unit, dim)
        m = min(m, MAX_AXIS_CELLS)
        while m > 1 and m**dim > self.MAX_STRATA:
            m -= 1
        units = m**dim
        return Design(self.name, units, per_unit, m, -(-units // self.units_per_block))

    def fill_rows(self, per_block: np.ndarray, rows: np.ndarray) -> None:
        """Columns 5-7 as ``nrooks`` (one design per row): the design means, for their spread."""
        SAMPLER_SPECS["nrooks"].fill_rows(per_block, rows)

    def statistics(self, t: np.ndarray, shift: float) -> tuple[float, float, float]:
        """Mean of all samples; the variance as in the class docstring."""
        n, pairs = t[0], t[4]
        if pairs <= 0:
            return math.nan, math.nan, n
        pairs_var = t[3] / (4.0 * pairs * pairs)
        if t[5] < self.SPREAD_MIN_DESIGNS:
            return shift + t[2] / n, pairs_var, n
        spread_var = SAMPLER_SPECS["nrooks"].statistics(t, shift)[1]
        return shift + t[2] / n, max(pairs_var, spread_var), n

    def notes(self, design: Design, dim: int) -> list[str]:
        """The strata of a design and where the standard error comes from."""
        return [f"{design.strata_m}^{dim} strata per design, 2 samples each; the standard error is the "
                f"stratum pairs' variance, or from {self.SPREAD_MIN_DESIGNS} designs on the larger of it "
                "and the spread of the design means"]

    def design_point_launch(self, size: int, dim: int) -> tuple[str, int, int, tuple[int, ...]]:
        """``size`` = strata per axis m: 2 m^dim points, one work-item per stratum."""
        strata = size**dim
        return "stratified_points", 2 * strata, strata, (size, strata)


class DesignSpread(SamplerSpec):
    """A sampler whose standard error is the spread of independent design means (nrooks, sobol).

    Each scheduler block is one design; its mean goes to accumulator columns
    5-7, and the estimate is the mean of the design means.
    """

    def fill_rows(self, per_block: np.ndarray, rows: np.ndarray) -> None:
        """Columns 5-7: one design, its mean (shifted) and the mean squared."""
        n = per_block[:, 0]
        with np.errstate(invalid="ignore", divide="ignore"):
            m = np.where(n > 0, per_block[:, 2] / np.where(n > 0, n, 1), 0.0)
        rows[:, 5] = (n > 0).astype(np.float64)
        rows[:, 6] = m
        rows[:, 7] = m * m

    def statistics(self, t: np.ndarray, shift: float) -> tuple[float, float, float]:
        """Mean of the design means; variance = their sample variance / designs."""
        r = t[5]
        if r <= 0:
            return math.nan, math.nan, t[0]
        mean, var = mean_and_variance(r, t[6], t[7], shift)
        return mean, (var / r if r > 1 else math.nan), t[0]


@register
class NRooks(DesignSpread):
    """Latin hypercube (N-rooks) designs.

    A design is one Latin hypercube of n points: n = design_samples // points,
    default clamp(N // (16 points), 1, 2^20) (2^16 when unbounded); N is
    rounded down to whole designs, at least 2 (the standard error comes from
    the spread of the design means).
    """

    name = "nrooks"
    kernel_code = 2
    units_per_block = 4096
    min_designs = 2
    variance_method = "spread of the means of independent Latin hypercube designs"
    REPLICATES = 16
    MAX_POINTS = 1 << 20
    UNBOUNDED_POINTS = 1 << 16

    def plan(self, dim: int, points: int, samples: int | None, design_samples: int | None) -> Design:
        """One hypercube of n point tuples, n as in the class docstring."""
        if design_samples is None:
            n = min(max(samples // (self.REPLICATES * points), 1), self.MAX_POINTS) if samples else self.UNBOUNDED_POINTS
        else:
            n = design_samples // points
        if not 1 <= n <= MAX_AXIS_CELLS:
            raise InputError(f"design_samples: an N-rooks design holds 1 to {MAX_AXIS_CELLS} points, got {n}")
        return Design(self.name, n, points, 0, -(-n // self.units_per_block))

    def extra_defines(self, design: Design) -> list[str]:
        """The bit width and shifts of the hashed permutation (sampling/nrooks.cl)."""
        w = max((design.units - 1).bit_length(), 0)
        return [f"-DNROOKS_MASK={(1 << w) - 1}u", f"-DNROOKS_S1={max(1, w // 2)}u", f"-DNROOKS_S2={max(1, (w + 2) // 3)}u"]

    def notes(self, design: Design, dim: int) -> list[str]:
        """The size of a design."""
        return [f"Latin hypercube designs of {design.units} points"]

    def design_point_launch(self, size: int, dim: int) -> tuple[str, int, int, tuple[int, ...]]:
        """``size`` = points n, one work-item per point."""
        return "nrooks_points", size, size, (size,)


@register
class Sobol(DesignSpread):
    """Randomised quasi-Monte Carlo: Owen-scrambled Sobol' points (kernels/samplers/sobol_sampler.cl).

    A design is one replicate: 2^m point tuples of one independent Owen
    scrambling, consecutive sample indices (one scheduler block, so launch
    splits, devices and resume cannot change a replicate).  With N samples,
    R replicates (``replicates``, default 16) and P points per unit
    (combined estimators), 2^m is the largest power of two with
    R * 2^m * P <= N (at least 1, at most 2^30), and the run is exactly R
    replicates: N is rounded down to R * 2^m * P (up to R * P when smaller).
    Past 2^30 points per replicate the replicates grow instead: N // (2^30 P).
    ``design_samples`` fixes 2^m (rounded down to a power of two) and R
    becomes N // (2^m P), at least 2 (so a resumed run may ask for more).
    A time budget without a sample count (and without ``design_samples``)
    is planned from the measured rate (:mod:`mcocl.integration.sobol_budget`):
    a pilot of replicates of 2^12 for PILOT_SHARE of the budget, then
    replicates of 2^M until the time is spent, 2^M the largest power of two
    with R * 2^M * P samples predicted to take at most BUDGET_MARGIN of the
    time left (:meth:`budget_log2`), so about R to 2R replicates complete.
    Target-only runs use replicates of 2^18 until the halting rule stops
    them.  A resumed run keeps its checkpoint's design.
    Standard error: the sample variance of the R replicate means / R.
    ``scrambling`` (SCRAMBLINGS): ``"hash"`` (the default) scrambles by the
    Laine-Karras hash, ``"linear"`` by a random lower-triangular matrix and a
    digital shift per (replicate, coordinate) (kernels/samplers/sobol_block.cl).
    """

    name = "sobol"
    kernel_code = 3  # integrate.cl's branch of independent units; the sampler back end differs
    units_per_block = 4096
    min_designs = 2
    variance_method = "spread of the means of independent Owen-scrambled Sobol' replicates"
    precisions = ("single", "double")
    REPLICATES = 16
    MAX_LOG2_POINTS = 30
    UNBOUNDED_LOG2_POINTS = 18
    MAX_COORDINATES = 1024  # dimensions of kernels/samplers/sobol_joe_kuo_1024.cl
    TABLE_CHUNK = 64
    SCRAMBLINGS = ("hash", "linear")  # Design.scrambling indexes this
    # The time plan (mcocl/integration/sobol_budget.py): the pilot's replicates
    # are one kernel block each, and it takes this share of the budget (long
    # enough to measure the rate with the chunks the engine sizes for it).
    PILOT_LOG2_POINTS = 12
    PILOT_SHARE = 0.05
    # R * 2^M is planned to fill at most this share of the time left, so a
    # rate that drops by up to 1/BUDGET_MARGIN still completes R replicates.
    BUDGET_MARGIN = 0.8

    def plan(self, dim: int, points: int, samples: int | None, design_samples: int | None) -> Design:
        """The default number of replicates (see :meth:`plan_replicated`)."""
        return self.plan_replicated(dim, points, samples, design_samples, None)

    def plan_replicated(self, dim: int, points: int, samples: int | None, design_samples: int | None,
                        replicates: int | None) -> Design:
        """R replicates of 2^m point tuples, as in the class docstring."""
        if dim * points > self.MAX_COORDINATES:
            raise InputError(f"sampler='sobol' draws at most {self.MAX_COORDINATES} coordinates per sample "
                             f"(dim x points per unit), got {dim} x {points} = {dim * points}")
        if replicates is not None and design_samples is not None:
            raise InputError("sampler='sobol': give replicates or design_samples, not both")
        if replicates is not None and not 2 <= replicates <= 1 << 20:
            raise InputError(f"replicates must be between 2 and {1 << 20} (the standard error needs two), got {replicates}")
        if design_samples is not None:
            log2 = max(design_samples // points, 1).bit_length() - 1
            if log2 > self.MAX_LOG2_POINTS:
                raise InputError(f"design_samples: a Sobol' replicate holds at most 2^{self.MAX_LOG2_POINTS} "
                                 f"point tuples, got {design_samples // points}")
            count = 0
        elif samples is None:
            log2, count = self.UNBOUNDED_LOG2_POINTS, 0
        else:
            r = self.REPLICATES if replicates is None else replicates
            log2 = max(samples // (r * points), 1).bit_length() - 1
            count = r if log2 <= self.MAX_LOG2_POINTS else 0
            log2 = min(log2, self.MAX_LOG2_POINTS)
        units = 1 << log2
        return Design(self.name, units, points, 0, -(-units // self.units_per_block), count)

    def budget_log2(self, rate: float, seconds: float, replicates: int, points: int) -> int:
        """log2 of the replicate size of a time plan: the largest M in PILOT_LOG2_POINTS ..
        MAX_LOG2_POINTS with ``replicates`` * 2^M * ``points`` samples taking at most
        BUDGET_MARGIN * ``seconds`` at ``rate`` samples per second (the pilot's size when none does)."""
        fit = rate * seconds * self.BUDGET_MARGIN / (replicates * points) if rate > 0 and seconds > 0 else 0.0
        if not math.isfinite(fit) or fit < 1 << self.PILOT_LOG2_POINTS:
            return self.PILOT_LOG2_POINTS
        return min(int(fit).bit_length() - 1, self.MAX_LOG2_POINTS)

    def budget_design(self, log2_points: int, points: int, like: Design) -> Design:
        """An unbounded design of replicates of 2^``log2_points`` point tuples, with ``like``'s
        precision and scrambling (the time plan's pilot and final runs)."""
        units = 1 << log2_points
        return Design(self.name, units, points, 0, -(-units // self.units_per_block), 0,
                      double=like.double, scrambling=like.scrambling)

    def granules(self, design: Design, samples: int | None) -> tuple[int | None, int]:
        """Exactly the design's R replicates; without R (``design_samples``, or 2^m capped) the
        budget rounded down to whole replicates, at least two; ``None`` when unbounded."""
        if samples is None:
            return None, design.units
        if design.replicates:
            return design.replicates, design.units
        return super().granules(design, samples)

    def defines(self, design: Design, dim: int, points: int) -> list[str]:
        """The Sobol' back end: points per scrambling and the table's dimensions."""
        table = -(-dim * points // self.TABLE_CHUNK) * self.TABLE_CHUNK
        return [*super().defines(design, dim, points), "-DSAMPLER_BACKEND=SAMPLER_BACKEND_SOBOL",
                f"-DSOBOL_LOG2_POINTS={design.units.bit_length() - 1}", f"-DSOBOL_TABLE_DIMS={table}",
                f"-DSOBOL_SCRAMBLE_LINEAR={design.scrambling}"]

    def notes(self, design: Design, dim: int) -> list[str]:
        """The replicates and how the sample budget was rounded."""
        m = design.units.bit_length() - 1
        how = "Owen-scrambled" if design.scrambling == 0 else "linearly scrambled (random matrix and digital shift)"
        per = f"2^{m} point tuples" if design.samples_per_unit == 1 else f"2^{m} units of {design.samples_per_unit} points"
        if design.replicates == 0:
            return [f"independent {how} Sobol' replicates of {per}: the sample budget is rounded "
                    "down to whole replicates (at least 2), or they run until the time or error target"]
        return [f"{design.replicates} independent {how} Sobol' replicates of {per}: "
                f"the sample budget is rounded down to replicates x 2^{m}"
                + (f" x {design.samples_per_unit}" if design.samples_per_unit > 1 else "")]


def _int_root(target: float, dim: int) -> int:
    """The largest m >= 1 with m^dim <= target."""
    m = max(int(math.floor(target ** (1.0 / dim))), 1)
    while (m + 1) ** dim <= target:
        m += 1
    while m > 1 and m**dim > target:
        m -= 1
    return m


@register
class Vegas(Independent):
    """VEGAS adaptive importance sampling (Lepage 1978), driven by :mod:`mcocl.integration.vegas`.

    A run is ``vegas_iterations`` iterations (default 10) of samples // iterations
    samples each.  Each draws samples through the current grid
    (kernels/sampling/vegas_grid.cl) and trains the next grid.  Where an
    iteration holds 8 designs of m^dim strata with m >= 2 (m the largest with
    16 m^dim <= its samples; whole designs), its uniforms are stratified as
    ``stratified``'s are, two per stratum, and its variance is the larger of
    the stratum pairs' one and the spread of the design means; else they are
    independent (sample variance / n).  The first
    iterations // 4 are warm-up: they only adapt the grid.  The estimate is
    the inverse-variance weighted mean of the others, with chi^2/dof across
    them reported.  A time budget alone runs independent samples, each
    iteration sized from the rate measured so far.  One point tuple per
    sample (no combined estimators).
    """

    name = "vegas"
    kernel_code = 4
    precisions = ("single",)
    variance_method = ("inverse-variance weighted mean of the iterations after the warm-up, each: "
                       "stratum pairs (stratified iterations) or sample variance / n of f J")

    def plan(self, dim: int, points: int, samples: int | None, design_samples: int | None) -> Design:
        """The independent sampler's unbounded design (mcocl/integration/vegas.py plans the iterations)."""
        if points != 1:
            raise InputError("sampler='vegas' adapts one point per sample; it does not combine proposals= "
                             "(use a single proposal=, or another sampler)")
        if design_samples is not None:
            raise InputError("design_samples does not apply to sampler='vegas' (use samples= and vegas_iterations=)")
        return Design(self.name, UNBOUNDED_UNITS, points, 0, 1)

    def extra_defines(self, design: Design) -> list[str]:
        """The grid's bins per dimension and whether iterations are stratified (kernels/sampling/vegas_grid.cl)."""
        return [f"-DVEGAS_BINS={design.bins}u", f"-DVEGAS_STRATIFIED={int(design.strata_m > 1)}"]

    def fill_rows(self, per_block: np.ndarray, rows: np.ndarray) -> None:
        """Stratified iterations: columns 5-7 as ``nrooks`` (one design per row), for the spread of design means."""
        if np.any(per_block[:, 4] > 0):
            SAMPLER_SPECS["nrooks"].fill_rows(per_block, rows)

    def statistics(self, t: np.ndarray, shift: float) -> tuple[float, float, float]:
        """Independent iterations as ``independent``.  Stratified ones: the mean of all samples and the
        larger of the stratum pairs' variance and the spread of the design means (both unbiased; the
        pairs miss a jump whose stratum's two samples fall on one side, the spread does not)."""
        if t[4] <= 0:
            return super().statistics(t, shift)
        est, pairs_var, n = SAMPLER_SPECS["stratified"].statistics(t, shift)
        spread_var = SAMPLER_SPECS["nrooks"].statistics(t, shift)[1]
        return est, max(pairs_var, spread_var) if math.isfinite(spread_var) else pairs_var, n
