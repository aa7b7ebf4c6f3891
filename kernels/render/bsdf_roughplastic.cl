/* bsdf_roughplastic.cl — a rough dielectric coating over a Lambertian base,
 * as Mitsuba 3's `roughplastic` (linear variant, specular reflectance 1):
 * one-sided unless the material is twosided (render/bsdf.cl mirrors it).
 *
 * eta = int_ior / ext_ior, D and G = G1(i) G1(o) the coating's microfacet
 * distribution (GGX or Beckmann, render/bsdf_roughconductor.cl), F the
 * Fresnel reflectance (render/bsdf_dielectric.cl), h the half vector, rho the
 * base albedo, t(mu) the coating's tabulated external transmittance and R_int
 * its internal reflectance (mcocl/render/roughplastic_tables.py):
 *
 *   specular:  f cos = F(i.h) D(h) G / (4 cos theta_i)                   (Walter et al. 2007, eq. 20)
 *   diffuse:   f cos = rho / (1 - R_int) t(cos theta_i) t(cos theta_o) cos theta_o / (pi eta^2)
 *
 * (Weidlich & Wilkie 2007, the internal reflections summed as a geometric
 * series, linear in rho; the smooth plastic's model with the rough coat's
 * transmittance in place of 1 - F.)  The lobes are sampled with probabilities
 * proportional to (1 - t_i) s and t_i (1 - s), s = 1 / (1 + mean(rho)) (Mitsuba's
 * specular sampling weight): the specular one by a microfacet normal (GGX
 * visible normals, Beckmann D cos) reflected, the diffuse one cosine-distributed;
 * pdf and weight are the mixture's (eval / pdf).
 */
#ifndef MCOCL_BSDF_ROUGHPLASTIC_CL
#define MCOCL_BSDF_ROUGHPLASTIC_CL

#include "render/material.cl"
#include "render/bsdf_diffuse.cl"
#include "render/bsdf_roughdielectric.cl"

/* Entries of the transmittance table (mcocl/render/roughplastic_tables.py RES); R_int follows them. */
#define ROUGHPLASTIC_RES 64

/* t(mu) by linear interpolation of the table (first float `table`) at mu = k / (RES - 1). */
MC_INLINE floatv roughplastic_transmittance(const material_v *mat, floatv table, floatv mu) {
    global const float *base = (global const float *)mat->mats;
    floatv x = lane_min(lane_max(mu, 0.0f), 1.0f) * (float)(ROUGHPLASTIC_RES - 1);
    floatv i0 = lane_min(floor(x), (floatv)((float)(ROUGHPLASTIC_RES - 2)));
    uintv k = to_uintv(table + i0);
    floatv a = gather_float(base, k), b = gather_float(base, k + 1u);
    return a + (x - i0) * (b - a);
}

/* Floats per table (mcocl/render/roughplastic_tables.py TABLE_FLOATS): a grid's tables follow each other. */
#define ROUGHPLASTIC_TABLE_FLOATS 80

/* A textured alpha's tables (MAT_FLAG_ALPHA_GRID; roughplastic_tables.py alpha_grid_tables): the first
 * float of the table below alpha on the grid evenly spaced in log alpha, *step the floats to the one
 * above (0 when the grid has one alpha), *w the weight of the one above. */
MC_INLINE floatv roughplastic_grid(const material_v *mat, floatv table, floatv alpha, floatv *step, floatv *w) {
    global const float *base = (global const float *)mat->mats;
    uintv head = to_uintv(table) + (uint)ROUGHPLASTIC_RES;
    floatv log_lo = gather_float(base, head + 1u), inv_step = gather_float(base, head + 2u);
    floatv last = gather_float(base, head + 3u);
    floatv x = lane_min(lane_max((log(alpha) - log_lo) * inv_step, 0.0f), last);
    floatv i0 = lane_min(floor(x), lane_max(last - 1.0f, 0.0f));
    *w = x - i0;
    *step = lane_select((floatv)(0.0f), (floatv)((float)ROUGHPLASTIC_TABLE_FLOATS), last > 0.0f);
    return table + i0 * (float)ROUGHPLASTIC_TABLE_FLOATS;
}

/* The coat's t(mu_i), t(mu_o) and R_int: the material's table, or on MAT_FLAG_ALPHA_GRID lanes the grid's
 * two tables around the lanes' alpha, interpolated linearly in log alpha. */
