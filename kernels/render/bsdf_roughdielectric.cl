/* bsdf_roughdielectric.cl — a rough dielectric interface (frosted glass),
 * Walter, Marschner, Li & Torrance 2007, "Microfacet models for refraction
 * through rough surfaces", as Mitsuba 3's `roughdielectric`: GGX or (lanes
 * with MAT_FLAG_BECKMANN) Beckmann microfacets of roughness alpha, the
 * functions D, G1 and the normal sampling of render/bsdf_roughconductor.cl
 * (anisotropic lanes, MAT_FLAG_ANISOTROPIC: render/microfacet_aniso.cl).
 * Two-sided by nature: cos theta_i < 0 means the path is inside
 * (eta = int_ior / ext_ior is behind the front side).
 *
 * With eta_p = eta_t / eta_i along the path (eta outside, 1 / eta inside),
 * F the Fresnel reflectance at the microfacet (fresnel_dielectric), h the
 * half vector (Walter eqs. 13 and 16, turned to the upper side), and
 * G = G1(i) G1(o) (separable Smith, Walter eq. 23):
 *
 *   reflection (o on i's side):   f cos o = F D(h) G / (4 |cos i|)                                (Walter eq. 20)
 *   refraction:                   f cos o = (1 - F) D(h) G |i.h| |o.h| eta_p^2
 *                                           / (|cos i| (i.h + eta_p o.h)^2) * s                   (Walter eq. 21)
 *
 * each times its lobe's tint, mat->color or mat->transmit (Mitsuba's specular_reflectance and
 * specular_transmittance; the sampling ignores them).
 * s = 1 / eta_p^2 for radiance (TRANSPORT_RADIANCE: the solid-angle
 * compression of Veach's thesis §5.2, eq. 5.12), 1 for importance (the
 * adjoint BSDF, eq. 5.14), as the smooth dielectric (bsdf_dielectric.cl); so
 * unlike the other BSDFs eval takes the transport mode.
 *
 * Sampling draws a microfacet normal m for the view direction turned to the
 * upper side (GGX: visible normals, Heitz 2018; Beckmann: D(m) cos theta_m,
 * Walter eqs. 28-29), then reflects with probability F(i.m), else refracts:
 *
 *   pdf(o) = pdf_m(m) F / (4 |o.m|)                                   (reflection, Walter eq. 14)
 *   pdf(o) = pdf_m(m) (1 - F) eta_p^2 |o.m| / (i.m + eta_p o.m)^2     (refraction, Walter eq. 17)
 *   weight = D G |i.m| / (|cos i| pdf_m(m))  (times s on refraction)
 *
 * Energy: single scattering only; light that would reflect off a second
 * microfacet is lost (shadowing-masking G), so the white-furnace albedo is
 * below 1 by an amount that grows with alpha and grazing incidence
 * (tests/test_render_bsdf_roughdielectric.py).
 */
#ifndef MCOCL_BSDF_ROUGHDIELECTRIC_CL
#define MCOCL_BSDF_ROUGHDIELECTRIC_CL

#include "render/material.cl"
#include "render/bsdf_dielectric.cl"
#include "render/bsdf_roughconductor.cl"

/* The density of the sampled microfacet normal m for wu = wi turned to the upper side;
 * av, aniso: the second roughness of the anisotropic lanes (render/microfacet_aniso.cl). */
MC_INLINE floatv roughdielectric_normal_pdf(vec3v wu, vec3v m, floatv alpha, floatv av, intv beck, intv aniso) {
    floatv a2 = alpha * alpha;
    floatv pg = ggx_g1(wu, m, a2) * lane_max(v3_dot(wu, m), 0.0f) * ggx_d(m, a2) / wu.z;
    floatv pb = beckmann_d(m, a2) * m.z;
    floatv p = lane_select(pg, pb, beck);
    if (lane_any(aniso)) p = lane_select(p, aniso_normal_pdf(wu, m, alpha, av, beck), aniso);
    return p;
}

/* D(m) G1(i) G1(o) of the lanes' distribution. */
MC_INLINE floatv roughdielectric_dg(vec3v wi, vec3v wo, vec3v m, floatv alpha, floatv av, intv beck, intv aniso) {
    floatv a2 = alpha * alpha;
    floatv dg = ggx_d(m, a2) * ggx_g1(wi, m, a2) * ggx_g1(wo, m, a2);
    if (lane_any(beck)) {
        floatv db = beckmann_d(m, a2) * beckmann_g1(wi, m, alpha) * beckmann_g1(wo, m, alpha);
        dg = lane_select(dg, db, beck);
    }
    if (lane_any(aniso)) {
        floatv da = aniso_d(m, alpha, av, beck) * aniso_g1(wi, m, alpha, av, beck) * aniso_g1(wo, m, alpha, av, beck);
        dg = lane_select(dg, da, aniso);
    }
    return dg;
}

