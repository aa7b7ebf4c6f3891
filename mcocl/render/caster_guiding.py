"""Caustic casters: the glass shapes towards which ``nee`` and ``mis`` aim part of their continuations.

A path tracer finds a caustic (a small lamp focused by glass onto a diffuse
surface: light -> glass -> glass -> diffuse -> camera) only when the diffuse
vertex's BSDF sample happens to leave towards the glass and, through it, hits
the lamp; next-event estimation cannot connect through a delta surface.  On
scenes/caustic.json 50 % of a 64 spp render's squared error sits in 19 of
19,200 pixels at the focus (bench/error_concentration.py).

At the first non-delta vertex of a path (the surface whose caustic the camera
sees, directly or through mirrors and glass), where its BSDF does not refract,
``nee`` and ``mis`` (kernels/render/integrator.cl, -DCASTER_GUIDING=K) choose
the continuation from a mixture (one-sample MIS with the balance heuristic,
Veach's thesis §9.2.4; the lecture's "kombinované odhady"): with probability
:data:`CASTER_SHARE` a direction uniform in the cone that one caster's
bounding sphere subtends from the point (the casters the point lies outside,
chosen uniformly), else the BSDF's own sample.  The path's weight is f cos
over the mixture density ``share * p_cone + (1 - share) * p_bsdf`` whichever
technique drew the direction, and the same mixture density is the BSDF
strategy's pdf in the MIS weights of the vertex's light sample and of the
emitter its continuation hits, so the estimator stays unbiased and both MIS
weights of a path still sum to one (tests/test_render_caster_guiding.py: a
glass ball in the white furnace; caustic.json against bdpt).  A delta lobe
the BSDF picks (smooth plastic's coating) is drawn with probability
(1 - share) times its own, and its weight is divided by (1 - share).

What it costs: a direction outside every cone keeps (1 - share) of its BSDF
density, so the vertex's weight grows by up to 1 / (1 - share) (4x at 0.75).
At one vertex per path that bounds the harm; applied at every vertex of a
closed Cornell box with a glass ball the factors compounded and the image
was 100x noisier.  Aimed paths also run longer (through the glass and on).

Where: casters are the shapes whose material is a smooth ``dielectric`` (it
bends light into caustics; ``thindielectric`` passes it straight, and a
mirror's reflected caustics are left to BSDF sampling), each bounded by the
sphere around its bounding box, and only those from whose centre some area
light's bounding sphere subtends less than :data:`SMALL_LIGHT_SR`: a small
light makes a sharp caustic that BSDF sampling rarely finds, a large one a
soft caustic that it finds well (the Cornell box's ceiling light subtends
0.17 sr from its glass ball, and aiming there cost a third of the
efficiency at share 0.5; caustic.json's lamp subtends 0.00045 sr, and
aiming made mis 1.6-1.8x as efficient: README, *Caustics*).  Point and
spot lights do not count (no path hits them, aimed or not).  A scene with
more than :data:`MAX_CASTERS` casters gets no aiming: choosing a subset would
favour some glass over the rest for no reason the host can see.
"""

from __future__ import annotations

import numpy as np

from ..layouts import RENDER_PARAMS, MaterialKind

# The most casters a render aims at: the rows of render_params.casters (mcocl/layouts.py).
MAX_CASTERS = next(count for name, _, count in RENDER_PARAMS.fields if name == "casters")
# The probability that a guided vertex aims at a caster rather than sampling its BSDF (module docstring).
CASTER_SHARE = 0.75
# The materials that cast caustics.
CASTER_KINDS = (int(MaterialKind.DIELECTRIC),)
# A caster is aimed at only if some area light subtends less than this solid angle (sr) from its centre.
SMALL_LIGHT_SR = 0.01
# A bounding sphere's radius is padded by this fraction so that rounding cannot put a surface point outside it.
RADIUS_PAD = 1e-4


