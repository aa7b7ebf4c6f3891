/* bsdf_dielectric.cl — a smooth dielectric interface (glass), two-sided by
 * nature, as Mitsuba 3's `dielectric`: reflect with the Fresnel probability
 * R, refract otherwise.  eta = int_ior / ext_ior; the side is given by the
 * sign of cos(theta_i) (negative: the path is inside).
 *
 * Radiance is scaled by (eta_i / eta_t)^2 on refraction: the solid angle is
 * compressed across the interface (Veach's thesis §5.2, eq. 5.12).  Importance
 * (light paths, TRANSPORT_IMPORTANCE of bsdf.cl) is not: the adjoint BSDF of a
 * refraction lacks that factor (Veach's thesis §5.2, eq. 5.14).  The path's
 * `eta` factor tracks it for Russian roulette as Mitsuba does.  The
 * material's colour tints the reflection, its `transmit` the transmission
 * (Mitsuba's specular_reflectance and specular_transmittance); the lobe is
 * chosen by the Fresnel term alone.
 */
#ifndef MCOCL_BSDF_DIELECTRIC_CL
#define MCOCL_BSDF_DIELECTRIC_CL

#include "render/material.cl"

/* Unpolarised Fresnel reflectance of a dielectric interface (pbrt-v4
 * §9.3.6).  Returns R; *cos_t = cosine of the refracted direction (sign
 * opposite to cos_i), *eta_it = eta_t / eta_i along the path, *eta_ti its
 * inverse.  Total internal reflection gives R = 1. */
MC_INLINE floatv fresnel_dielectric(floatv cos_i, floatv eta, floatv *cos_t, floatv *eta_it, floatv *eta_ti) {
    intv outside = cos_i >= 0.0f;
    floatv it = lane_select(1.0f / eta, eta, outside);
    floatv ti = lane_select(eta, 1.0f / eta, outside);
    floatv ci = lane_abs(cos_i);
    floatv ct2 = 1.0f - ti * ti * lane_mad(-ci, ci, 1.0f);
    floatv ct = safe_sqrt(ct2);
    floatv a_s = (it * ct - ci) / (it * ct + ci);
    floatv a_p = (it * ci - ct) / (it * ci + ct);
    floatv r = 0.5f * (a_s * a_s + a_p * a_p);
    r = lane_select(r, (floatv)(1.0f), ct2 <= 0.0f);          /* total internal reflection */
    r = lane_select(r, (floatv)(0.0f), eta == 1.0f);           /* index matched: no interface */
    *cos_t = lane_select(ct, -ct, cos_i >= 0.0f);
    *eta_it = it;
    *eta_ti = ti;
    return r;
}

/* Returns the weight; *pdf is the discrete probability of the chosen lobe,
 * *eta_path the factor eta_t / eta_i of the move (1 on reflection).  u picks
 * the lobe; (u1, u2) are unused (both lobes are deltas).  mat->color and mat->transmit tint them,
 * mat->eta = int_ior / ext_ior.  mode TRANSPORT_IMPORTANCE (light paths) leaves
 * out the radiance scaling (eta_i / eta_t)^2 of refraction (Veach's thesis §5.2). */
MC_INLINE vec3v dielectric_bsdf_sample(const material_v *mat, vec3v wi, floatv u, floatv u1, floatv u2,
                                       vec3v *wo, floatv *pdf, floatv *eta_path, int mode) {
    const int importance = mode == TRANSPORT_IMPORTANCE;
    floatv cos_t, eta_it, eta_ti;
    floatv r = fresnel_dielectric(wi.z, mat->eta, &cos_t, &eta_it, &eta_ti);
    intv refl = u < r;
    vec3v wr = v3(-wi.x, -wi.y, wi.z);
    vec3v wt = v3(-eta_ti * wi.x, -eta_ti * wi.y, cos_t);
    *wo = v3_select(wt, wr, refl);
    *pdf = lane_select(1.0f - r, r, refl);
    *eta_path = lane_select(eta_it, (floatv)(1.0f), refl);
    floatv scale = lane_select(eta_ti * eta_ti, (floatv)(1.0f), refl | (intv)(importance ? -1 : 0));
    return v3_scale(v3_select(mat->transmit, mat->color, refl), scale);
}

#endif
