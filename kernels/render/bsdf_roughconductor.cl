/* bsdf_roughconductor.cl — a rough metal: the GGX microfacet distribution
 * (Walter et al. 2007) with a constant Fresnel factor F (the material's
 * specular reflectance), one-sided, isotropic roughness alpha; or, for the
 * lanes whose material has MAT_FLAG_BECKMANN, the Beckmann distribution
 * (below the GGX functions).  Lanes with MAT_FLAG_ANISOTROPIC use the
 * anisotropic distributions of render/microfacet_aniso.cl (alpha along the
 * first tangent, alpha_second along the second); lanes with MAT_FLAG_COMPLEX_IOR
 * multiply F by the conductor Fresnel term at i.m (render/fresnel_conductor.cl).
 *
 *   D(m)      = 1 / (pi a^2 (((m_x^2 + m_y^2) / a^2 + m_z^2)^2))          (Walter eq. 33)
 *   G1(v)     = 2 / (1 + lane_sqrt(1 + a^2 tan^2 theta_v))                       (Walter eq. 34)
 *   f cos o   = F D(h) G1(i) G1(o) / (4 cos theta_i)                        (separable Smith G, as Mitsuba 3)
 *
 * Directions are sampled from the distribution of *visible* normals,
 * D_i(m) = G1(i) max(0, i.m) D(m) / cos theta_i (Heitz, "Sampling the GGX
 * Distribution of Visible Normals", JCGT 2018), reflected about m; the
 * Jacobian of the reflection, 1 / (4 |o.m|), gives
 *   pdf(o)    = G1(i) D(h) / (4 cos theta_i),     weight = F G1(o).
 */
#ifndef MCOCL_BSDF_ROUGHCONDUCTOR_CL
#define MCOCL_BSDF_ROUGHCONDUCTOR_CL

#include "render/material.cl"
#include "render/microfacet_aniso.cl"
#include "render/fresnel_conductor.cl"

/* Roughness below this is clamped: D would overflow float. */
#define GGX_MIN_ALPHA 1e-4f

MC_INLINE floatv ggx_d(vec3v m, floatv a2) {
    floatv t = (m.x * m.x + m.y * m.y) / a2 + m.z * m.z;
    return lane_select((floatv)(0.0f), 1.0f / (RT_PI * a2 * t * t), m.z > 0.0f);
}

/* Smith's masking for GGX; zero on the wrong side of the microfacet. */
MC_INLINE floatv ggx_g1(vec3v v, vec3v m, floatv a2) {
    floatv tan2 = (v.x * v.x + v.y * v.y) / (v.z * v.z);
    floatv g = 2.0f / (1.0f + lane_sqrt(1.0f + a2 * tan2));
    return lane_select((floatv)(0.0f), g, (v3_dot(v, m) * v.z) > 0.0f);
}

/* Heitz 2018, listing 1: a visible normal for view direction wi (wi.z > 0) (render/microfacet_aniso.cl). */
MC_INLINE vec3v ggx_sample_visible_normal(vec3v wi, floatv alpha, floatv u1, floatv u2) {
    return ggx_sample_visible_normal_aniso(wi, alpha, alpha, u1, u2);
}

/* ---- Beckmann (Walter et al. 2007, §5.1) ----
 *
 *   D(m)    = exp(-tan^2 theta_m / a^2) / (pi a^2 cos^4 theta_m)               (Walter eq. 25)
 *   G1(v)   = (3.535 b + 2.181 b^2) / (1 + 2.276 b + 2.577 b^2) for b < 1.6, else 1,
 *             b = 1 / (a tan theta_v)                                       (Walter eq. 27, Smith)
 *
 * Normals are sampled from D(m) cos theta_m (Walter eqs. 28-29:
 * tan^2 theta_m = -a^2 log(1 - u1), phi_m = 2 pi u2) and reflected, so
 *   pdf(o) = D(h) cos theta_h / (4 |o.h|),   weight = F G1(i) G1(o) |i.m| / (cos theta_i cos theta_m).
 */
MC_INLINE floatv beckmann_d(vec3v m, floatv a2) {
    floatv c2 = m.z * m.z;
    floatv t2 = (m.x * m.x + m.y * m.y) / c2;
    return lane_select((floatv)(0.0f), exp(-t2 / a2) / (RT_PI * a2 * c2 * c2), m.z > 0.0f);
}

