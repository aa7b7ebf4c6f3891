"""The walk sampler ``sobol``: randomised quasi-Monte Carlo walks with a replicate-spread standard error.

Walk w of a query point is sample w of the sampler (kernels/walks/walk_rng.cl).
With blocks of 2^m walks (``walks_per_block``) and the Sobol' back end built
with SOBOL_LOG2_POINTS = m (kernels/samplers/sobol_sampler.cl), walk j of
block b is Sobol' point j of scrambling b: every block is one independent
Owen scrambling (a replicate) of all the walk's dimensions, each dimension
with its own seed.  Dimensions past the table (long walks) are padded by
index shuffling, as in the sobol_sampler.cl comment.

The standard error.  The walks of a block are not independent, so the
per-walk variance would be wrong.  :func:`walk_batches` turns each block
into one batch per query point: Y_b = the mean of its finite walks (minus the
point's shift), stored as count 1, sum Y_b, sum Y_b^2, the other columns
(non-finite walks, moves, guard hits) unchanged.  The estimate is the mean of
the R batch means and its stderr sqrt(var(Y_b) / R), as integration's
``sampler="sobol"`` does (mcocl/integration/samplers.py, Sobol).
"""

from __future__ import annotations

import numpy as np

WALK_SAMPLERS = ("independent", "sobol")
REPLICATES = 16
MAX_LOG2_WALKS = 30
# Sobol' dimensions in a walk build's table; later ones are padded.
WALK_TABLE_DIMS = 256


def sobol_walks_per_block(walks: int | None, replicates: int | None, default: int) -> int:
    """Walks per block (= per replicate), a power of two: the largest with ``replicates`` (default
    REPLICATES) blocks in ``walks``, at most ``default`` unless ``replicates`` is given; ``default``
    when the run is unbounded (time or target halting)."""
    if walks is None:
        return default
    r = REPLICATES if replicates is None else replicates
    n = max(walks // r, 1)
    per = 1 << min(n.bit_length() - 1, MAX_LOG2_WALKS)
    return per if replicates is not None else min(per, default)


def walk_sobol_defines(walks_per_block: int) -> list[str]:
    """Build options: the Sobol' back end with 2^m >= walks_per_block points per scrambling."""
    log2 = max(int(walks_per_block) - 1, 0).bit_length()
    return ["-DSAMPLER_BACKEND=SAMPLER_BACKEND_SOBOL", f"-DSOBOL_LOG2_POINTS={log2}",
            f"-DSOBOL_TABLE_DIMS={WALK_TABLE_DIMS}"]


def walk_batches(stats: np.ndarray) -> np.ndarray:
    """(nblocks, nq, STATS) walk statistics -> one batch per block and point (see the module docstring)."""
    t = np.asarray(stats, dtype=np.float64)
    n = t[..., 0]
    y = np.where(n > 0, t[..., 2] / np.where(n > 0, n, 1.0), 0.0)
    out = t.copy()
    out[..., 0] = (n > 0).astype(np.float64)
    out[..., 2] = y
    out[..., 3] = y * y
    return out


__all__ = ["REPLICATES", "WALK_SAMPLERS", "WALK_TABLE_DIMS", "sobol_walks_per_block", "walk_batches",
           "walk_sobol_defines"]
