/* bsdf_thindielectric.cl — a thin dielectric sheet (a window pane), as
 * Mitsuba 3's `thindielectric`: two parallel interfaces so close that the
 * light leaving the sheet does so where it entered, undeflected.
 *
 * With R = F(|cos theta_i|) the Fresnel reflectance of one interface
 * (fresnel_dielectric, render/bsdf_dielectric.cl) and T = 1 - R, the light
 * bouncing between the two interfaces sums to a geometric series:
 *
 *   R' = R + T^2 R / (1 - R^2)      (reflected: first bounce + every odd inner bounce)
 *   T' = 1 - R' = T^2 / (1 - R^2)   (transmitted straight through: wo = -wi)
 *
 * (Mitsuba 3's thindielectric, after its documentation; absorption inside the
 * sheet is not modelled.)  Both lobes are Dirac deltas: reflection is chosen
 * with probability R', so each sample's weight is its lobe's tint
 * (Mitsuba's specular_reflectance, specular_transmittance).  Two-sided by
 * nature and symmetric: no radiance scaling (no change of medium along the
 * path), eta 1 in both transport modes.
 */
#ifndef MCOCL_BSDF_THINDIELECTRIC_CL
#define MCOCL_BSDF_THINDIELECTRIC_CL

#include "render/material.cl"
#include "render/bsdf_dielectric.cl"

/* R' of the sheet at incidence cosine |cos_i| (the two interfaces summed). */
MC_INLINE floatv thindielectric_reflectance(floatv cos_i, floatv eta) {
    floatv ct, it, ti;
    floatv r = fresnel_dielectric(lane_abs(cos_i), eta, &ct, &it, &ti);
    floatv t = 1.0f - r;
    return lane_select(r, r + t * t * r / (1.0f - r * r), r < 1.0f);
}

/* u picks the lobe; (u1, u2) unused.  mat->color tints the reflection, mat->transmit the transmission;
 * mat->eta = int_ior / ext_ior. */
MC_INLINE vec3v thindielectric_bsdf_sample(const material_v *mat, vec3v wi, floatv u, floatv u1, floatv u2,
                                           vec3v *wo, floatv *pdf, floatv *eta, int mode) {
    floatv r = thindielectric_reflectance(wi.z, mat->eta);
    intv refl = u < r;
    *wo = v3_select(v3_neg(wi), v3(-wi.x, -wi.y, wi.z), refl);
    *pdf = lane_select(1.0f - r, r, refl);
    *eta = (floatv)(1.0f);
    return v3_select(v3s(0.0f), v3_select(mat->transmit, mat->color, refl), wi.z != 0.0f);
}

#endif