/* Smith's masking for Beckmann (Walter's rational fit); zero on the wrong side of the microfacet. */
MC_INLINE floatv beckmann_g1(vec3v v, vec3v m, floatv alpha) {
    floatv b = lane_abs(v.z) / (alpha * lane_sqrt(v.x * v.x + v.y * v.y));  /* 1 / (a tan theta); inf at normal incidence */
    floatv g = (3.535f * b + 2.181f * b * b) / (1.0f + 2.276f * b + 2.577f * b * b);
    g = lane_select(g, (floatv)(1.0f), b >= 1.6f);
    return lane_select((floatv)(0.0f), g, (v3_dot(v, m) * v.z) > 0.0f);
}

/* Beckmann lanes of eval: f cos / F and the pdf, for the half vector m of (wi, wo) (both above). */
MC_INLINE floatv beckmann_eval(vec3v wi, vec3v wo, vec3v m, floatv alpha, floatv *pdf) {
    floatv d = beckmann_d(m, alpha * alpha);
    *pdf = d * m.z / (4.0f * lane_abs(v3_dot(wo, m)));
    return d * beckmann_g1(wi, m, alpha) * beckmann_g1(wo, m, alpha) / (4.0f * wi.z);
}

/* Beckmann lanes of sample: wo reflected about a normal drawn from D(m) cos theta_m; returns weight / F. */
MC_INLINE floatv beckmann_sample(vec3v wi, floatv alpha, floatv u1, floatv u2, vec3v *wo, floatv *pdf, intv *ok) {
    floatv t2 = -(alpha * alpha) * log(1.0f - u1);  /* u1 < 1 on the sample grid */
    floatv cm = 1.0f / lane_sqrt(1.0f + t2);
    floatv sm = lane_sqrt(t2) * cm;
    floatv c;
    floatv s = lane_sincos_2pi(u2, &c);
    vec3v m = v3(sm * c, sm * s, cm);
    floatv dm = v3_dot(wi, m);
    vec3v o = v3_sub(v3_scale(m, 2.0f * dm), wi);
    *wo = o;
    *ok = (dm > 0.0f) & (o.z > 0.0f);
    *pdf = beckmann_d(m, alpha * alpha) * cm / (4.0f * dm);
    return beckmann_g1(wi, m, alpha) * beckmann_g1(o, m, alpha) * dm / (wi.z * cm);
}

/* The lanes' Fresnel factor at i.m: the specular reflectance, times the conductor term where complex_ior. */
MC_INLINE vec3v roughconductor_fresnel(const material_v *mat, floatv cos_im) {
    vec3v spec = mat->color;
    intv cplx = (mat->flags & MAT_FLAG_COMPLEX_IOR) != 0;
    if (lane_any(cplx)) {
        vec3v eta, k;
        material_conductor_ior(mat, &eta, &k);
        spec = v3_select(spec, v3_mul(spec, fresnel_conductor(cos_im, eta, k)), cplx);
    }
    return spec;
}

/* mat->color is the Fresnel factor F, mat->alpha the roughness. */
MC_INLINE vec3v roughconductor_bsdf_eval(const material_v *mat, vec3v wi, vec3v wo, floatv *pdf) {
    floatv alpha = lane_max(mat->alpha, GGX_MIN_ALPHA);
    floatv a2 = alpha * alpha;
    intv ok = (wi.z > 0.0f) & (wo.z > 0.0f);
    vec3v m = v3_normalize(v3_add(wi, wo));
    floatv d = ggx_d(m, a2);
    floatv g1i = ggx_g1(wi, m, a2);
    floatv p = g1i * d / (4.0f * wi.z);
    floatv fc = p * ggx_g1(wo, m, a2);
    intv beck = (mat->flags & MAT_FLAG_BECKMANN) != 0;
    if (lane_any(beck)) {
        floatv pb;
        floatv fb = beckmann_eval(wi, wo, m, alpha, &pb);
        p = lane_select(p, pb, beck);
        fc = lane_select(fc, fb, beck);
    }
    intv aniso = (mat->flags & MAT_FLAG_ANISOTROPIC) != 0;
    if (lane_any(aniso)) {
        floatv av = lane_max(material_alpha_second(mat), GGX_MIN_ALPHA);
        floatv da = aniso_d(m, alpha, av, beck);
        floatv fa = da * aniso_g1(wi, m, alpha, av, beck) * aniso_g1(wo, m, alpha, av, beck) / (4.0f * wi.z);
        floatv pa = aniso_normal_pdf(wi, m, alpha, av, beck) / (4.0f * lane_abs(v3_dot(wo, m)));
        p = lane_select(p, pa, aniso);
        fc = lane_select(fc, fa, aniso);
    }
    *pdf = lane_select((floatv)(0.0f), p, ok);
    return v3_scale(roughconductor_fresnel(mat, v3_dot(wi, m)), lane_select((floatv)(0.0f), fc, ok));
}

