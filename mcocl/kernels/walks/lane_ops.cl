/* lane_ops.cl — inline lane operations for the walk's hot loop.
 *
 * The wheel's PoCL calls OpenCL built-ins out of line (../shared/POCL-NOTES.md:
 * "inlines OpenCL built-ins: no"); objdump of the walk kernel showed calls to
 * select, any, isfinite, fabs, fmin, min, vstore8 and vload8 in every
 * iteration, which cost more than the walk's arithmetic.  These replacements
 * are bit operations and vector swizzles that LLVM keeps inline.
 *
 * Masks as everywhere (lanes.cl): a comparison gives -1/0 per lane in vector
 * builds and 1/0 in the scalar build; every helper here takes either.
 */
#ifndef MCOCL_WALK_LANE_OPS_CL
#define MCOCL_WALK_LANE_OPS_CL

#include "lanes.cl"

#if LANES == 1
#define wl_as_int(x) as_int(x)
#define wl_as_uint(x) as_uint(x)
#define wl_as_float(x) as_float(x)
#define wl_full(m) (-(int)((m) != 0)) /* 1/0 -> all ones / 0 */
#else
#define wl_as_int(x) MC_CAT(as_int, LANE_SUFFIX)(x)
#define wl_as_uint(x) MC_CAT(as_uint, LANE_SUFFIX)(x)
#define wl_as_float(x) MC_CAT(as_float, LANE_SUFFIX)(x)
#define wl_full(m) (m)
#endif

#define WL_INLINE inline __attribute__((always_inline))

/* m ? b : a, per lane */
WL_INLINE floatv wl_self(floatv a, floatv b, intv m) {
    const intv f = wl_full(m);
    return wl_as_float((wl_as_int(a) & ~f) | (wl_as_int(b) & f));
}

WL_INLINE uintv wl_selu(uintv a, uintv b, intv m) {
    const uintv f = wl_as_uint(wl_full(m));
    return (a & ~f) | (b & f);
}

/* neither Inf nor NaN */
WL_INLINE intv wl_finite(floatv x) { return (wl_as_int(x) & 0x7f800000) != 0x7f800000; }

WL_INLINE floatv wl_abs(floatv x) { return wl_as_float(wl_as_int(x) & 0x7fffffff); }

/* min(a, b); b when a is NaN (as fmin) */
WL_INLINE floatv wl_min(floatv a, floatv b) { return wl_self(b, a, a < b); }

WL_INLINE uintv wl_minu(uintv a, uintv b) { return wl_selu(b, a, a < b); }

/* |a| with the sign of b */
WL_INLINE floatv wl_copysign(floatv a, floatv b) {
    return wl_as_float((wl_as_int(a) & 0x7fffffff) | (wl_as_int(b) & (int)0x80000000));
}

/* -1, 0 or +1 with the sign of x (0 for +-0 and NaN, as sign()) */
WL_INLINE floatv wl_sign(floatv x) {
    const floatv one = wl_as_float((wl_as_int(x) & (int)0x80000000) | 0x3f800000);
    return wl_self(one, (floatv)(0.0f), (x == 0.0f) | (x != x));
}

/* x clamped into the open interval (0, 1) (unit_interval.cl's clamp_open01, inline) */
WL_INLINE floatv wl_open01(floatv x) {
    return wl_self(wl_min(x, (floatv)(0x1.fffffep-1f)), (floatv)(0x1p-24f), !(x > 0x1p-24f));
}

/* true if any lane of the mask is set */
WL_INLINE int wl_any(intv m) {
#if LANES == 1
    return m != 0;
#elif LANES == 2
    return (m.s0 | m.s1) != 0;
#elif LANES == 4
    const int2 a = m.lo | m.hi;
    return (a.s0 | a.s1) != 0;
#elif LANES == 8
    const int4 a = m.lo | m.hi;
    const int2 b = a.lo | a.hi;
    return (b.s0 | b.s1) != 0;
#else
    const int8 a = m.lo | m.hi;
    const int4 b = a.lo | a.hi;
    const int2 c = b.lo | b.hi;
    return (c.s0 | c.s1) != 0;
#endif
}

/* A lane vector seen as an array (type punning through a union: no vstore call). */
typedef union { floatv v; float a[LANES]; } wl_float_lanes;
typedef union { uintv v; uint a[LANES]; } wl_uint_lanes;
typedef union { intv v; int a[LANES]; } wl_int_lanes;
typedef union { doublev v; double a[LANES]; } wl_double_lanes;

#endif