def shape_spheres(cs, prims: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(shapes, (len(shapes), 4) float64 centre and radius): the bounding sphere of each shape that the
    primitives ``prims`` belong to, over those primitives (the sphere around their bounding box; a shape of
    one sphere primitive, that sphere)."""
    prims = np.asarray(prims, np.int64)
    if len(prims) == 0:
        return np.zeros(0, np.int64), np.zeros((0, 4))
    nt = cs.num_triangles
    shape_of = np.asarray(cs.prim_shape, np.int64)[prims]
    lo = np.empty((len(prims), 3))
    hi = np.empty((len(prims), 3))
    tri = prims < nt
    if tri.any():
        v = cs.tri_vertices[prims[tri], :, :3].astype(np.float64)
        lo[tri], hi[tri] = v.min(axis=1), v.max(axis=1)
    if (~tri).any():
        sph = cs.spheres[prims[~tri] - nt].astype(np.float64)
        lo[~tri], hi[~tri] = sph[:, :3] - sph[:, 3:4], sph[:, :3] + sph[:, 3:4]
    shapes, first, inverse, counts = np.unique(shape_of, return_index=True, return_inverse=True, return_counts=True)
    slo = np.full((len(shapes), 3), np.inf)
    shi = np.full((len(shapes), 3), -np.inf)
    np.minimum.at(slo, inverse, lo)
    np.maximum.at(shi, inverse, hi)
    out = np.empty((len(shapes), 4))
    out[:, :3] = 0.5 * (slo + shi)
    out[:, 3] = 0.5 * np.linalg.norm(shi - slo, axis=1)
    single = (counts == 1) & ~tri[first]
    if single.any():  # one sphere: its own sphere, not the one around its box
        out[single] = cs.spheres[prims[first[single]] - nt].astype(np.float64)
    return shapes, out


def light_solid_angles(casters: np.ndarray, lights: np.ndarray) -> np.ndarray:
    """(K, L): the solid angle each light's bounding sphere subtends from each caster's centre (4 pi inside it)."""
    d2 = ((casters[:, None, :3] - lights[None, :, :3]) ** 2).sum(axis=-1)
    r2 = lights[None, :, 3] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        s2 = np.where(d2 > r2, r2 / np.where(d2 > 0, d2, 1.0), 1.0)
    return np.where(d2 > r2, 2.0 * np.pi * s2 / (1.0 + np.sqrt(1.0 - s2)), 4.0 * np.pi)


def caster_spheres(cs) -> np.ndarray:
    """(K, 4) float32: centre and radius of the bounding sphere of each caster shape of a compiled scene.

    Casters are the smooth-dielectric shapes from whose centre some area light subtends less than
    :data:`SMALL_LIGHT_SR`; K is 0 when there is none or more than :data:`MAX_CASTERS` (module docstring).
    """
    none = np.zeros((0, 4), np.float32)
    if cs.materials.ndim != 2 or len(cs.shape_material) == 0 or cs.num_lights == 0:
        return none
    kinds = np.asarray(cs.materials[:, 0])
    shape_kind = kinds[np.asarray(cs.shape_material, np.int64)]
    glass = np.isin(shape_kind, CASTER_KINDS)
    if not glass.any():
        return none
    _, casters = shape_spheres(cs, np.flatnonzero(glass[np.asarray(cs.prim_shape, np.int64)]))
    casters = casters[casters[:, 3] > 0]
    _, lights = shape_spheres(cs, cs.light_prims)
    if len(casters) == 0 or len(lights) == 0:
        return none
    casters = casters[light_solid_angles(casters, lights).min(axis=1) < SMALL_LIGHT_SR]
    if len(casters) == 0 or len(casters) > MAX_CASTERS:
        return none
    casters[:, 3] *= 1.0 + RADIUS_PAD
    return casters.astype(np.float32)


__all__ = ["CASTER_KINDS", "CASTER_SHARE", "MAX_CASTERS", "SMALL_LIGHT_SR", "caster_spheres", "light_solid_angles",
           "shape_spheres"]
