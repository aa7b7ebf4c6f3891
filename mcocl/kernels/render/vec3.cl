/* vec3.cl — 3-vectors over lane types, and orthonormal frames.
 *
 * The renderer's light-transport code is written once over `floatv` (see
 * lanes.cl): built with LANES=1 a vec3v is three floats, with LANES=8 it is
 * three float8 holding eight independent paths (structure of arrays), which
 * is what reaches the SIMD units on PoCL (../shared/POCL-NOTES.md, "Bounce
 * loops").  RGB colours are vec3v too.
 */
#ifndef MCOCL_RENDER_VEC3_CL
#define MCOCL_RENDER_VEC3_CL

#include "lanes.cl"

#define RT_INLINE inline __attribute__((always_inline))

#define RT_PI 3.14159265358979323846f
#define RT_INV_PI 0.31830988618379067154f
#define RT_INV_2PI 0.15915494309189533577f
#define RT_INV_4PI 0.07957747154594766788f

typedef struct {
    floatv x, y, z;
} vec3v;

RT_INLINE vec3v v3(floatv x, floatv y, floatv z) {
    vec3v r;
    r.x = x; r.y = y; r.z = z;
    return r;
}
RT_INLINE vec3v v3s(floatv s) { return v3(s, s, s); }
RT_INLINE vec3v v3_add(vec3v a, vec3v b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
RT_INLINE vec3v v3_sub(vec3v a, vec3v b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
RT_INLINE vec3v v3_mul(vec3v a, vec3v b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
RT_INLINE vec3v v3_scale(vec3v a, floatv s) { return v3(a.x * s, a.y * s, a.z * s); }
RT_INLINE vec3v v3_neg(vec3v a) { return v3(-a.x, -a.y, -a.z); }
/* a + s b */
RT_INLINE vec3v v3_madd(vec3v a, floatv s, vec3v b) { return v3(fma(s, b.x, a.x), fma(s, b.y, a.y), fma(s, b.z, a.z)); }
RT_INLINE floatv v3_dot(vec3v a, vec3v b) { return fma(a.x, b.x, fma(a.y, b.y, a.z * b.z)); }
RT_INLINE vec3v v3_cross(vec3v a, vec3v b) {
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
RT_INLINE floatv v3_len2(vec3v a) { return v3_dot(a, a); }
RT_INLINE vec3v v3_normalize(vec3v a) { return v3_scale(a, rsqrt(v3_dot(a, a))); }
RT_INLINE floatv v3_maxabs(vec3v a) { return fmax(fabs(a.x), fmax(fabs(a.y), fabs(a.z))); }
RT_INLINE floatv v3_maxc(vec3v a) { return fmax(a.x, fmax(a.y, a.z)); }
/* m ? b : a, lane by lane (m is a comparison mask) */
RT_INLINE vec3v v3_select(vec3v a, vec3v b, intv m) {
    return v3(select(a.x, b.x, m), select(a.y, b.y, m), select(a.z, b.z, m));
}
RT_INLINE intv v3_isfinite(vec3v a) { return isfinite(a.x) & isfinite(a.y) & isfinite(a.z); }
/* Rec. 709 luminance, the "power" of an RGB radiance. */
RT_INLINE floatv v3_luminance(vec3v c) { return 0.212671f * c.x + 0.715160f * c.y + 0.072169f * c.z; }

/* An orthonormal frame (s, t, n). */
typedef struct {
    vec3v s, t, n;
} frame3v;

/* The frame around a unit normal n, branch-free: Duff et al., "Building an
 * Orthonormal Basis, Revisited" (JCGT 2017), listing 3. */
RT_INLINE frame3v frame_from_normal(vec3v n) {
    floatv sgn = copysign((floatv)(1.0f), n.z);
    floatv a = -1.0f / (sgn + n.z);
    floatv b = n.x * n.y * a;
    frame3v f;
    f.s = v3(1.0f + sgn * n.x * n.x * a, sgn * b, -sgn * n.x);
    f.t = v3(b, sgn + n.y * n.y * a, -n.y);
    f.n = n;
    return f;
}
RT_INLINE vec3v frame_to_local(frame3v f, vec3v v) { return v3(v3_dot(v, f.s), v3_dot(v, f.t), v3_dot(v, f.n)); }
RT_INLINE vec3v frame_to_world(frame3v f, vec3v v) {
    return v3_madd(v3_madd(v3_scale(f.s, v.x), v.y, f.t), v.z, f.n);
}

/* sqrt of max(x, 0): cosines from 1 - sin^2 that rounded below zero. */
RT_INLINE floatv safe_sqrt(floatv x) { return sqrt(fmax(x, (floatv)(0.0f))); }

#endif
