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

#define RT_INLINE inline __attribute__((always_inline))

/* Elementary lane operations written as plain operators.  PoCL's wheel
 * (3.0-rc2) does not inline OpenCL built-ins: on float8, select(), fma(),
 * fmin(), any() ... each compiled to a call into its library (measured: 600
 * calls of select alone in the megakernel), which kept every lane operation
 * out of registers.  A vector ?: and comparisons compile to single
 * instructions.  Semantics: masks are comparison results (-1/0 on vectors,
 * 1/0 on scalars); rt_min/rt_max return the second operand when the
 * comparison involves a NaN. */
#define rt_select(a, b, m) ((m) ? (b) : (a)) /* lane-wise m ? b : a, like select(a, b, m) */
#define rt_min(a, b) rt_min_(a, b)
#define rt_max(a, b) rt_max_(a, b)
#define rt_fma(a, b, c) ((a) * (b) + (c))

#if LANES == 1
#define RT_AS_FLOATV as_float
#define RT_AS_UINTV as_uint
#else
#define RT_AS_FLOATV MC_CAT(as_float, LANE_SUFFIX)
#define RT_AS_UINTV MC_CAT(as_uint, LANE_SUFFIX)
#endif

RT_INLINE floatv rt_min_(floatv a, floatv b) { return rt_select(b, a, a < b); }
RT_INLINE floatv rt_max_(floatv a, floatv b) { return rt_select(b, a, a > b); }
RT_INLINE floatv rt_abs(floatv x) { return RT_AS_FLOATV(RT_AS_UINTV(x) & 0x7fffffffu); }
RT_INLINE floatv rt_copysign(floatv x, floatv s) {
    return RT_AS_FLOATV((RT_AS_UINTV(x) & 0x7fffffffu) | (RT_AS_UINTV(s) & 0x80000000u));
}
/* finite: x - x is 0 for finite x and NaN for Inf and NaN (no fast-math, so it is not folded) */
RT_INLINE intv rt_isfinite(floatv x) { return (x - x) == 0.0f; }

/* sqrt lane by lane through the compiler's scalar builtin, which LLVM turns
 * into one inline vector square root (vsqrtps) instead of a call that spills
 * every live vector register. */
#if defined(__clang__)
#define RT_SQRT1(x) __builtin_sqrtf(x)
#else
#define RT_SQRT1(x) sqrt(x)
#endif
#if LANES == 1
#define rt_sqrt(x) RT_SQRT1(x)
#elif LANES == 2
RT_INLINE floatv rt_sqrt(floatv x) { return (floatv)(RT_SQRT1(x.s0), RT_SQRT1(x.s1)); }
#elif LANES == 4
RT_INLINE floatv rt_sqrt(floatv x) { return (floatv)(RT_SQRT1(x.s0), RT_SQRT1(x.s1), RT_SQRT1(x.s2), RT_SQRT1(x.s3)); }
#elif LANES == 8
RT_INLINE floatv rt_sqrt(floatv x) {
    return (floatv)(RT_SQRT1(x.s0), RT_SQRT1(x.s1), RT_SQRT1(x.s2), RT_SQRT1(x.s3), RT_SQRT1(x.s4), RT_SQRT1(x.s5),
                    RT_SQRT1(x.s6), RT_SQRT1(x.s7));
}
#else
RT_INLINE floatv rt_sqrt(floatv x) {
    return (floatv)(RT_SQRT1(x.s0), RT_SQRT1(x.s1), RT_SQRT1(x.s2), RT_SQRT1(x.s3), RT_SQRT1(x.s4), RT_SQRT1(x.s5),
                    RT_SQRT1(x.s6), RT_SQRT1(x.s7), RT_SQRT1(x.s8), RT_SQRT1(x.s9), RT_SQRT1(x.sa), RT_SQRT1(x.sb),
                    RT_SQRT1(x.sc), RT_SQRT1(x.sd), RT_SQRT1(x.se), RT_SQRT1(x.sf));
}
#endif
#define rt_rsqrt(x) (1.0f / rt_sqrt(x))

