/* caster_guiding.cl — the cone sampling towards caustic casters that nee and mis
 * mix into the continuation of a non-delta vertex (-DCASTER_GUIDING; host and the
 * estimator: mcocl/render/caster_guiding.py).
 *
 * The casters are the bounding spheres in render_params.casters (centre xyz,
 * radius), each with the side its caustic falls on in caster_axes (the axis
 * from a small light through it, the cosine of the half-angle around it).
 * From a point p only the casters p lies outside, on that side, and within
 * render_params.caster_reach radii of the centre take part: the
 * technique picks one of those n uniformly and a direction uniform in the cone
 * it subtends (pbrt-v4 §6.2.4; the cone of render/lights.cl's sphere_cone), so
 * its density is (1/n) sum over those casters of [w in cone_k] / (2 pi (1 - cos
 * theta_max,k)).  Sampling and density read the same caster_view of the point,
 * so a direction has a density exactly where it can be drawn.
 */
#ifndef MCOCL_CASTER_GUIDING_CL
#define MCOCL_CASTER_GUIDING_CL

#include "render/lights.cl"

/* The scene's number of casters, the rows of render_params.casters in use: a build constant (the host's
 * -DCASTER_GUIDING=K), so that the loops below unroll and the per-caster values stay in registers (with a
 * launch-time count they went through the stack, and a caustic.json render took twice as long). */
#define CASTER_ROWS CASTER_GUIDING

/* The casters as seen from one point, computed once per vertex: for every row, whether p lies outside
 * its bounding sphere (and the cone is not empty), the cone's axis, 1 - cos(theta_max) and the uniform
 * density in it; n: how many casters take part. */
typedef struct {
    vec3v axis[CASTER_ROWS];
    floatv omc[CASTER_ROWS];
    floatv density[CASTER_ROWS];
    intv out[CASTER_ROWS];
    uintv n;
} caster_view;

MC_INLINE caster_view caster_view_at(const render_params *prm, vec3v p) {
    caster_view v;
    v.n = (uintv)(0u);
    _Pragma("unroll") for (uint k = 0; k < CASTER_ROWS; ++k) {
        const float4 c = prm->casters[k];
        floatv s2max, dc;
        intv out = sphere_cone(p, v3((floatv)(c.x), (floatv)(c.y), (floatv)(c.z)), (floatv)(c.w), (intv)(0),
                               &v.omc[k], &s2max, &v.axis[k], &dc);
        out = out & (v.omc[k] > 0.0f); /* a caster so far away that its cone is empty in float takes no part */
        /* and only on its caustic's side: p within the row's half-angle of the axis from the small light
         * through the caster, seen from the caster's centre (-wc is the unit direction from it to p) */
        const float4 a = prm->caster_axes[k];
        out = out & (-v3_dot(v.axis[k], v3((floatv)(a.x), (floatv)(a.y), (floatv)(a.z))) >= a.w);
        /* and within its reach: farther away its caustic has spread out, and the cone is small */
        out = out & (dc <= prm->caster_reach * c.w);
        v.out[k] = out;
        v.density[k] = RT_INV_2PI / lane_select((floatv)(1.0f), v.omc[k], out);
        v.n = v.n + lane_select((uintv)(0u), (uintv)(1u), out);
    }
    return v;
}

/* The technique's solid-angle density of the unit direction w (0 where no caster takes part). */
MC_INLINE floatv caster_pdf(const caster_view *v, vec3v w) {
    floatv sum = (floatv)(0.0f);
    _Pragma("unroll") for (uint k = 0; k < CASTER_ROWS; ++k) {
        intv inside = v->out[k] & (v3_dot(w, v->axis[k]) >= 1.0f - v->omc[k]);
        sum = sum + lane_select((floatv)(0.0f), v->density[k], inside);
    }
    return lane_select((floatv)(0.0f), sum / to_floatv(max(v->n, (uintv)(1u))), v->n > (uintv)(0u));
}

/* A direction uniform in the cone of the pick-th caster that takes part (pick < v->n). */
MC_INLINE vec3v caster_sample(const caster_view *v, uintv pick, floatv u1, floatv u2) {
    vec3v axis = v3(0.0f, 0.0f, 1.0f);
    floatv omc = (floatv)(0.0f);
    uintv seen = (uintv)(0u);
    _Pragma("unroll") for (uint k = 0; k < CASTER_ROWS; ++k) {
        intv take = v->out[k] & (seen == pick);
        axis = v3_select(axis, v->axis[k], take);
        omc = lane_select(omc, v->omc[k], take);
        seen = seen + lane_select((uintv)(0u), (uintv)(1u), v->out[k]);
    }
    /* cos(theta) uniform in [cos theta_max, 1], written through 1 - cos to keep small cones exact */
    floatv t = u1 * omc;
    floatv ct = 1.0f - t;
    floatv st = safe_sqrt(t * (2.0f - t));
    floatv cph;
    floatv sph = lane_sincos_2pi(u2, &cph);
    return frame_to_world(frame_from_normal(axis), v3(st * cph, st * sph, ct));
}

#endif
