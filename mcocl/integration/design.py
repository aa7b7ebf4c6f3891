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

import dataclasses
from collections.abc import Collection
from dataclasses import asdict, dataclass

from ..errors import InputError

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
        replicates: designs a sample budget runs (sobol: its R independent
            scramblings), else 0 (the budget decides, see ``granules``).
        bins: bins per dimension of the VEGAS grid (vegas), else 0.
        double: 1 when the integrand is evaluated and its sums kept in double
            (``precision="double"``), else 0 (float32, the default).
        scrambling: sobol's scrambling, an index into ``Sobol.SCRAMBLINGS``
            (0: the Laine-Karras hash, the default; 1: random linear matrix
            scrambling with a digital shift), else 0.
    """

    sampler: str
    units: int
    samples_per_unit: int
    strata_m: int
    granule_blocks: int
    replicates: int = 0
    bins: int = 0
    double: int = 0
    scrambling: int = 0

    def to_dict(self) -> dict:
        """JSON form (saved in checkpoints)."""
        return asdict(self)


def design_from_checkpoint(d: object, where: object, samplers: Collection[str]) -> Design:
    """The :class:`Design` saved in a checkpoint, every field checked (else :class:`InputError`).

    Args:
        d: the checkpoint's ``design`` entry.
        where: the checkpoint, for messages.
        samplers: the registered sampler names (:mod:`mcocl.integration.samplers`).
    """
    fields = {"sampler": str, "units": int, "samples_per_unit": int, "strata_m": int, "granule_blocks": int}
    # fields added later default to 0 in Design, so checkpoints written before them still load
    optional = {f.name: int for f in dataclasses.fields(Design) if f.name not in fields}
    if not isinstance(d, dict) or not set(fields) <= set(d) <= set(fields) | set(optional):
        raise InputError(f"checkpoint {where}: its design is damaged ({d!r})")
    for k, t in {**fields, **optional}.items():
        if k not in d:
            continue
        v = d[k]
        if isinstance(v, bool) or not isinstance(v, t):
            raise InputError(f"checkpoint {where}: its design field {k!r} is {v!r}")
    if d["sampler"] not in samplers:
        raise InputError(f"checkpoint {where}: its design has an unknown sampler {d['sampler']!r}")
    if not (1 <= d["units"] <= UNBOUNDED_UNITS and 1 <= d["samples_per_unit"] <= 1 << 20
            and 0 <= d["strata_m"] <= MAX_AXIS_CELLS and 1 <= d["granule_blocks"] <= UNBOUNDED_UNITS):
        raise InputError(f"checkpoint {where}: its design is out of range ({d!r})")
    if any(not 0 <= d.get(k, 0) <= UNBOUNDED_UNITS for k in optional) or d.get("double", 0) not in (0, 1):
        raise InputError(f"checkpoint {where}: its design is out of range ({d!r})")
    return Design(**d)
