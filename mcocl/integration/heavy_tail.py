"""Warning of infinite or unstable variance (issue 12, part 3).

A Monte Carlo standard error means something only when the integrand's
variance is finite and the run has seen its distribution.  For f = x^-a on
[0, 1] the variance is infinite from a = 1/2 on: the sample mean still
converges, but more slowly than 1/sqrt(N), the reported standard error is too
small, and runs sit many "standard errors" below the truth.  Nothing in the
mean or the variance estimate shows it.

What does show it is how the sum of squared deviations is shared among the
blocks of the run (each block is a fixed set of samples, so the blocks are
independent and alike).  With a finite fourth moment every block holds about
1/B of the sum.  When the squares have an infinite mean (an infinite
variance) the sum is dominated by its largest terms, and the largest block
keeps a share that does not shrink with B (for a Pareto tail of index
alpha < 1 the largest term's expected share is 1 - alpha).  The same happens
with a finite but not yet resolved variance, e.g. a narrow peak hit by a
handful of samples: the standard error is unreliable then too.

So the accumulator records the largest block's sum of squares, and the run
reports a warning when, with at least MIN_BLOCKS blocks, that block holds
more than SHARE_LIMIT of the total and at least SPREAD_LIMIT times its fair
share 1/B.
"""

from __future__ import annotations

import math

import numpy as np

from ..accumulate import Accumulator

#: Column of the integration statistics holding the sum of squared deviations (job.py).
SQUARES = 3
#: Where the largest block's sum of squares is kept (in the checkpoint's metadata).
PEAK_KEY = "largest_block_squares"
MIN_BLOCKS = 32
SHARE_LIMIT = 0.1
SPREAD_LIMIT = 8.0


class TailWatchingAccumulator(Accumulator):
    """An :class:`Accumulator` that also keeps the largest block's sum of squares.

    The maximum does not depend on the order of the blocks, so it is the same
    however the work was split, and it is saved with the checkpoint.
    """

    def _fold(self, p: np.ndarray) -> None:
        super()._fold(p)
        peak = float(np.max(p[:, SQUARES]))
        if math.isfinite(peak) and peak > float(self.meta.get(PEAK_KEY, 0.0)):
            self.meta[PEAK_KEY] = peak


def heavy_tail_share(acc: Accumulator) -> float | None:
    """The largest block's share of the sum of squared deviations, or None when too few blocks were folded."""
    total = float(acc.totals[SQUARES])
    peak = acc.meta.get(PEAK_KEY)
    if acc.blocks_done < MIN_BLOCKS or not isinstance(peak, (int, float)) or not total > 0 or not math.isfinite(total):
        return None
    return min(1.0, float(peak) / total)


def heavy_tail_note(acc: Accumulator) -> str | None:
    """A warning for ``notes`` when one block dominates the squares (see the module docstring), else None."""
    share = heavy_tail_share(acc)
    if share is None or share <= SHARE_LIMIT or share * acc.blocks_done <= SPREAD_LIMIT:
        return None
    return (
        f"WARNING: the variance looks infinite or unresolved: one block of {acc.blocks_done} holds "
        f"{100 * share:.0f}% of the sum of squared deviations, so the standard error is unreliable (too small) "
        "and the error may fall slower than 1/sqrt(N). A singularity such as x^-a with a >= 1/2 does this: "
        "sample it with a power-law proposal (proposals=mcocl.power(-a), on the CLI --proposal power:a=-a, "
        "with a near the singularity's exponent), or substitute to remove it; a narrow peak needs more samples "
        "or the vegas sampler"
    )