MC_INLINE void roughplastic_coat(const material_v *mat, floatv alpha, floatv mu_i, floatv mu_o, floatv *t_i,
                                 floatv *t_o, floatv *r_int) {
    global const float *base = (global const float *)mat->mats;
    floatv table = material_table(mat);
    intv grid = (mat->flags & MAT_FLAG_ALPHA_GRID) != 0;
    if (lane_any(grid)) {
        floatv step, w;
        floatv t0 = lane_select(table, roughplastic_grid(mat, table, alpha, &step, &w), grid);
        floatv t1 = t0 + lane_select((floatv)(0.0f), step, grid);
        w = lane_select((floatv)(0.0f), w, grid);
        floatv a = roughplastic_transmittance(mat, t0, mu_i), b = roughplastic_transmittance(mat, t1, mu_i);
        *t_i = a + w * (b - a);
        a = roughplastic_transmittance(mat, t0, mu_o);
        b = roughplastic_transmittance(mat, t1, mu_o);
        *t_o = a + w * (b - a);
        a = gather_float(base, to_uintv(t0) + (uint)ROUGHPLASTIC_RES);
        b = gather_float(base, to_uintv(t1) + (uint)ROUGHPLASTIC_RES);
        *r_int = a + w * (b - a);
        return;
    }
    *t_i = roughplastic_transmittance(mat, table, mu_i);
    *t_o = roughplastic_transmittance(mat, table, mu_o);
    *r_int = gather_float(base, to_uintv(table) + (uint)ROUGHPLASTIC_RES);
}

/* f cos and the pdf of sampling wo (both lobes), for wi, wo above the surface (else 0). */
MC_INLINE vec3v roughplastic_bsdf_eval(const material_v *mat, vec3v wi, vec3v wo, floatv *pdf) {
    floatv alpha = lane_max(mat->alpha, GGX_MIN_ALPHA);
    intv beck = (mat->flags & MAT_FLAG_BECKMANN) != 0;
    intv none = (intv)(0);
    intv ok = (wi.z > 0.0f) & (wo.z > 0.0f);
    vec3v h = v3_normalize(v3_add(wi, wo));
    floatv ct, it, ti;
    floatv f = fresnel_dielectric(v3_dot(wi, h), mat->eta, &ct, &it, &ti);
    floatv spec = f * roughdielectric_dg(wi, wo, h, alpha, alpha, beck, none) / (4.0f * wi.z);
    floatv t_i, t_o, r_int;
    roughplastic_coat(mat, alpha, wi.z, wo.z, &t_i, &t_o, &r_int);
    floatv kd = t_i * t_o * wo.z * RT_INV_PI / ((1.0f - r_int) * mat->eta * mat->eta);
    floatv d_mean = (mat->color.x + mat->color.y + mat->color.z) * (1.0f / 3.0f);
    floatv s = 1.0f / (1.0f + d_mean);
    floatv ps = (1.0f - t_i) * s, pd = t_i * (1.0f - s);
    floatv p_spec = lane_select(ps / (ps + pd), (floatv)(1.0f), ps + pd <= 0.0f);
    floatv pm = roughdielectric_normal_pdf(wi, h, alpha, alpha, beck, none);
    floatv p = p_spec * pm / (4.0f * lane_abs(v3_dot(wo, h))) + (1.0f - p_spec) * wo.z * RT_INV_PI;
    *pdf = lane_select((floatv)(0.0f), p, ok);
    vec3v fc = v3_add(v3s(spec), v3_scale(mat->color, kd));
    return v3_select(v3s(0.0f), fc, ok);
}

/* u_lobe picks the lobe (probabilities as eval's pdf), (u1, u2) the direction; symmetric, eta 1. */
MC_INLINE vec3v roughplastic_bsdf_sample(const material_v *mat, vec3v wi, floatv u_lobe, floatv u1, floatv u2,
                                         vec3v *wo, floatv *pdf, floatv *eta, int mode) {
    floatv alpha = lane_max(mat->alpha, GGX_MIN_ALPHA);
    intv beck = (mat->flags & MAT_FLAG_BECKMANN) != 0;
    intv front = wi.z > 0.0f;
    vec3v wiv = v3_select(v3(0.0f, 0.0f, 1.0f), wi, front);
    floatv t_i, t_o, r_int;
    roughplastic_coat(mat, alpha, wiv.z, wiv.z, &t_i, &t_o, &r_int);
    floatv d_mean = (mat->color.x + mat->color.y + mat->color.z) * (1.0f / 3.0f);
    floatv s = 1.0f / (1.0f + d_mean);
    floatv ps = (1.0f - t_i) * s, pd = t_i * (1.0f - s);
    floatv p_spec = lane_select(ps / (ps + pd), (floatv)(1.0f), ps + pd <= 0.0f);
    vec3v m = aniso_sample_normal(wiv, alpha, alpha, u1, u2, beck);
    vec3v wr = v3_sub(v3_scale(m, 2.0f * v3_dot(wiv, m)), wiv);
    floatv cpdf;
    vec3v wd = square_to_cosine_hemisphere(u1, u2, &cpdf);
    vec3v o = v3_select(wd, wr, u_lobe < p_spec);
    *wo = o;
    *eta = (floatv)(1.0f);
    floatv p;
    vec3v f = roughplastic_bsdf_eval(mat, wiv, o, &p);
    intv ok = front & (p > 0.0f);
    *pdf = lane_select((floatv)(0.0f), p, ok);
    return v3_select(v3s(0.0f), v3_scale(f, 1.0f / p), ok);
}

#endif
