"""Progressive accumulation of per-block statistics, merged in index order.

Every estimator kernel turns a *block* of sample indices into a small array of
statistics (sums of contributions, of their squares, counts, ...; an image for
the renderer).  :class:`Accumulator` adds those arrays up **in block order**,
one block after the other, in float64.  Because the order of the additions is
fixed by the block index alone, the totals are bit-identical however the blocks
were split into launches, devices or runs (save, stop, load, resume).

Blocks may arrive out of order (several devices); they wait in ``pending``
until every earlier block has been folded.

The formulas that turn sums into an estimate live here too:
:func:`mean_and_variance` for i.i.d. samples (the lecture's secondary
estimator: the variance of the mean is sigma^2 / N).
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from .errors import InputError

FORMAT_VERSION = 1


class Accumulator:
    """Order-fixed float64 sums of per-block statistic arrays.

    Args:
        shape: the shape of one block's statistics (``(k,)`` for k scalars,
            ``(H, W, c)`` for an image).
        meta: a JSON-serialisable description of the job that produced the
            sums; saved with them and checked on :meth:`load`.
    """

    def __init__(self, shape: tuple[int, ...], meta: dict[str, Any] | None = None) -> None:
        self.shape = tuple(int(s) for s in shape)
        self.meta: dict[str, Any] = dict(meta or {})
        self.totals = np.zeros(self.shape, dtype=np.float64)
        self.blocks_done = 0
        self.pending: dict[int, np.ndarray] = {}

    def add(self, first_block: int, partials: np.ndarray) -> None:
        """Add the statistics of blocks ``first_block .. first_block + len(partials) - 1``.

        Args:
            first_block: index of the first block in ``partials``.
            partials: array of shape ``(nblocks, *shape)``.

        Raises:
            ValueError: the shape is wrong or the blocks were already added.
        """
        p = np.asarray(partials, dtype=np.float64)
        if p.shape[1:] != self.shape:
            raise ValueError(f"block statistics of shape {p.shape[1:]}, expected {self.shape}")
        if len(p) == 0:
            return
        if first_block < self.blocks_done or first_block in self.pending:
            raise ValueError(f"blocks starting at {first_block} were already added")
        self.pending[first_block] = p
        while self.blocks_done in self.pending:
            chunk = self.pending.pop(self.blocks_done)
            self._fold(chunk)
            self.blocks_done += len(chunk)

    def _fold(self, p: np.ndarray) -> None:
        # add.accumulate is sequential by definition (it yields every prefix),
        # so totals + p[0] + p[1] + ... is evaluated left to right whatever the
        # chunking: the bit-identity guarantee rests on this line.
        if len(p) == 1:
            self.totals = self.totals + p[0]
        else:
            self.totals = np.add.accumulate(np.concatenate([self.totals[None], p]), axis=0)[-1]

    # -- persistence -----------------------------------------------------

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the folded totals and metadata to ``path`` (atomically).

        Blocks still pending (waiting for an earlier block) are not saved: a
        resumed run recomputes them, and gets the same numbers.
        """
        path = Path(path)
        tmp = path.with_name(path.name + ".tmp")
        with open(tmp, "wb") as fh:
            np.savez(
                fh,
                totals=self.totals,
                blocks_done=np.int64(self.blocks_done),
                meta=np.array(json.dumps({"format": FORMAT_VERSION, **self.meta}, sort_keys=True)),
            )
        os.replace(tmp, path)

    @classmethod
    def load(cls, path: str | os.PathLike[str], expect_meta: dict[str, Any] | None = None) -> Accumulator:
        """Read an accumulator written by :meth:`save`.

        Args:
            expect_meta: if given, every key in it must match the saved
                metadata; a mismatch raises :class:`InputError` naming the key.
        """
        try:
            with np.load(path, allow_pickle=False) as z:
                totals = z["totals"]
                blocks = int(z["blocks_done"])
                meta = json.loads(str(z["meta"]))
        except FileNotFoundError:
            raise InputError(f"checkpoint {path} does not exist") from None
        except (OSError, KeyError, ValueError) as e:
            raise InputError(f"checkpoint {path} is not an mcocl checkpoint ({e})") from None
        if meta.pop("format", None) != FORMAT_VERSION:
            raise InputError(f"checkpoint {path} has an unsupported format version")
        if expect_meta:
            for key, want in expect_meta.items():
                got = meta.get(key)
                if json.dumps(got, sort_keys=True) != json.dumps(want, sort_keys=True):
                    raise InputError(
                        f"checkpoint {path} was made for a different job: {key} is {got!r} there, {want!r} here"
                    )
        acc = cls(totals.shape, meta)
        acc.totals = np.array(totals, dtype=np.float64)
        acc.blocks_done = blocks
        return acc


def mean_and_variance(n: float, s1: float, s2: float, shift: float = 0.0) -> tuple[float, float]:
    """Mean and unbiased sample variance from shifted sums.

    The kernels accumulate ``s1 = sum(v - c)`` and ``s2 = sum((v - c)**2)``
    for a constant shift ``c`` close to the mean, which keeps the variance
    formula ``(s2 - s1**2/n) / (n - 1)`` free of catastrophic cancellation
    when the variance is tiny against the mean (near zero-variance importance
    sampling, control variates).

    Returns:
        ``(mean, variance)``; the variance is ``nan`` for ``n < 2``.
    """
    if n <= 0:
        return math.nan, math.nan
    mean = shift + s1 / n
    if n < 2:
        return mean, math.nan
    var = max(s2 - s1 * s1 / n, 0.0) / (n - 1)
    return mean, var