/* f cos(theta_o) and the pdf of sampling wo; mode as the sample function's. */
MC_INLINE vec3v roughdielectric_bsdf_eval(const material_v *mat, vec3v wi, vec3v wo, floatv *pdf, int mode) {
    floatv alpha = lane_max(mat->alpha, GGX_MIN_ALPHA);
    intv beck = (mat->flags & MAT_FLAG_BECKMANN) != 0;
    intv aniso = (mat->flags & MAT_FLAG_ANISOTROPIC) != 0;
    floatv av = alpha;
    if (lane_any(aniso)) av = lane_select(av, lane_max(material_alpha_second(mat), GGX_MIN_ALPHA), aniso);
    floatv ci = wi.z, co = wo.z;
    intv refl = ci * co > 0.0f;
    floatv eta_p = lane_select(1.0f / mat->eta, mat->eta, ci > 0.0f);
    floatv k = lane_select(eta_p, (floatv)(1.0f), refl);
    vec3v h = v3_normalize(v3_add(wi, v3_scale(wo, k)));        /* Walter eqs. 13 and 16 */
    h = v3_scale(h, lane_copysign((floatv)(1.0f), h.z));
    floatv dih = v3_dot(wi, h), doh = v3_dot(wo, h);
    /* each direction on the side of h its hemisphere asks for (Walter eq. 23's chi+) */
    intv ok = (ci != 0.0f) & (co != 0.0f) & (dih * ci > 0.0f) & (doh * co > 0.0f);
    floatv ct, it, ti;
    floatv f = fresnel_dielectric(dih, mat->eta, &ct, &it, &ti);
    floatv dg = roughdielectric_dg(wi, wo, h, alpha, av, beck, aniso);
    vec3v wu = v3_scale(wi, lane_copysign((floatv)(1.0f), ci));
    floatv pm = roughdielectric_normal_pdf(wu, h, alpha, av, beck, aniso);
    floatv aci = lane_abs(ci);
    floatv den = dih + eta_p * doh;
    floatv jac_t = eta_p * eta_p * lane_abs(doh) / (den * den);  /* |dh / do| of refraction, Walter eq. 17 */
    floatv s = (floatv)(1.0f);
    if (mode == TRANSPORT_RADIANCE) s = 1.0f / (eta_p * eta_p);
    floatv fr = f * dg / (4.0f * aci);
    floatv ft = (1.0f - f) * dg * lane_abs(dih) * jac_t / aci * s;
    floatv pr = f * pm / (4.0f * lane_abs(doh));
    floatv pt = (1.0f - f) * pm * jac_t;
    *pdf = lane_select((floatv)(0.0f), lane_select(pt, pr, refl), ok);
    return v3_scale(v3_select(mat->transmit, mat->color, refl), lane_select((floatv)(0.0f), lane_select(ft, fr, refl), ok));
}

/* u_lobe picks reflection or refraction, (u1, u2) the microfacet normal;
 * *eta the path's eta_t / eta_i (1 on reflection). */
MC_INLINE vec3v roughdielectric_bsdf_sample(const material_v *mat, vec3v wi, floatv u_lobe, floatv u1, floatv u2,
                                            vec3v *wo, floatv *pdf, floatv *eta, int mode) {
    floatv alpha = lane_max(mat->alpha, GGX_MIN_ALPHA);
    intv beck = (mat->flags & MAT_FLAG_BECKMANN) != 0;
    intv aniso = (mat->flags & MAT_FLAG_ANISOTROPIC) != 0;
    floatv av = alpha;
    if (lane_any(aniso)) av = lane_select(av, lane_max(material_alpha_second(mat), GGX_MIN_ALPHA), aniso);
    floatv ci = wi.z;
    floatv sgn = lane_copysign((floatv)(1.0f), ci);
    vec3v wu = v3_scale(wi, sgn);
    /* a microfacet normal for the upper-side view: GGX visible normals, Beckmann D cos */
    intv up = wu.z > 0.0f;
    vec3v wuv = v3_select(v3(0.0f, 0.0f, 1.0f), wu, up);
    vec3v m = ggx_sample_visible_normal(wuv, alpha, u1, u2);
    if (lane_any(beck)) {
        floatv t2 = -(alpha * alpha) * log(1.0f - u1);  /* u1 < 1 on the sample grid */
        floatv cm = 1.0f / lane_sqrt(1.0f + t2);
        floatv sm = lane_sqrt(t2) * cm;
        floatv c;
        floatv sn = lane_sincos_2pi(u2, &c);
        m = v3_select(m, v3(sm * c, sm * sn, cm), beck);
    }
    if (lane_any(aniso)) m = v3_select(m, aniso_sample_normal(wuv, alpha, av, u1, u2, beck), aniso);
    floatv pm = roughdielectric_normal_pdf(wuv, m, alpha, av, beck, aniso);
    floatv dim = v3_dot(wi, m);
    floatv cos_t, eta_it, eta_ti;
    floatv f = fresnel_dielectric(dim, mat->eta, &cos_t, &eta_it, &eta_ti);
    intv refl = u_lobe < f;
    vec3v wr = v3_sub(v3_scale(m, 2.0f * dim), wi);
    vec3v wt = v3_sub(v3_scale(m, dim * eta_ti + cos_t), v3_scale(wi, eta_ti));  /* Snell at m (pbrt-v4 §9.3.2) */
    vec3v o = v3_select(wt, wr, refl);
    *wo = o;
    floatv doh = v3_dot(o, m);
    intv ok = up & (pm > 0.0f) & (dim * ci > 0.0f) & (doh * o.z > 0.0f) &
              lane_select(o.z * ci < 0.0f, o.z * ci > 0.0f, refl);
    floatv dg = roughdielectric_dg(wi, o, m, alpha, av, beck, aniso);
    floatv w = dg * lane_abs(dim) / (lane_abs(ci) * pm);
    floatv den = dim + eta_it * doh;
    floatv pr = f * pm / (4.0f * lane_abs(doh));
    floatv pt = (1.0f - f) * pm * eta_it * eta_it * lane_abs(doh) / (den * den);
    floatv s = (floatv)(1.0f);
    if (mode == TRANSPORT_RADIANCE) s = eta_ti * eta_ti;
    w = lane_select(w * s, w, refl);
    *pdf = lane_select((floatv)(0.0f), lane_select(pt, pr, refl), ok);
    *eta = lane_select(eta_it, (floatv)(1.0f), refl);
    return v3_scale(v3_select(mat->transmit, mat->color, refl), lane_select((floatv)(0.0f), w, ok));
}

#endif
