"""How many samples a design holds, and how designs map to kernel blocks.

A *design* is the set of samples an estimator must see complete to be
unbiased: one stratification of the cube (stratified), one Latin hypercube
(nrooks).  Runs are made of whole designs, so a run can stop after any design
and still be unbiased; the independent sampler has no design structure and
stops after any block.

Rounding rules (documented for users in README and ``--help``):

independent  N samples -> N // points units (a unit is one point tuple; points
             > 1 only for combined estimators).  Nothing else is rounded.
stratified   a design is H = m^dim strata with 2 samples (units) in each:
             m = floor((S / (2 points))^(1/dim)), S = ``design_samples``
             (default min(N, 2^24)); m is capped at 2^22 per axis (float
             coordinates), H at 2^31.  N is rounded down to whole designs,
             at least one.
nrooks       a design is one Latin hypercube of n points: n = design_samples
             // points, default clamp(N // (16 points), 1, 2^20); N is rounded
             down to whole designs, at least 2 (the standard error comes from
             the spread of the design means).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from ..errors import InputError

UNITS_PER_BLOCK = {"independent": 4096, "stratified": 2048, "nrooks": 4096}
SAMPLER_CODE = {"independent": 0, "stratified": 1, "nrooks": 2}
UNBOUNDED_UNITS = 1 << 62
MAX_AXIS_CELLS = 1 << 22
MAX_STRATA = 1 << 31
STRATIFIED_DEFAULT_DESIGN = 1 << 24
STRATIFIED_UNBOUNDED_DESIGN = 1 << 20
NROOKS_REPLICATES = 16
NROOKS_MAX_POINTS = 1 << 20
NROOKS_UNBOUNDED_POINTS = 1 << 16


@dataclass(frozen=True)
class Design:
    """The design of one integration run.

    Attributes:
        sampler: ``independent``, ``stratified`` or ``nrooks``.
        units: units per design (``UNBOUNDED_UNITS`` for independent).
        samples_per_unit: integrand evaluations per unit.
        strata_m: strata per axis (stratified), else 0.
        granule_blocks: kernel blocks per scheduler block (a design, or 1).
    """

    sampler: str
    units: int
    samples_per_unit: int
    strata_m: int
    granule_blocks: int

    @property
    def units_per_block(self) -> int:
        """Units one kernel work-item computes."""
        return UNITS_PER_BLOCK[self.sampler]

    def to_dict(self) -> dict:
        """JSON form (saved in checkpoints)."""
        return asdict(self)

    def defines(self, dim: int, points: int) -> list[str]:
        """The ``-D`` options of the kernel skeleton."""
        opts = [
            f"-DDIM={dim}",
            f"-DPOINTS={points}",
            f"-DSAMPLER={SAMPLER_CODE[self.sampler]}",
            f"-DDESIGN_UNITS={self.units}ul",
            f"-DUNITS_PER_BLOCK={self.units_per_block}",
            f"-DBLOCKS_PER_DESIGN={self.granule_blocks if self.sampler != 'independent' else max(1, -(-self.units // self.units_per_block))}ul",
            f"-DSTRATA_M={max(self.strata_m, 1)}",
        ]
        if self.sampler == "nrooks":
            w = max((self.units - 1).bit_length(), 0)
            opts += [f"-DNROOKS_MASK={(1 << w) - 1}u", f"-DNROOKS_S1={max(1, w // 2)}u", f"-DNROOKS_S2={max(1, (w + 2) // 3)}u"]
        return opts


def design_from_checkpoint(d: object, where: object) -> Design:
    """The :class:`Design` saved in a checkpoint, every field checked (else :class:`InputError`)."""
    fields = {"sampler": str, "units": int, "samples_per_unit": int, "strata_m": int, "granule_blocks": int}
    if not isinstance(d, dict) or set(d) != set(fields):
        raise InputError(f"checkpoint {where}: its design is damaged ({d!r})")
    for k, t in fields.items():
        v = d[k]
        if isinstance(v, bool) or not isinstance(v, t):
            raise InputError(f"checkpoint {where}: its design field {k!r} is {v!r}")
    if d["sampler"] not in UNITS_PER_BLOCK:
        raise InputError(f"checkpoint {where}: its design has an unknown sampler {d['sampler']!r}")
    if not (1 <= d["units"] <= UNBOUNDED_UNITS and 1 <= d["samples_per_unit"] <= 1 << 20
            and 0 <= d["strata_m"] <= MAX_AXIS_CELLS and 1 <= d["granule_blocks"] <= UNBOUNDED_UNITS):
        raise InputError(f"checkpoint {where}: its design is out of range ({d!r})")
    return Design(**d)


def _int_root(target: float, dim: int) -> int:
    m = max(int(math.floor(target ** (1.0 / dim))), 1)
    while (m + 1) ** dim <= target:
        m += 1
    while m > 1 and m**dim > target:
        m -= 1
    return m


def plan(sampler: str, dim: int, points: int, samples: int | None, design_samples: int | None) -> Design:
    """Choose the design of a run (see the module docstring for the rules)."""
    if sampler == "independent":
        return Design("independent", UNBOUNDED_UNITS, points, 0, 1)
    upb = UNITS_PER_BLOCK[sampler]
    if sampler == "stratified":
        per_unit = 2 * points
        if design_samples is None:
            design_samples = min(samples, STRATIFIED_DEFAULT_DESIGN) if samples else STRATIFIED_UNBOUNDED_DESIGN
        m = _int_root(design_samples / per_unit, dim)
        m = min(m, MAX_AXIS_CELLS)
        while m > 1 and m**dim > MAX_STRATA:
            m -= 1
        units = m**dim
        return Design("stratified", units, per_unit, m, -(-units // upb))
    if sampler == "nrooks":
        if design_samples is None:
            n = min(max(samples // (NROOKS_REPLICATES * points), 1), NROOKS_MAX_POINTS) if samples else NROOKS_UNBOUNDED_POINTS
        else:
            n = design_samples // points
        if not 1 <= n <= MAX_AXIS_CELLS:
            raise InputError(f"design_samples: an N-rooks design holds 1 to {MAX_AXIS_CELLS} points, got {n}")
        return Design("nrooks", n, points, 0, -(-n // upb))
    raise InputError(f"sampler: unknown sampler {sampler!r}; choose independent, stratified or nrooks")


def total_granules(design: Design, samples: int | None) -> tuple[int | None, int]:
    """(scheduler blocks to run, unit limit of the last one) for a sample budget.

    ``None`` blocks means unbounded (halting by time or target only).
    """
    if samples is None:
        return None, design.units
    if design.sampler == "independent":
        units = max(samples // design.samples_per_unit, 1)
        return -(-units // design.units_per_block), units
    per_design = design.units * design.samples_per_unit
    minimum = 2 if design.sampler == "nrooks" else 1
    return max(samples // per_design, minimum), design.units
