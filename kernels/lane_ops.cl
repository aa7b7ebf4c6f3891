/* lane_ops.cl — inline lane operations for hot loops (walks, integration, rendering).
 *
 * The wheel's PoCL calls OpenCL built-ins out of line (docs/pocl-notes.md:
 * "inlines OpenCL built-ins: no"); objdump of the walk kernel showed calls to
 * select, any, isfinite, fabs, fmin, min, vstore8 and vload8 in every
 * iteration, which cost more than the walk's arithmetic.  These replacements
 * are bit operations and vector swizzles that LLVM keeps inline.
 *
 * Masks as everywhere (lanes.cl): a comparison gives -1/0 per lane in vector
 * builds and 1/0 in the scalar build; every helper here takes either.
 */
#ifndef MCOCL_LANE_OPS_CL
#define MCOCL_LANE_OPS_CL

#include "lanes.cl"

#if LANES == 1
#define lane_as_int(x) as_int(x)
#define lane_as_uint(x) as_uint(x)
#define lane_as_float(x) as_float(x)
#define lane_full_mask(m) (-(int)((m) != 0)) /* 1/0 -> all ones / 0 */
#else
#define lane_as_int(x) MC_CAT(as_int, LANE_SUFFIX)(x)
#define lane_as_uint(x) MC_CAT(as_uint, LANE_SUFFIX)(x)
#define lane_as_float(x) MC_CAT(as_float, LANE_SUFFIX)(x)
#define lane_full_mask(m) (m)
#endif


/* m ? b : a, per lane */
MC_INLINE floatv lane_select(floatv a, floatv b, intv m) {
    const intv f = lane_full_mask(m);
    return lane_as_float((lane_as_int(a) & ~f) | (lane_as_int(b) & f));
}

MC_INLINE uintv lane_select_u(uintv a, uintv b, intv m) {
    const uintv f = lane_as_uint(lane_full_mask(m));
    return (a & ~f) | (b & f);
}

/* neither Inf nor NaN */
MC_INLINE intv lane_finite(floatv x) { return (lane_as_int(x) & 0x7f800000) != 0x7f800000; }

MC_INLINE floatv lane_abs(floatv x) { return lane_as_float(lane_as_int(x) & 0x7fffffff); }

/* min(a, b); b when a is NaN (as fmin) */
MC_INLINE floatv lane_min(floatv a, floatv b) { return lane_select(b, a, a < b); }

MC_INLINE uintv lane_min_u(uintv a, uintv b) { return lane_select_u(b, a, a < b); }

/* max(a, b); b when a is NaN */
MC_INLINE floatv lane_max(floatv a, floatv b) { return lane_select(b, a, a > b); }

/* x clamped into [lo, hi] */
MC_INLINE floatv lane_clamp(floatv x, float lo, float hi) { return lane_min(lane_max(x, (floatv)(lo)), (floatv)(hi)); }

/* |a| with the sign of b */
MC_INLINE floatv lane_copysign(floatv a, floatv b) {
    return lane_as_float((lane_as_int(a) & 0x7fffffff) | (lane_as_int(b) & (int)0x80000000));
}

/* -1, 0 or +1 with the sign of x (0 for +-0 and NaN, as sign()) */
MC_INLINE floatv lane_sign(floatv x) {
    const floatv one = lane_as_float((lane_as_int(x) & (int)0x80000000) | 0x3f800000);
    return lane_select(one, (floatv)(0.0f), (x == 0.0f) | (x != x));
}

/* x clamped into the open interval (0, 1) (unit_interval.cl's clamp_open01, inline) */
MC_INLINE floatv lane_open01(floatv x) {
    return lane_select(lane_min(x, (floatv)(0x1.fffffep-1f)), (floatv)(0x1p-24f), !(x > 0x1p-24f));
}

/* true if any lane of the mask is set */
MC_INLINE int lane_any(intv m) {
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
typedef union { floatv v; float a[LANES]; } float_lanes;
typedef union { uintv v; uint a[LANES]; } uint_lanes;
typedef union { intv v; int a[LANES]; } int_lanes;
typedef union { doublev v; double a[LANES]; } double_lanes;


/* ---- doubles ---------------------------------------------------------- */
#if LANES == 1
#define lane_as_long(x) as_long(x)
#define lane_as_double(x) as_double(x)
#define lane_full_mask_l(m) (-(long)((m) != 0))
#else
#define lane_as_long(x) MC_CAT(as_long, LANE_SUFFIX)(x)
#define lane_as_double(x) MC_CAT(as_double, LANE_SUFFIX)(x)
#define lane_full_mask_l(m) (m)
#endif

/* m ? b : a, per lane, for doubles (m: a comparison of doubles) */
MC_INLINE doublev lane_select_d(doublev a, doublev b, longv m) {
    const longv f = lane_full_mask_l(m);
    return lane_as_double((lane_as_long(a) & ~f) | (lane_as_long(b) & f));
}

/* 1.0 where m holds, else 0.0 (m: a comparison of doubles) */
MC_INLINE doublev lane_indicator_d(longv m) {
    return lane_as_double(lane_as_long((doublev)(1.0)) & lane_full_mask_l(m));
}

/* floor(y) for 0 <= y < 2^51, by rounding through 2^52 (no call to floor) */
MC_INLINE doublev lane_floor_nonneg_d(doublev y) {
    const doublev f = (y + 0x1p52) - 0x1p52;
    return f - lane_indicator_d(f > y);
}

/* A positive finite float moved one float up (+1) or down (-1) where the mask holds. */
MC_INLINE floatv lane_step_positive(floatv t, intv up, intv down) {
    return lane_as_float(lane_as_int(t) + mask_bit(up) - mask_bit(down));
}

#endif
