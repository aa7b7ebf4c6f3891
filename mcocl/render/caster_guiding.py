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
bounding sphere subtends from the point (one of the casters that take part
there, below, chosen uniformly), else the BSDF's own sample.  The path's weight is f cos
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
aiming made mis about 2x as efficient: README, *Caustics*).  Point and
spot lights do not count (no path hits them, aimed or not).

And only on the caustic's side: a vertex aims at a caster only where it lies
within :data:`CASTER_CONE_DEG` of the axis from the small light through the
caster's centre, seen from that centre.  A ball of glass (n = 1.5) deviates
light that crosses it by 2 (i - asin(sin i / n)) at incidence i, so about 85 %
of what it transmits leaves within 60 degrees of that axis; elsewhere (beside
the glass, on the lamp's side) its caustic is faint or absent, and aiming
there only costs.  Without the rule a Cornell box lit by a small lamp, with a
glass ball on its floor, was 4.5-5x noisier at share 0.75 than without aiming
(indirect light dominates there, and every floor point gave three quarters of
its continuations to the ball); with it, 1.02x.  And only within
:data:`CASTER_REACH` radii of the caster's centre: a ball lens focuses at
1.5 radii (n = 1.5) and beyond twice that its caustic is wider than the ball,
soft, while the cone it subtends shrinks below 0.2 sr; a glass ball of radius
0.08 on a table in that box made the floor under the table 1.25x noisier
without this bound and no noisier with it.  A caster inside a small
light's bounding sphere has no axis: every point outside it aims.  Each
(caster, small light) pair is one row of ``render_params``; a scene with more
than :data:`MAX_CASTERS` rows gets no aiming: choosing a subset would favour
some glass over the rest for no reason the host can see.
"""

from __future__ import annotations

import numpy as np

from ..layouts import RENDER_PARAMS, MaterialKind

# The most (caster, small light) rows a render aims with: the rows of render_params.casters (mcocl/layouts.py).
MAX_CASTERS = next(count for name, _, count in RENDER_PARAMS.fields if name == "casters")
# The probability that a guided vertex aims at a caster rather than sampling its BSDF (module docstring).
CASTER_SHARE = 0.75
# The materials that cast caustics.
CASTER_KINDS = (int(MaterialKind.DIELECTRIC),)
# A caster is aimed at only if some area light subtends less than this solid angle (sr) from its centre.
SMALL_LIGHT_SR = 0.01
# The half-angle (degrees) around the axis from a small light through a caster within which a point aims at it.
CASTER_CONE_DEG = 60.0
# How far from a caster's centre, in radii of its bounding sphere, a point still aims at it (module docstring).
CASTER_REACH = 4.0
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


def caster_rows(cs) -> np.ndarray:
    """(K, 8) float32, one row per caster and small light: the caster's bounding sphere (centre, radius),
    then the unit axis from the light's centre through the caster's and the cosine of
    :data:`CASTER_CONE_DEG` (-1, every direction, where the caster lies inside the light's bounding sphere).

    Casters are the smooth-dielectric shapes; a light is small for a caster when it subtends less than
    :data:`SMALL_LIGHT_SR` from the caster's centre.  K is 0 when there is no such pair or more than
    :data:`MAX_CASTERS` (module docstring).
    """
    none = np.zeros((0, 8), np.float32)
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
    k, j = np.nonzero(light_solid_angles(casters, lights) < SMALL_LIGHT_SR)
    if len(k) == 0 or len(k) > MAX_CASTERS:
        return none
    rows = np.empty((len(k), 8))
    rows[:, :4] = casters[k]
    rows[:, 3] *= 1.0 + RADIUS_PAD
    axis = casters[k, :3] - lights[j, :3]
    dist = np.linalg.norm(axis, axis=1)
    inside = dist <= lights[j, 3]
    rows[:, 4:7] = np.where(inside[:, None], [0.0, 0.0, 1.0], axis / np.where(inside, 1.0, dist)[:, None])
    rows[:, 7] = np.where(inside, -1.0, np.cos(np.radians(CASTER_CONE_DEG)))
    return rows.astype(np.float32)


__all__ = ["CASTER_CONE_DEG", "CASTER_KINDS", "CASTER_REACH", "CASTER_SHARE", "MAX_CASTERS", "SMALL_LIGHT_SR", "caster_rows",
           "light_solid_angles", "shape_spheres"]
