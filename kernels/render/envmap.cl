/* envmap.cl — the environment map: radiance lookup, importance sampling of
 * directions and their density (host and conventions: mcocl/render/envmap.py,
 * Mitsuba 3's envmap).
 *
 * env_map (float4): header quad 0 = (W, H as uint bits), quads 1-3 = the
 * rows of the world -> local rotation; then H rows of W + 1 texels (the first
 * column repeated), scaled.  Local direction (x, y, z) <-> (u, v):
 * u = atan2(x, -z) / 2 pi, v = acos(y) / pi, and back
 * (sin t sin p, cos t, -sin t cos p) with (t, p) = (pi v, 2 pi u).
 * Radiance: bilinear at texel position (x, y) = (u W - 1/2 wrapped into
 * [0, W), v (H - 1)): texel columns are centred at (i + 1/2) / W, rows at
 * j / (H - 1), as Mitsuba 3 looks its maps up (measured against it:
 * tests/test_render_envmap.py).  The density's second axis is s = x / W.
 *
 * env_cdf (uint): the piecewise-constant density of the W x (H - 1) cells
 * between texel centres as sampling/piecewise.cl's 2-D table (marginal over
 * the H - 1 cell rows, then each row's conditional over its W cells), exact
 * on the uniforms' grid; pdf_solid_angle = pdf_uv / (2 pi^2 sin t).
 */
#ifndef MCOCL_RENDER_ENVMAP_CL
#define MCOCL_RENDER_ENVMAP_CL

#include "render/vec3.cl"
#include "sampling/gather.cl"
#include "sampling/piecewise.cl"

#define ENVMAP_HEADER_QUADS 4u
#define RT_2PI2 19.739208802178716f /* 2 pi^2 */

typedef struct {
    global const float4 *texels; /* the env_map table above; 0: no map bound */
    global const uint *cdf;
    uint w, h;                   /* image size; cells: nb = w columns, na = h - 1 rows */
    uint top_a, top_b;           /* largest powers of two <= na, nb */
    float4 r0, r1, r2;           /* world -> local rows */
} envmap_t;

MC_INLINE uint envmap_top(uint n) { return n > 0u ? 1u << (31u - clz(n)) : 0u; }

/* The map of an env_map / env_cdf table pair (an unbound map when texels is 0). */
MC_INLINE envmap_t envmap_of(global const float4 *texels, global const uint *cdf) {
    envmap_t m;
    m.texels = texels;
    m.cdf = cdf;
    m.w = m.h = 0u;
    m.top_a = m.top_b = 0u;
    m.r0 = m.r1 = m.r2 = (float4)(0.0f);
    if (texels != 0) {
        const float4 hd = texels[0];
        m.w = as_uint(hd.x);
        m.h = as_uint(hd.y);
        m.r0 = texels[1];
        m.r1 = texels[2];
        m.r2 = texels[3];
        m.top_a = envmap_top(m.h - 1u);
        m.top_b = envmap_top(m.w);
    }
    return m;
}

/* (s, v) of the world direction d (s = x / W: the texel column position, see the header), and sin(theta). */
MC_INLINE void envmap_uv(const envmap_t *m, vec3v d, floatv *u, floatv *v, floatv *sin_t) {
    vec3v l = v3_normalize(v3(d.x * m->r0.x + d.y * m->r0.y + d.z * m->r0.z,
                              d.x * m->r1.x + d.y * m->r1.y + d.z * m->r1.z,
                              d.x * m->r2.x + d.y * m->r2.y + d.z * m->r2.z));
    floatv uu = atan2(l.x, -l.z) * RT_INV_2PI - 0.5f / (float)m->w;
    uu = lane_select(uu, uu + 1.0f, uu < 0.0f);
    uu = lane_select(uu, uu + 1.0f, uu < 0.0f);
    *u = lane_select(uu, (floatv)(0.0f), uu >= 1.0f);
    /* sin(theta) from the other two components: accurate near the poles, where 1 - y^2 is not */
    floatv st = lane_sqrt(l.x * l.x + l.z * l.z);
    *v = atan2(st, l.y) * RT_INV_PI;
    *sin_t = st;
}

/* The radiance arriving from world direction d (bilinear, scaled). */
MC_INLINE vec3v envmap_radiance(const envmap_t *m, vec3v d, intv active) {
    floatv u, v, st;
    envmap_uv(m, d, &u, &v, &st);
    const uint w = m->w, h = m->h;
    floatv x = u * (float)w, y = v * (float)(h - 1u);
    uintv x0 = lane_min_u(to_uintv_rtz(x), (uintv)(w - 1u));
    uintv y0 = lane_min_u(to_uintv_rtz(y), (uintv)(h - 2u));
    floatv fx = x - to_floatv(x0), fy = y - to_floatv(y0);
    uintv i00 = lane_select((uintv)(0u), (uintv)(ENVMAP_HEADER_QUADS) + y0 * (w + 1u) + x0, active);
    rec4v a = gather_rec4(m->texels, i00), b = gather_rec4(m->texels, i00 + 1u);
    rec4v c = gather_rec4(m->texels, i00 + (w + 1u)), e = gather_rec4(m->texels, i00 + (w + 2u));
    floatv w00 = (1.0f - fx) * (1.0f - fy), w10 = fx * (1.0f - fy), w01 = (1.0f - fx) * fy, w11 = fx * fy;
    vec3v out = v3(w00 * a.x + w10 * b.x + w01 * c.x + w11 * e.x, w00 * a.y + w10 * b.y + w01 * c.y + w11 * e.y,
                   w00 * a.z + w10 * b.z + w01 * c.z + w11 * e.z);
    return v3_select(v3s(0.0f), out, active);
}

/* The solid-angle density with which envmap_sample picks world direction d. */
MC_INLINE floatv envmap_pdf(const envmap_t *m, vec3v d, intv active) {
    floatv u, v, st;
    envmap_uv(m, d, &u, &v, &st);
    floatv puv = pc2_pdf(m->cdf, m->cdf + m->h, m->h - 1u, m->w, v, u);
    floatv p = puv / (RT_2PI2 * st);
    return lane_select((floatv)(0.0f), p, active & (st > 0.0f));
}

/* A world direction by the map's density, from two uniforms; *pdf its solid-angle density. */
MC_INLINE vec3v envmap_sample(const envmap_t *m, floatv u1, floatv u2, floatv *pdf) {
    floatv v, u, puv;
    pc2_warp(m->cdf, m->cdf + m->h, m->h - 1u, m->top_a, m->w, m->top_b, u1, u2, &v, &u, &puv);
    floatv cp;
    floatv sp = lane_sincos_2pi(u + 0.5f / (float)m->w, &cp);
    floatv ct = cos(RT_PI * v), st = sin(RT_PI * v);
    vec3v l = v3(st * sp, ct, -st * cp);
    /* local -> world: the transpose of the world -> local rows */
    vec3v d = v3(l.x * m->r0.x + l.y * m->r1.x + l.z * m->r2.x, l.x * m->r0.y + l.y * m->r1.y + l.z * m->r2.y,
                 l.x * m->r0.z + l.y * m->r1.z + l.z * m->r2.z);
    *pdf = lane_select((floatv)(0.0f), puv / (RT_2PI2 * st), st > 0.0f);
    return d;
}

#endif
