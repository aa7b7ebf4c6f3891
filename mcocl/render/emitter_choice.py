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

Area lights (``integrator.light_sampler``): ``"power"`` chooses an emitting
primitive in proportion to its power, luminance · area · π (pbrt-v4's power
light sampler), ``"uniform"`` every emitting primitive with the same
probability; ``"bvh"`` uses the same power CDF for the tables but the kernel
chooses through the light BVH (:mod:`mcocl.render.light_bvh`).  Luminance is
Rec. 709: 0.2126 R + 0.7152 G + 0.0722 B.

The environment's share.  It used to be its power π · luminance · 4π R²
into the bounding sphere of the scene (radius R), which a large ground plane
makes huge: on bench/make_big_scene.py's scene the dim sky took 99.5 % of
the light samples.  The share is now :data:`ENV_SHARE` (1/2) whenever the
scene has both an environment and area lights, whatever their size or
power — Mitsuba 3's uniform choice among its emitters gives the same split
for one area light.  Measured (bench/env_share.py, noise per sample of
``mis`` against a long reference; figures in scenes/README.md) against the
old bounding-sphere rule and a share of 1/(number of emissive shapes + 1)
(Mitsuba's uniform choice per emitter): TODO-MEASURE.
"""

from __future__ import annotations

import numpy as np

from ..rng import GRID_CELLS

GRID = GRID_CELLS  # the uniforms' grid (kernels/rng/uniform.cl): u = (m + 1/2) / 2^23
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


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


ENV_SHARE = 0.5  # the environment's share of light samples when there are area lights too


def light_choice(power: np.ndarray, sampler: str = "power") -> tuple[np.ndarray, np.ndarray]:
    """``(cdf, pmf)`` of the area-light choice over lights of the given powers (float64, >= 0).

    ``sampler`` ``"power"`` and ``"bvh"``: proportional to ``power`` (the BVH
    sampler chooses in the kernel; its tables keep the power CDF); ``"uniform"``:
    the same for every light of non-zero power.  ``cdf`` float32 (L + 1,) with
    ``cdf[0] = 0``, ``cdf[L] = 1``; ``pmf`` the exact grid probabilities
    (:func:`cdf_choice_pmf`).  All lights black: ``([0], [])``.
    """
    power = np.asarray(power, np.float64)
    weight = (power > 0).astype(np.float64) if sampler == "uniform" else power
    total = float(weight.sum())
    if total <= 0.0:
        return np.zeros(1, np.float32), np.zeros(0, np.float32)
    cdf = np.concatenate([[0.0], np.cumsum(weight) / total]).astype(np.float32)
    cdf[-1] = 1.0
    # A black light keeps its slot with probability 0: CDF inversion never picks it.
    return cdf, cdf_choice_pmf(cdf)


def environment_choice(env_rgb: np.ndarray, has_area_lights: bool) -> tuple[float, float]:
    """``(env_threshold, env_pmf)``: the environment is chosen when u < threshold, with exact probability env_pmf.

    The share is :data:`ENV_SHARE` when there are area lights too, 1 without
    them, 0 without an environment: it does not depend on the scene's size
    (see the module docstring for why and how it was chosen).
    """
    has_env = bool(np.any(np.asarray(env_rgb, np.float32)[:3] > 0))
    if has_env and has_area_lights:
        threshold = np.float32(ENV_SHARE)
    elif has_env:
        threshold = np.float32(1.0)
    else:
        threshold = np.float32(0.0)
    return float(threshold), float(cells_below(threshold)) / GRID


__all__ = ["ENV_SHARE", "GRID", "LUMINANCE", "cdf_choice_pmf", "cells_below", "environment_choice",
           "light_choice"]
