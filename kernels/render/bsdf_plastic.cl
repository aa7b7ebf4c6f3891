/* bsdf_plastic.cl — a smooth dielectric coating over a Lambertian base, as
 * Mitsuba 3's `plastic` (linear variant, specular reflectance 1): one-sided
 * unless the material is twosided (render/bsdf.cl mirrors it).
 *
 * eta = int_ior / ext_ior, F(c) the Fresnel reflectance of the coating
 * (fresnel_dielectric, render/bsdf_dielectric.cl), rho the base albedo
 * (mat->color), Fdr_int the diffuse reflectance of the coating seen from
 * inside (light bouncing between base and coating):
 *
 *   specular lobe: a mirror reflection of weight F(cos theta_i)          (a Dirac delta)
 *   diffuse lobe:  f cos = rho / (1 - Fdr_int) (1 - F(cos theta_i)) (1 - F(cos theta_o)) cos theta_o / (pi eta^2)
 *
 * (Weidlich & Wilkie 2007, "Arbitrarily layered micro-facet surfaces", with
 * the internal reflections summed as a geometric series; the linear
 * 1 / (1 - Fdr_int) form is Mitsuba's `nonlinear = false`.)  With Fdr_int
 * exact and a white base the two lobes sum to 1: the hemispherical mean of
 * 1 - F seen from outside is eta^2 (1 - Fdr_int).
 *
 * The specular lobe is sampled with probability proportional to
 * F(cos theta_i) s, the diffuse one to (1 - F(cos theta_i)) (1 - s), where
 * s = 1 / (1 + mean(rho)) is the specular share of the reflectances (Mitsuba's
 * specular sampling weight); the diffuse direction is cosine-distributed.
 * eval reports the diffuse lobe only (the delta has no density), with the
 * pdf of sampling it (lobe probability times the cosine density).
 */
#ifndef MCOCL_BSDF_PLASTIC_CL
#define MCOCL_BSDF_PLASTIC_CL

#include "render/material.cl"
#include "render/bsdf_diffuse.cl"
#include "render/bsdf_dielectric.cl"

/* Hemispherical average of the Fresnel reflectance seen from inside a medium
 * of relative index eta = n_inside / n_outside, i.e. 2 int_0^1 F(c) c dc for
 * light leaving the medium: the polynomial fits of Egan & Hilgeman (1979) as
 * d'Eon & Irving (2011, "A quantized-diffusion model for rendering
 * translucent materials", §5.1) give them (also Mitsuba's
 * fresnel_diffuse_reflectance(1 / eta)).  tests/test_render_bsdf_plastic.py
 * checks them against a quadrature of the Fresnel formula. */
MC_INLINE floatv fresnel_diffuse_internal(floatv eta) {
    floatv e2 = eta * eta, e3 = e2 * eta, e4 = e3 * eta, e5 = e4 * eta;
    floatv dense = -9.23372f + 22.2272f * eta - 20.9292f * e2 + 10.2291f * e3 - 2.54396f * e4 + 0.254913f * e5;
    floatv thin = 0.919317f - 3.4793f * eta + 6.75335f * e2 - 7.80989f * e3 + 4.98554f * e4 - 1.36881f * e5;
    return lane_select(thin, dense, eta >= 1.0f);
}

/* The probability of sampling the specular lobe at incidence with Fresnel reflectance f_i. */
MC_INLINE floatv plastic_specular_probability(const material_v *mat, floatv f_i) {
    floatv d_mean = (mat->color.x + mat->color.y + mat->color.z) * (1.0f / 3.0f);
    floatv s = 1.0f / (1.0f + d_mean);
    floatv ps = f_i * s;
    floatv pd = (1.0f - f_i) * (1.0f - s);
    return lane_select(ps / (ps + pd), (floatv)(1.0f), ps + pd <= 0.0f);
}

/* f cos / (cos theta_o / pi) of the diffuse lobe: rho (1 - F_i)(1 - F_o) / ((1 - Fdr_int) eta^2). */
MC_INLINE vec3v plastic_diffuse_scale(const material_v *mat, floatv f_i, floatv f_o) {
    floatv eta = mat->eta;
    floatv k = (1.0f - f_i) * (1.0f - f_o) / ((1.0f - fresnel_diffuse_internal(eta)) * eta * eta);
    return v3_scale(mat->color, k);
}

/* The diffuse lobe (the specular one is a delta): f cos and the pdf of sampling wo. */
MC_INLINE vec3v plastic_bsdf_eval(const material_v *mat, vec3v wi, vec3v wo, floatv *pdf) {
    intv ok = (wi.z > 0.0f) & (wo.z > 0.0f);
    floatv ct, it, ti;
    floatv f_i = fresnel_dielectric(lane_abs(wi.z), mat->eta, &ct, &it, &ti);
    floatv f_o = fresnel_dielectric(lane_abs(wo.z), mat->eta, &ct, &it, &ti);
    floatv cos_pdf = lane_select((floatv)(0.0f), wo.z * RT_INV_PI, ok);
    *pdf = (1.0f - plastic_specular_probability(mat, f_i)) * cos_pdf;
    return v3_scale(plastic_diffuse_scale(mat, f_i, f_o), cos_pdf);
}

/* u_lobe < P(specular) picks the mirror reflection (*delta set), otherwise a
 * cosine-distributed diffuse direction from (u1, u2).  The BSDF is symmetric
 * (eta enters squared, not as refraction), so mode does not matter; eta 1. */
MC_INLINE vec3v plastic_bsdf_sample(const material_v *mat, vec3v wi, floatv u_lobe, floatv u1, floatv u2,
                                    vec3v *wo, floatv *pdf, floatv *eta, int mode, intv *delta) {
    intv front = wi.z > 0.0f;
    floatv ct, it, ti;
    floatv f_i = fresnel_dielectric(lane_abs(wi.z), mat->eta, &ct, &it, &ti);
    floatv p_spec = plastic_specular_probability(mat, f_i);
    intv spec = u_lobe < p_spec;
    floatv cpdf;
    vec3v wd = square_to_cosine_hemisphere(u1, u2, &cpdf);
    floatv f_o = fresnel_dielectric(wd.z, mat->eta, &ct, &it, &ti);
    vec3v w_diff = v3_scale(plastic_diffuse_scale(mat, f_i, f_o), 1.0f / (1.0f - p_spec));
    vec3v w_spec = v3s(f_i / p_spec);
    *wo = v3_select(wd, v3(-wi.x, -wi.y, wi.z), spec);
    *pdf = lane_select((floatv)(0.0f), lane_select((1.0f - p_spec) * cpdf, p_spec, spec), front);
    *eta = (floatv)(1.0f);
    *delta = spec;
    return v3_select(v3s(0.0f), v3_select(w_diff, w_spec, spec), front);
}

#endif
