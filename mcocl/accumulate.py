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

import hashlib
import json
import math
import os
import tokenize
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .datafile import loads_json
from .errors import InputError
from .output_files import write_atomically

# 2: a SHA-256 digest of the contents is saved with them (version 1 files are refused: unverifiable).
FORMAT_VERSION = 2


@dataclass
class RowRanges:
    """Statistics of consecutive blocks, each zero outside one range of rows of its block.

    A block's statistics of shape ``shape`` are seen as rows (the product of the
    leading axes, e.g. the pixels of an ``(H, W, STATS)`` film) of
    ``shape[-1]`` numbers; block ``i`` holds ``values[i, :counts[i]]`` at rows
    ``starts[i] ..`` and zeros elsewhere (a sobol render's block of one pixel
    range: mcocl/render/job.py).  :meth:`Accumulator.add` folds only those rows:
    the same bits as folding the whole zero-padded block (x + 0.0 is x for the
    finite, non-negative sums a film holds), at the cost of the range rather
    than of the whole film, which made a film cut into T ranges cost T times
    its size per batch on the host.

    Attributes:
        values: ``(nblocks, rows, shape[-1])`` the blocks' rows (``rows`` at least every count).
        starts, counts: per block, the first row and the number of rows it holds.
        shape: one block's full shape.
    """

    values: np.ndarray
    starts: tuple[int, ...]
    counts: tuple[int, ...]
    shape: tuple[int, ...]

    def __len__(self) -> int:
        return len(self.starts)

    def dense(self) -> np.ndarray:
        """The blocks as one ``(nblocks, *shape)`` array, zeros outside their ranges."""
        out = np.zeros((len(self), int(np.prod(self.shape[:-1])), self.shape[-1]), self.values.dtype)
        for i, (s, n) in enumerate(zip(self.starts, self.counts)):
            out[i, s:s + n] = self.values[i, :n]
        return out.reshape((len(self), *self.shape))

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        d = self.dense()
        return d if dtype is None else d.astype(dtype)


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
        p: np.ndarray | RowRanges
        if isinstance(partials, RowRanges):
            p = partials
            if tuple(p.shape) != self.shape:
                raise ValueError(f"block statistics of shape {tuple(p.shape)}, expected {self.shape}")
        else:
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

    def _fold(self, p: np.ndarray | RowRanges) -> None:
        if isinstance(p, RowRanges):
            # The blocks' rows in block order (the same bits as their dense form), in place: a fresh copy
            # of the whole film per chunk would cost what the sparse fold saves.  The folds run in the
            # caller's thread between reads of the totals, so no reader sees a half-added block.
            if not (self.totals.flags.c_contiguous and self.totals.dtype == np.float64):
                self.totals = np.ascontiguousarray(self.totals, dtype=np.float64)
            rows = self.totals.reshape(-1, self.shape[-1])  # a view: the adds land in the totals
            for i, (s, n) in enumerate(zip(p.starts, p.counts)):
                np.add(rows[s:s + n], p.values[i, :n], out=rows[s:s + n], dtype=np.float64)
            return
        # totals + p[0] + p[1] + ... is evaluated left to right whatever the
        # chunking: the bit-identity guarantee rests on this order.  One
        # whole-array add per block (into a fresh array, so no caller's view of
        # the old totals changes): np.add.accumulate along axis 0 gives the same
        # sums but walks the blocks element by element, a whole block apart in
        # memory, and took most of a splatting render's host time on images.
        totals = self.totals + p[0]
        for block in p[1:]:
            np.add(totals, block, out=totals)
        self.totals = totals

    # -- persistence -----------------------------------------------------

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the folded totals and metadata to ``path`` (atomically, under a unique temporary name).

        Blocks still pending (waiting for an earlier block) are not saved: a
        resumed run recomputes them, and gets the same numbers.  A SHA-256
        digest over the arrays and the metadata is saved with them, so
        :meth:`load` refuses a damaged or edited file.
        """
        totals = np.ascontiguousarray(self.totals, dtype=np.float64)
        meta = json.dumps({"format": FORMAT_VERSION, **self.meta}, sort_keys=True)
        digest = _digest(totals, self.blocks_done, meta)

        def write(tmp: Path) -> None:
            with open(tmp, "wb") as fh:
                np.savez(fh, totals=totals, blocks_done=np.int64(self.blocks_done), meta=np.array(meta),
                         sha256=np.array(digest))

        write_atomically(path, write)

    @classmethod
    def load(cls, path: str | os.PathLike[str], expect_meta: dict[str, Any] | None = None) -> Accumulator:
        """Read an accumulator written by :meth:`save`.

        Every failure is an :class:`InputError` naming the file: not there,
        not a checkpoint at all (an image, a truncated or empty file), damaged
        or edited (the digest does not match), or written for another job.

        Args:
            expect_meta: if given, every key in it must match the saved
                metadata; a mismatch raises :class:`InputError` naming the key.
        """
        name = f"checkpoint {path}"
        try:
            with open(path, "rb") as fh:
                head = fh.read(4)
        except FileNotFoundError:
            raise InputError(f"{name} does not exist") from None
        except OSError as e:
            raise InputError(f"{name}: cannot read it: {e.strerror or e}") from None
        if head != b"PK\x03\x04":
            raise InputError(f"{name} is not an mcocl checkpoint (a checkpoint is the .npz archive that "
                             f"--checkpoint writes; this file {'is empty' if not head else 'is something else'})")
        try:
            with np.load(path, allow_pickle=False) as z:
                if set(z.files) != {"totals", "blocks_done", "meta", "sha256"}:
                    raise InputError(f"{name} is not an mcocl checkpoint of this version (arrays {sorted(z.files)})")
                totals = np.asarray(z["totals"])
                blocks_arr = np.asarray(z["blocks_done"])
                meta_text = str(z["meta"])
                digest = str(z["sha256"])
        except InputError:
            raise
        # tokenize.TokenError and SyntaxError: NumPy parses each array's header as a Python literal
        except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile, zlib.error, UnicodeDecodeError,
                RuntimeError, MemoryError, tokenize.TokenError, SyntaxError) as e:
            raise InputError(f"{name} is damaged or truncated ({type(e).__name__}: {e})") from None
        if totals.dtype != np.float64 or blocks_arr.shape != () or blocks_arr.dtype != np.int64:
            raise InputError(f"{name} is damaged: unexpected array types")
        blocks = int(blocks_arr)
        if digest != _digest(np.ascontiguousarray(totals), blocks, meta_text):
            raise InputError(f"{name} is damaged or was edited: its SHA-256 digest does not match its contents")
        try:
            meta = loads_json(meta_text, name)
        except ValueError as e:
            raise InputError(f"{name} has unreadable metadata ({e})") from None
        if not isinstance(meta, dict) or meta.pop("format", None) != FORMAT_VERSION:
            raise InputError(f"{name} has an unsupported format version")
        if blocks < 0:
            raise InputError(f"{name} is damaged: {blocks} blocks done")
        acc = cls(totals.shape, meta)
        acc.check_meta(expect_meta or {}, path)
        acc.totals = np.array(totals, dtype=np.float64)
        acc.blocks_done = blocks
        return acc

    def check_meta(self, expect_meta: dict[str, Any], path: Any) -> None:
        """Every key of ``expect_meta`` must match the saved metadata, else :class:`InputError` naming the key."""
        for key, want in expect_meta.items():
            got = self.meta.get(key)
            if json.dumps(got, sort_keys=True) != json.dumps(want, sort_keys=True):
                raise InputError(
                    f"checkpoint {path} was made for a different job: {key} is {got!r} there, {want!r} here"
                )

    def meta_int(self, key: str, path: Any, lo: int, hi: int) -> int:
        """The saved integer ``meta[key]``, which must lie in ``[lo, hi]`` (else :class:`InputError`)."""
        v = self.meta.get(key)
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            raise InputError(f"checkpoint {path}: its field {key!r} is {v!r}, not a whole number in [{lo}, {hi}]")
        return v

    def meta_float(self, key: str, path: Any, limit: float) -> float:
        """The saved number ``meta[key]``, finite and at most ``limit`` in magnitude (else :class:`InputError`)."""
        v = self.meta.get(key)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or abs(v) > limit:
            raise InputError(f"checkpoint {path}: its field {key!r} is {v!r}, not a number of magnitude <= {limit:g}")
        return float(v)

    def check_shape(self, shape: tuple[int, ...], path: str | os.PathLike[str]) -> None:
        """Refuse a loaded checkpoint whose totals do not have the job's statistics shape."""
        if self.shape != tuple(int(s) for s in shape):
            raise InputError(f"checkpoint {path} holds statistics of shape {self.shape}; this job needs {tuple(shape)}")


def _digest(totals: np.ndarray, blocks_done: int, meta: str) -> str:
    """SHA-256 over the totals (dtype, shape, bytes), the block count and the metadata text."""
    h = hashlib.sha256()
    h.update(f"mcocl-checkpoint {totals.dtype.str} {totals.shape} {int(blocks_done)}\n".encode())
    h.update(totals.tobytes())
    h.update(meta.encode("utf-8", "surrogatepass"))
    return h.hexdigest()


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
