"""Which emitter light sampling chooses, with the probabilities the kernel really has.

kernels/render/lights.cl chooses the constant environment when a uniform
``u_env < env_threshold`` and otherwise an emitting primitive by inverting
``light_cdf`` with a second uniform (the largest k with ``light_cdf[k] <= u``).
The uniforms are not continuous: they are the 2^23 cell centres
``u_m = (m + 1/2) / 2^23`` of kernels/rng/uniform.cl.  The probability of a
choice is therefore the share of grid cells mapped to it, which differs from
the difference of two float32 CDF values by up to a cell (2^-23); an
estimator that divides by the float difference is biased by that much.
The functions here count the cells, and :func:`mcocl.render.compiled.compile_scene`
stores their results, so that every consumer of a compiled scene (the
render kernel's records, tests, benchmarks) sees one set of probabilities.

Powers (the choice is proportional to them, like pbrt-v4's power light
sampler): an area emitter sends luminance · area · π; the constant
environment sends π · luminance · 4π R² into the scene's bounding sphere of
radius R (half the diagonal of the geometry's box).  Luminance is Rec. 709:
0.2126 R + 0.7152 G + 0.0722 B.
"""

from __future__ import annotations

import math

import numpy as np

from ..rng import GRID_CELLS

GRID = GRID_CELLS  # the uniforms' grid (kernels/rng/uniform.cl): u = (m + 1/2) / 2^23
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
MIN_ENV_RADIUS = 1e-3  # an environment around a point-sized scene still gets a finite power


def cells_below(x: np.ndarray | float) -> np.ndarray:
    """How many grid uniforms u_m = (m + 1/2) / 2^23 are < x (exact for float32 x)."""
    c = np.ceil(np.asarray(x, np.float64) * GRID - 0.5)
    return np.clip(c, 0, GRID)


def cdf_choice_pmf(cdf: np.ndarray) -> np.ndarray:
    """float32 (L,): the exact probability that CDF inversion on the grid picks entry k of ``cdf`` (L + 1,).

    Entry k is picked for the cells with ``cdf[k] <= u < cdf[k + 1]`` (the last
    one up to 1); a black light (``cdf[k] == cdf[k + 1]``) gets no cell.
    """
    cdf = np.asarray(cdf, np.float32)
    n = len(cdf) - 1
    if n <= 0:
        return np.zeros(0, np.float32)
    below = cells_below(cdf[:n])
    upper = np.append(below[1:], GRID)
    return ((upper - below) / GRID).astype(np.float32)


def area_power(radiance_rgb: np.ndarray, area: np.ndarray) -> float:
    """Total power of area emitters: sum of luminance · area · π (float64 from the float32 tables)."""
    if len(area) == 0:
        return 0.0
    lum = np.asarray(radiance_rgb, np.float32).astype(np.float64) @ LUMINANCE
    return float(np.sum(lum * np.asarray(area, np.float32).astype(np.float64) * math.pi))


def bounding_sphere(bounds: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre (float64 (3,)) and radius of the scene's bounding sphere: the box's centre and half its
    diagonal, at least ``MIN_ENV_RADIUS`` (the sphere the environment's power and light rays refer to)."""
    lo, hi = np.asarray(bounds, np.float32).astype(np.float64)
    return 0.5 * (lo + hi), max(0.5 * float(np.linalg.norm(hi - lo)), MIN_ENV_RADIUS)


def environment_choice(env_rgb: np.ndarray, bounds: np.ndarray, p_area: float) -> tuple[float, float]:
    """``(env_threshold, env_pmf)``: the environment is chosen when u < threshold, with exact probability env_pmf."""
    env = np.asarray(env_rgb, np.float32)[:3].astype(np.float64)
    p_env = 0.0
    if np.any(env > 0):
        radius = bounding_sphere(bounds)[1]
        p_env = math.pi * float(env @ LUMINANCE) * 4.0 * math.pi * radius ** 2
    if p_env > 0 and p_area > 0:
        threshold = np.float32(p_env / (p_env + p_area))
    elif p_env > 0:
        threshold = np.float32(1.0)
    else:
        threshold = np.float32(0.0)
    return float(threshold), float(cells_below(threshold)) / GRID


__all__ = ["GRID", "LUMINANCE", "area_power", "bounding_sphere", "cdf_choice_pmf", "cells_below", "environment_choice"]
