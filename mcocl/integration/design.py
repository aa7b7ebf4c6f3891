"""The design of an integration run: how many samples make one unbiased whole.

A *design* is the set of samples an estimator must see complete to be
unbiased: one stratification of the cube (stratified), one Latin hypercube
(nrooks).  Runs are made of whole designs, so a run can stop after any design
and still be unbiased; the independent sampler has no design structure and
stops after any block.

How each sampler sizes its design and rounds a sample budget (documented for
users in README and ``--help``) is written with the sampler, in
:mod:`mcocl.integration.samplers`.  A :class:`Design` is plain data: it is
saved in checkpoints and shipped to other processes.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

# The independent sampler's "design" is unbounded: any block may end a run.
UNBOUNDED_UNITS = 1 << 62
# Coordinates are float32 cells: at most 2^22 cells per axis keep them distinct.
MAX_AXIS_CELLS = 1 << 22


@dataclass(frozen=True)
class Design:
    """The design of one integration run.

    Attributes:
        sampler: the sampler's registered name (``independent``, ``stratified``, ``nrooks``).
        units: units per design (``UNBOUNDED_UNITS`` for independent).
        samples_per_unit: integrand evaluations per unit.
        strata_m: strata per axis (stratified), else 0.
        granule_blocks: kernel blocks per scheduler block (a design, or 1).
        bins: bins per dimension of the VEGAS grid (vegas), else 0.
    """

    sampler: str
    units: int
    samples_per_unit: int
    strata_m: int
    granule_blocks: int
    bins: int = 0

    def to_dict(self) -> dict:
        """JSON form (saved in checkpoints)."""
        return asdict(self)
