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
chooses through the light BVH (:mod:`mcocl.render.light_bvh`); ``"auto"``
(the default) is ``"bvh"`` where that tree is flat and ``"power"`` elsewhere
(:func:`resolve_light_sampler`).  Luminance is
Rec. 709: 0.2126 R + 0.7152 G + 0.0722 B.

The environment's share.  It used to be its power π · luminance · 4π R²
into the bounding sphere of the scene (radius R), which a large ground plane
makes huge: on bench/make_big_scene.py's scene the dim sky took 99.1 % of
the light samples.  The share no longer depends on the scene's size:

- ``mis``: 0.  The environment is constant, so the radiance arriving from
  it is proportional to what the BSDF's own sampling already follows (the
  BSDF times the cosine), up to visibility; uniform directions on the sphere
  can only do worse, and every light sample they take is one the area lights
  lose.  The environment is then found by BSDF sampling alone, with MIS
  weight 1 (its light pdf is 0), which is unbiased.  (An environment *map*
  would need its own importance sampling and a share of its own.)
- ``nee``: 1/2 when there are area lights too (:data:`ENV_SHARE`), else 1:
  that integrator sees the environment only through light samples after the
  first vertex, so it must keep a fixed share; 1/2 is what Mitsuba 3's
  uniform choice among emitters gives for one area light.
- ``path`` does not sample lights; ``lt`` (light tracing) starts 1/2 of its
  light paths at the environment when there are area lights too, like ``nee``.

Measured with bench/light_choice.py (variance of the pixel means at equal
spp, ``mis``, 96 px wide, 64 spp; noise relative to the old rule):

==============================  ==========  =====  =====  =====  =====
scene                           old rule    1/2    1/8    1/32   0
==============================  ==========  =====  =====  =====  =====
big-mesh scene, sky 0.05        1 (0.991)   92.7   411    738    964
many_lights.json, sky 2         1 (0.973)   1.56   1.69   1.70   1.71
veach_mis.json, sky 0.5         --          1      1.09   1.11   1.12
==============================  ==========  =====  =====  =====  =====

(the veach row relative to the share 1/2).  A share of 1/(emissive shapes +
1), Mitsuba's uniform choice per emitter, was 1/2 on the big scene and 1.69
on the many-light scene: between the two.
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


MIN_ENV_RADIUS = 1e-3  # a point-sized scene still gets a bounding sphere light rays can start outside
FLAT_LIGHTS = 16  # at most this many area lights: a flat light BVH (kernels/render/light_bvh.cl)
ENV_SHARE = 0.5  # the environment's share of light samples under ``nee`` when there are area lights too


def bounding_sphere(bounds: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre (float64 (3,)) and radius of the scene's bounding sphere: the box's centre and half its
    diagonal, at least ``MIN_ENV_RADIUS`` (light tracing's environment rays start outside it)."""
    lo, hi = np.asarray(bounds, np.float32).astype(np.float64)
    return 0.5 * (lo + hi), max(0.5 * float(np.linalg.norm(hi - lo)), MIN_ENV_RADIUS)


def resolve_light_sampler(name: str, area_lights: int, point_lights: int) -> str:
    """The light sampler ``"auto"`` stands for (other names unchanged), from the scene's lights.

    ``"bvh"`` when the scene has 2 to :data:`FLAT_LIGHTS` emitting primitives
    and no point, spot or directional light (the light BVH is then flat,
    mcocl/render/light_bvh.py: a sample costs about what the power table's
    does and the image's noise is lower), else ``"power"`` (a deep tree costs
    1.5x per sample and lost on MSE per second on scenes/many_lights.json;
    measured in scenes/README.md, *Light choice*).
    """
    if name != "auto":
        return name
    return "bvh" if 2 <= area_lights <= FLAT_LIGHTS and point_lights == 0 else "power"


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


def environment_choice(env_rgb: np.ndarray, has_area_lights: bool, integrator: str = "mis",
                       share: float | None = None, env_map: bool = False) -> tuple[float, float]:
    """``(env_threshold, env_pmf)``: the environment is chosen when u < threshold, with exact probability env_pmf.

    The share follows the integrator (see the module docstring for why and
    the measurements): 0 for ``mis``; for ``nee`` and ``path``
    :data:`ENV_SHARE` with area lights, 1 without; 0 without an environment.
    An environment *map* (``env_map``; mcocl/render/envmap.py) is importance
    sampled, so under ``mis`` too it gets :data:`ENV_SHARE` with other lights
    (point, spot and directional lights count), 1 without.
    ``share`` overrides the rule (for measurements).
    """
    has_env = bool(np.any(np.asarray(env_rgb, np.float32)[:3] > 0))
    if not has_env:
        threshold = np.float32(0.0)
    elif share is not None:
        threshold = np.float32(share)
    elif integrator == "mis" and not env_map:
        threshold = np.float32(0.0)
    else:
        threshold = np.float32(ENV_SHARE if has_area_lights else 1.0)
    return float(threshold), float(cells_below(threshold)) / GRID


__all__ = ["ENV_SHARE", "FLAT_LIGHTS", "resolve_light_sampler", "GRID", "LUMINANCE", "bounding_sphere", "cdf_choice_pmf", "cells_below",
           "environment_choice", "light_choice"]