/* u_lobe unused (one lobe), eta 1. */
MC_INLINE vec3v roughconductor_bsdf_sample(const material_v *mat, vec3v wi, floatv u_lobe, floatv u1, floatv u2,
                                           vec3v *wo, floatv *pdf, floatv *eta, int mode) {
    floatv alpha = lane_max(mat->alpha, GGX_MIN_ALPHA);
    *eta = (floatv)(1.0f);
    floatv a2 = alpha * alpha;
    intv front = wi.z > 0.0f;
    /* from behind the sample is discarded anyway; keep the maths finite */
    vec3v wiv = v3_select(v3(0.0f, 0.0f, 1.0f), wi, front);
    vec3v m = ggx_sample_visible_normal(wiv, alpha, u1, u2);
    floatv dm = v3_dot(wiv, m);
    vec3v o = v3_sub(v3_scale(m, 2.0f * dm), wiv);
    *wo = o;
    intv ok = front & (o.z > 0.0f);
    floatv p = ggx_g1(wiv, m, a2) * ggx_d(m, a2) / (4.0f * wiv.z);
    floatv w = ggx_g1(o, m, a2);
    intv beck = (mat->flags & MAT_FLAG_BECKMANN) != 0;
    if (lane_any(beck)) {
        vec3v ob;
        floatv pb;
        intv okb;
        floatv wb = beckmann_sample(wiv, alpha, u1, u2, &ob, &pb, &okb);
        *wo = v3_select(o, ob, beck);
        ok = lane_select(ok, front & okb, beck);
        p = lane_select(p, pb, beck);
        w = lane_select(w, wb, beck);
    }
    intv aniso = (mat->flags & MAT_FLAG_ANISOTROPIC) != 0;
    intv cplx = (mat->flags & MAT_FLAG_COMPLEX_IOR) != 0;
    if (lane_any(aniso | cplx)) {
        /* the lanes' microfacet normal, for the Fresnel term (Beckmann's is its half vector) */
        vec3v mb = v3_normalize(v3_add(wiv, *wo));
        m = v3_select(m, mb, beck);
    }
    if (lane_any(aniso)) {
        floatv av = lane_max(material_alpha_second(mat), GGX_MIN_ALPHA);
        vec3v ma = aniso_sample_normal(wiv, alpha, av, u1, u2, beck);
        floatv da = v3_dot(wiv, ma);
        vec3v oa = v3_sub(v3_scale(ma, 2.0f * da), wiv);
        floatv pm = aniso_normal_pdf(wiv, ma, alpha, av, beck);
        floatv dga = aniso_d(ma, alpha, av, beck) * aniso_g1(wiv, ma, alpha, av, beck) * aniso_g1(oa, ma, alpha, av, beck);
        *wo = v3_select(*wo, oa, aniso);
        m = v3_select(m, ma, aniso);
        ok = lane_select(ok, front & (da > 0.0f) & (oa.z > 0.0f) & (pm > 0.0f), aniso);
        p = lane_select(p, pm / (4.0f * da), aniso);
        w = lane_select(w, dga * da / (wiv.z * pm), aniso);
    }
    *pdf = lane_select((floatv)(0.0f), p, ok);
    return v3_scale(roughconductor_fresnel(mat, v3_dot(wiv, m)), lane_select((floatv)(0.0f), w, ok));
}

#endif