/* any / all lanes of a mask, by OR / AND reductions over vector halves */
#if LANES == 1
#define rt_any(m) ((m) != 0)
#define rt_all(m) ((m) != 0)
#elif LANES == 2
#define rt_any(m) (((m).x | (m).y) != 0)
#define rt_all(m) (((m).x & (m).y) != 0)
#elif LANES == 4
#define rt_any(m) ((((m).lo | (m).hi).x | ((m).lo | (m).hi).y) != 0)
#define rt_all(m) ((((m).lo & (m).hi).x & ((m).lo & (m).hi).y) != 0)
#elif LANES == 8
RT_INLINE bool rt_any(int8 m) { int4 a = m.lo | m.hi; int2 b = a.lo | a.hi; return (b.x | b.y) != 0; }
RT_INLINE bool rt_all(int8 m) { int4 a = m.lo & m.hi; int2 b = a.lo & a.hi; return (b.x & b.y) != 0; }
#else
RT_INLINE bool rt_any(int16 m) { int8 c = m.lo | m.hi; int4 a = c.lo | c.hi; int2 b = a.lo | a.hi; return (b.x | b.y) != 0; }
RT_INLINE bool rt_all(int16 m) { int8 c = m.lo & m.hi; int4 a = c.lo & c.hi; int2 b = a.lo & a.hi; return (b.x & b.y) != 0; }
#endif

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
RT_INLINE vec3v v3_madd(vec3v a, floatv s, vec3v b) { return v3(rt_fma(s, b.x, a.x), rt_fma(s, b.y, a.y), rt_fma(s, b.z, a.z)); }
RT_INLINE floatv v3_dot(vec3v a, vec3v b) { return rt_fma(a.x, b.x, rt_fma(a.y, b.y, a.z * b.z)); }
RT_INLINE vec3v v3_cross(vec3v a, vec3v b) {
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
RT_INLINE floatv v3_len2(vec3v a) { return v3_dot(a, a); }
RT_INLINE vec3v v3_normalize(vec3v a) { return v3_scale(a, rt_rsqrt(v3_dot(a, a))); }
RT_INLINE floatv v3_maxabs(vec3v a) { return rt_max(rt_abs(a.x), rt_max(rt_abs(a.y), rt_abs(a.z))); }
RT_INLINE floatv v3_maxc(vec3v a) { return rt_max(a.x, rt_max(a.y, a.z)); }
/* m ? b : a, lane by lane (m is a comparison mask) */
RT_INLINE vec3v v3_select(vec3v a, vec3v b, intv m) {
    return v3(rt_select(a.x, b.x, m), rt_select(a.y, b.y, m), rt_select(a.z, b.z, m));
}
RT_INLINE intv v3_isfinite(vec3v a) { return rt_isfinite(a.x) & rt_isfinite(a.y) & rt_isfinite(a.z); }
/* Rec. 709 luminance, the "power" of an RGB radiance. */
RT_INLINE floatv v3_luminance(vec3v c) { return 0.212671f * c.x + 0.715160f * c.y + 0.072169f * c.z; }

/* sin and cos of 2 pi u for u in [0, 1), as polynomials in vector registers
 * (the built-in sincos is a library call on PoCL's wheel).  The angle is
 * reduced to r in [-pi/4, pi/4] around the nearest quarter turn q; the Taylor
 * series of sin r to r^9 and cos r to r^10 are accurate to 3e-10, below
 * float rounding. */
RT_INLINE floatv rt_sincos_2pi(floatv u, floatv *cosine) {
    floatv t = u - rt_select((floatv)(0.0f), (floatv)(1.0f), u > 0.5f); /* t in (-0.5, 0.5] */
    floatv q = t * 4.0f;
    floatv qr = rt_select(rt_select(rt_select((floatv)(0.0f), (floatv)(1.0f), q > 0.5f), (floatv)(2.0f), q > 1.5f),
                          rt_select((floatv)(-1.0f), (floatv)(-2.0f), q < -1.5f), q < -0.5f);
    floatv r = (t - 0.25f * qr) * (2.0f * RT_PI);
    floatv r2 = r * r;
    floatv sr = r * (1.0f + r2 * (-1.0f / 6.0f + r2 * (1.0f / 120.0f + r2 * (-1.0f / 5040.0f + r2 * (1.0f / 362880.0f)))));
    floatv cr = 1.0f + r2 * (-0.5f + r2 * (1.0f / 24.0f + r2 * (-1.0f / 720.0f + r2 * (1.0f / 40320.0f + r2 * (-1.0f / 3628800.0f)))));
    /* rotate by q quarter turns: q = 0 (s, c), 1 (c, -s), +-2 (-s, -c), -1 (-c, s) */
    intv q1 = qr == 1.0f, q2 = (qr == 2.0f) | (qr == -2.0f), qm = qr == -1.0f;
    floatv s = rt_select(rt_select(rt_select(sr, cr, q1), -sr, q2), -cr, qm);
    floatv c = rt_select(rt_select(rt_select(cr, -sr, q1), -cr, q2), sr, qm);
    *cosine = c;
    return s;
}

/* An orthonormal frame (s, t, n). */
typedef struct {
    vec3v s, t, n;
} frame3v;

/* The frame around a unit normal n, branch-free: Duff et al., "Building an
 * Orthonormal Basis, Revisited" (JCGT 2017), listing 3. */
RT_INLINE frame3v frame_from_normal(vec3v n) {
    floatv sgn = rt_copysign((floatv)(1.0f), n.z);
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
RT_INLINE floatv safe_sqrt(floatv x) { return rt_sqrt(rt_max(x, (floatv)(0.0f))); }

#endif
