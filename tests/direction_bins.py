"""Cells on the unit sphere for the chi-square tests of direction samplers (tests/chi2.py).

Directions are binned over (cos theta, phi); the expected count of a bin is N
times the integral of the sampler's pdf over the bin, computed by
Gauss-Legendre quadrature (d omega = d cos(theta) d phi).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def directions_to_bins(d: np.ndarray, n_cos: int, n_phi: int, cos_range: tuple[float, float] = (-1.0, 1.0)) -> np.ndarray:
    """Flat bin index of each direction (rows of ``d``); -1 outside ``cos_range``."""
    lo, hi = cos_range
    c = np.clip(d[:, 2], -1.0, 1.0)
    phi = np.arctan2(d[:, 1], d[:, 0])
    i = np.floor((c - lo) / (hi - lo) * n_cos).astype(np.int64)
    j = np.floor((phi + np.pi) / (2 * np.pi) * n_phi).astype(np.int64)
    i = np.clip(i, 0, n_cos - 1)
    j = np.clip(j, 0, n_phi - 1)
    idx = i * n_phi + j
    idx[(c < lo) | (c > hi)] = -1
    return idx


def quadrature_directions(n_cos: int, n_phi: int, nq: int, cos_range: tuple[float, float] = (-1.0, 1.0)):
    """Quadrature nodes of every bin: directions (n_cos*n_phi*nq*nq, 3) and weights (same order, bin-major)."""
    x, w = np.polynomial.legendre.leggauss(nq)
    lo, hi = cos_range
    dc = (hi - lo) / n_cos
    dp = 2 * np.pi / n_phi
    ci = lo + (np.arange(n_cos)[:, None] + 0.5 * (x[None, :] + 1)) * dc  # (n_cos, nq)
    pj = -np.pi + (np.arange(n_phi)[:, None] + 0.5 * (x[None, :] + 1)) * dp  # (n_phi, nq)
    c = np.broadcast_to(ci[:, None, :, None], (n_cos, n_phi, nq, nq))
    p = np.broadcast_to(pj[None, :, None, :], (n_cos, n_phi, nq, nq))
    s = np.sqrt(np.maximum(0.0, 1 - c * c))
    dirs = np.stack([s * np.cos(p), s * np.sin(p), c], axis=-1).reshape(-1, 3)
    ww = (w[:, None] * w[None, :]) * (0.25 * dc * dp)
    weights = np.broadcast_to(ww, (n_cos, n_phi, nq, nq)).reshape(-1)
    return dirs, weights


def integrate_bins(pdf_values: np.ndarray, weights: np.ndarray, nbins: int) -> np.ndarray:
    """Sum quadrature terms per bin (inputs in the order of :func:`quadrature_directions`)."""
    return (pdf_values * weights).reshape(nbins, -1).sum(axis=1)


def converged_counts(pdf_of: Callable[[np.ndarray], np.ndarray], idx: np.ndarray, n: int, n_cos: int, n_phi: int,
                     cos_range: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Observed and expected counts of ``n`` sampled directions in the bins, plus one cell for the lost samples.

    ``idx`` holds the bins of the valid samples (:func:`directions_to_bins`);
    ``pdf_of(dirs)`` is the sampler's solid-angle pdf.  The bins' masses are
    integrated with 8, 16 and then 32 quadrature nodes per axis, until two
    orders agree to 0.2 standard deviations of the counts (a peaked lobe
    needs more).  The masses may sum to less than 1: the rest is the
    expected count of samples the sampler gives up (pdf 0).
    """
    nbins = n_cos * n_phi
    prev = None
    for nq in (8, 16, 32):
        dirs, wts = quadrature_directions(n_cos, n_phi, nq, cos_range)
        mass = integrate_bins(np.asarray(pdf_of(dirs), np.float64), wts, nbins)
        if prev is not None and np.max(np.abs(mass - prev) * n / np.sqrt(np.maximum(mass * n, 1))) < 0.2:
            break
        prev = mass
    assert mass.sum() <= 1 + 2e-3, mass.sum()
    observed = np.append(np.bincount(idx, minlength=nbins), n - len(idx))
    expected = np.append(mass * n, max(n * (1 - mass.sum()), 0.0))
    return observed, expected
