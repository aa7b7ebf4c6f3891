/* vec3.cl — 3-vectors over lane types, and orthonormal frames.
 *
 * The renderer's light-transport code is written once over `floatv` (see
 * lanes.cl): built with LANES=1 a vec3v is three floats, with LANES=8 it is
 * three float8 holding eight independent paths (structure of arrays), which
 * is what reaches the SIMD units on PoCL (docs/pocl-notes.md, "Bounce
 * loops").  RGB colours are vec3v too.
 */
#ifndef MCOCL_RENDER_VEC3_CL
#define MCOCL_RENDER_VEC3_CL

#include "lanes.cl"

/* The lane operations (lane_select, lane_min, lane_sqrt, lane_any, ...) are
 * lanes.cl's (lane_ops.cl), shared with every kernel. */

#define RT_PI 3.14159265358979323846f
#define RT_INV_PI 0.31830988618379067154f
#define RT_INV_2PI 0.15915494309189533577f
#define RT_INV_4PI 0.07957747154594766788f

typedef struct {
    floatv x, y, z;
} vec3v;

MC_INLINE vec3v v3(floatv x, floatv y, floatv z) {
    vec3v r;
    r.x = x; r.y = y; r.z = z;
    return r;
}
MC_INLINE vec3v v3s(floatv s) { return v3(s, s, s); }
MC_INLINE vec3v v3_add(vec3v a, vec3v b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
MC_INLINE vec3v v3_sub(vec3v a, vec3v b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
MC_INLINE vec3v v3_mul(vec3v a, vec3v b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
MC_INLINE vec3v v3_scale(vec3v a, floatv s) { return v3(a.x * s, a.y * s, a.z * s); }
MC_INLINE vec3v v3_neg(vec3v a) { return v3(-a.x, -a.y, -a.z); }
/* a + s b */
MC_INLINE vec3v v3_madd(vec3v a, floatv s, vec3v b) { return v3(lane_mad(s, b.x, a.x), lane_mad(s, b.y, a.y), lane_mad(s, b.z, a.z)); }
MC_INLINE floatv v3_dot(vec3v a, vec3v b) { return lane_mad(a.x, b.x, lane_mad(a.y, b.y, a.z * b.z)); }
MC_INLINE vec3v v3_cross(vec3v a, vec3v b) {
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
MC_INLINE floatv v3_len2(vec3v a) { return v3_dot(a, a); }
MC_INLINE vec3v v3_normalize(vec3v a) { return v3_scale(a, lane_rsqrt(v3_dot(a, a))); }
MC_INLINE floatv v3_maxabs(vec3v a) { return lane_max(lane_abs(a.x), lane_max(lane_abs(a.y), lane_abs(a.z))); }
MC_INLINE floatv v3_maxc(vec3v a) { return lane_max(a.x, lane_max(a.y, a.z)); }
/* m ? b : a, lane by lane (m is a comparison mask) */
MC_INLINE vec3v v3_select(vec3v a, vec3v b, intv m) {
    return v3(lane_select(a.x, b.x, m), lane_select(a.y, b.y, m), lane_select(a.z, b.z, m));
}
/* sin and cos of 2 pi u for u in [0, 1), as polynomials in vector registers
 * (the built-in sincos is a library call on PoCL's wheel).  The angle is
 * reduced to r in [-pi/4, pi/4] around the nearest quarter turn q; the Taylor
 * series of sin r to r^9 and cos r to r^10 are accurate to 3e-10, below
 * float rounding. */
MC_INLINE floatv lane_sincos_2pi(floatv u, floatv *cosine) {
    floatv t = u - lane_select((floatv)(0.0f), (floatv)(1.0f), u > 0.5f); /* t in (-0.5, 0.5] */
    floatv q = t * 4.0f;
    floatv qr = lane_select(lane_select(lane_select((floatv)(0.0f), (floatv)(1.0f), q > 0.5f), (floatv)(2.0f), q > 1.5f),
                          lane_select((floatv)(-1.0f), (floatv)(-2.0f), q < -1.5f), q < -0.5f);
    floatv r = (t - 0.25f * qr) * (2.0f * RT_PI);
    floatv r2 = r * r;
    floatv sr = r * (1.0f + r2 * (-1.0f / 6.0f + r2 * (1.0f / 120.0f + r2 * (-1.0f / 5040.0f + r2 * (1.0f / 362880.0f)))));
    floatv cr = 1.0f + r2 * (-0.5f + r2 * (1.0f / 24.0f + r2 * (-1.0f / 720.0f + r2 * (1.0f / 40320.0f + r2 * (-1.0f / 3628800.0f)))));
    /* rotate by q quarter turns: q = 0 (s, c), 1 (c, -s), +-2 (-s, -c), -1 (-c, s) */
    intv q1 = qr == 1.0f, q2 = (qr == 2.0f) | (qr == -2.0f), qm = qr == -1.0f;
    floatv s = lane_select(lane_select(lane_select(sr, cr, q1), -sr, q2), -cr, qm);
    floatv c = lane_select(lane_select(lane_select(cr, -sr, q1), -cr, q2), sr, qm);
    *cosine = c;
    return s;
}

/* An orthonormal frame (s, t, n). */
typedef struct {
    vec3v s, t, n;
} frame3v;

/* The frame around a unit normal n, branch-free: Duff et al., "Building an
 * Orthonormal Basis, Revisited" (JCGT 2017), listing 3. */
MC_INLINE frame3v frame_from_normal(vec3v n) {
    floatv sgn = lane_copysign((floatv)(1.0f), n.z);
    floatv a = -1.0f / (sgn + n.z);
    floatv b = n.x * n.y * a;
    frame3v f;
    f.s = v3(1.0f + sgn * n.x * n.x * a, sgn * b, -sgn * n.x);
    f.t = v3(b, sgn + n.y * n.y * a, -n.y);
    f.n = n;
    return f;
}
MC_INLINE vec3v frame_to_local(frame3v f, vec3v v) { return v3(v3_dot(v, f.s), v3_dot(v, f.t), v3_dot(v, f.n)); }
MC_INLINE vec3v frame_to_world(frame3v f, vec3v v) {
    return v3_madd(v3_madd(v3_scale(f.s, v.x), v.y, f.t), v.z, f.n);
}

/* sqrt of max(x, 0): cosines from 1 - sin^2 that rounded below zero. */
MC_INLINE floatv safe_sqrt(floatv x) { return lane_sqrt(lane_max(x, (floatv)(0.0f))); }

#endif
