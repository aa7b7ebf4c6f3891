/* microfacet_aniso.cl — anisotropic GGX and Beckmann microfacet distributions
 * (roughness a_u along the first tangent x, a_v along the second y), for the
 * lanes of the rough BSDFs whose material has MAT_FLAG_ANISOTROPIC; the
 * isotropic lanes keep the formulas of render/bsdf_roughconductor.cl.
 *
 *   GGX:      D(m) = 1 / (pi a_u a_v (m_x^2/a_u^2 + m_y^2/a_v^2 + m_z^2)^2)      (Heitz 2014, "Understanding
 *             G1(v) = 2 / (1 + sqrt(1 + (a_u^2 v_x^2 + a_v^2 v_y^2) / v_z^2))    the masking-shadowing function", eqs. 85, 86)
 *   Beckmann: D(m) = exp(-(m_x^2/a_u^2 + m_y^2/a_v^2) / m_z^2) / (pi a_u a_v m_z^4)   (Heitz 2014, eq. 82)
 *             G1 as isotropic Beckmann (Walter eq. 27) with the roughness of v's azimuth,
 *             a(phi)^2 tan^2 theta = (a_u^2 v_x^2 + a_v^2 v_y^2) / v_z^2
 *
 * Normals are sampled as by the isotropic code: GGX by visible normals (Heitz
 * 2018, stretched by (a_u, a_v)), Beckmann from D(m) cos theta_m with
 * tan phi = (a_v / a_u) tan(2 pi u2) and tan^2 theta = -log(1 - u1) /
 * (cos^2 phi / a_u^2 + sin^2 phi / a_v^2) (pbrt-v3 §8.4.3).
 */
#ifndef MCOCL_MICROFACET_ANISO_CL
#define MCOCL_MICROFACET_ANISO_CL

#include "render/material.cl"

MC_INLINE floatv aniso_d(vec3v m, floatv au, floatv av, intv beck) {
    floatv x = m.x / au, y = m.y / av;
    floatv s = x * x + y * y, c2 = m.z * m.z;
    floatv t = s + c2;
    floatv dg = 1.0f / (RT_PI * au * av * t * t);
    floatv db = exp(-s / c2) / (RT_PI * au * av * c2 * c2);
    return lane_select((floatv)(0.0f), lane_select(dg, db, beck), m.z > 0.0f);
}

/* Smith's masking of the lanes' distribution; zero on the wrong side of the microfacet. */
MC_INLINE floatv aniso_g1(vec3v v, vec3v m, floatv au, floatv av, intv beck) {
    floatv a2t2 = (au * au * v.x * v.x + av * av * v.y * v.y) / (v.z * v.z);
    floatv gg = 2.0f / (1.0f + lane_sqrt(1.0f + a2t2));
    floatv b = lane_rsqrt(a2t2);  /* 1 / (a tan theta); inf at normal incidence */
    floatv gb = (3.535f * b + 2.181f * b * b) / (1.0f + 2.276f * b + 2.577f * b * b);
    gb = lane_select(gb, (floatv)(1.0f), b >= 1.6f);
    return lane_select((floatv)(0.0f), lane_select(gg, gb, beck), (v3_dot(v, m) * v.z) > 0.0f);
}

/* Heitz 2018, listing 1, for view direction wi (wi.z > 0) and roughnesses (au, av). */
MC_INLINE vec3v ggx_sample_visible_normal_aniso(vec3v wi, floatv au, floatv av, floatv u1, floatv u2) {
    /* stretch the view direction to the hemisphere configuration (§3.2) */
    vec3v vh = v3_normalize(v3(au * wi.x, av * wi.y, wi.z));
    /* orthonormal basis around vh (§4.1), with its degenerate case */
    floatv lensq = vh.x * vh.x + vh.y * vh.y;
    intv flat = lensq > 0.0f;
    floatv il = lane_rsqrt(lane_select((floatv)(1.0f), lensq, flat));
    vec3v t1v = v3(lane_select((floatv)(1.0f), -vh.y * il, flat), lane_select((floatv)(0.0f), vh.x * il, flat), (floatv)(0.0f));
    vec3v t2v = v3_cross(vh, t1v);
    /* a point of the projected area: a disk whose lower half is squashed (§4.2) */
    floatv r = lane_sqrt(u1);
    floatv c;
    floatv s = lane_sincos_2pi(u2, &c);
    floatv t1 = r * c, t2 = r * s;
    floatv h = 0.5f * (1.0f + vh.z);
    t2 = (1.0f - h) * lane_sqrt(lane_max(1.0f - t1 * t1, 0.0f)) + h * t2;
    /* reproject onto the hemisphere (§4.3) and unstretch (§3.4) */
    vec3v nh = v3_madd(v3_madd(v3_scale(t1v, t1), t2, t2v), safe_sqrt(1.0f - t1 * t1 - t2 * t2), vh);
    return v3_normalize(v3(au * nh.x, av * nh.y, lane_max(nh.z, 0.0f)));
}

/* A microfacet normal for wi (wi.z > 0): GGX visible normals, or Beckmann D(m) cos theta_m. */
MC_INLINE vec3v aniso_sample_normal(vec3v wi, floatv au, floatv av, floatv u1, floatv u2, intv beck) {
    vec3v m = ggx_sample_visible_normal_aniso(wi, au, av, u1, u2);
    if (lane_any(beck)) {
        floatv c;
        floatv s = lane_sincos_2pi(u2, &c);
        floatv px = au * c, py = av * s;  /* the azimuth (pbrt-v3 §8.4.3), unnormalised */
        floatv il = lane_rsqrt(px * px + py * py);
        floatv cp = px * il, sp = py * il;
        floatv t2 = -log(1.0f - u1) / (cp * cp / (au * au) + sp * sp / (av * av));  /* u1 < 1 on the grid */
        floatv cm = 1.0f / lane_sqrt(1.0f + t2);
        floatv sm = lane_sqrt(t2) * cm;
        m = v3_select(m, v3(sm * cp, sm * sp, cm), beck);
    }
    return m;
}

/* The density of aniso_sample_normal's m for wi (wi.z > 0). */
MC_INLINE floatv aniso_normal_pdf(vec3v wi, vec3v m, floatv au, floatv av, intv beck) {
    floatv d = aniso_d(m, au, av, beck);
    floatv pg = aniso_g1(wi, m, au, av, beck) * lane_max(v3_dot(wi, m), 0.0f) * d / wi.z;
    return lane_select(pg, d * m.z, beck);
}

#endif
