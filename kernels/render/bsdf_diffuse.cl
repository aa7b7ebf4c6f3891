/* bsdf_diffuse.cl — the Lambertian BSDF, one-sided as in Mitsuba 3's
 * `diffuse`: f = albedo / pi on the front hemisphere, black from behind.
 *
 * Every BSDF in this renderer works in the local shading frame (z = the
 * front normal), returns f * cos(theta_o) from `eval` (the quantity the
 * rendering equation integrates against solid angle) and the weight
 * f * cos(theta_o) / pdf from `sample`.
 */
#ifndef MCOCL_BSDF_DIFFUSE_CL
#define MCOCL_BSDF_DIFFUSE_CL

#include "render/material.cl"

/* Cosine-weighted hemisphere, p(w) = cos(theta) / pi (pbrt-v4 §A.5.3): a
 * uniform point of the unit disk (polar map, r = lane_sqrt(u1)) lifted to the
 * hemisphere.  cos(theta) = lane_sqrt(1 - u1) > 0 because u1 < 1. */
MC_INLINE vec3v square_to_cosine_hemisphere(floatv u1, floatv u2, floatv *pdf) {
    floatv r = lane_sqrt(u1);
    floatv c;
    floatv s = lane_sincos_2pi(u2, &c);
    floatv z = lane_sqrt(1.0f - u1);
    *pdf = z * RT_INV_PI;
    return v3(r * c, r * s, z);
}

/* f cos = albedo cos(theta_o) / pi on the front side; mat->color is the albedo. */
MC_INLINE vec3v diffuse_bsdf_eval(const material_v *mat, vec3v wi, vec3v wo, floatv *pdf) {
    intv ok = (wi.z > 0.0f) & (wo.z > 0.0f);
    floatv c = lane_select((floatv)(0.0f), wo.z * RT_INV_PI, ok);
    *pdf = c;
    return v3_scale(mat->color, c);
}

/* Weight f cos / pdf = albedo on the front side, 0 from behind (u_lobe unused; eta 1). */
MC_INLINE vec3v diffuse_bsdf_sample(const material_v *mat, vec3v wi, floatv u_lobe, floatv u1, floatv u2,
                                    vec3v *wo, floatv *pdf, floatv *eta, int mode) {
    *wo = square_to_cosine_hemisphere(u1, u2, pdf);
    intv ok = wi.z > 0.0f;
    *pdf = lane_select((floatv)(0.0f), *pdf, ok);
    *eta = (floatv)(1.0f);
    return v3_select(v3s(0.0f), mat->color, ok);
}

#endif
