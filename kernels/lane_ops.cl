/* lane_ops.cl — the one set of inline lane operations (integration, walks,
 * rendering), included by lanes.cl so that every kernel sees it.
 *
 * The wheel's PoCL calls OpenCL built-ins out of line (docs/pocl-notes.md:
 * "inlines OpenCL built-ins: no"); objdump of the walk kernel showed calls to
 * select, any, isfinite, fabs, fmin, min, vstore8 and vload8 in every
 * iteration, which cost more than the walk's arithmetic, and the megakernel
 * made 600 calls of select alone.  These replacements are operators, bit
 * operations and vector swizzles that LLVM keeps inline.
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
#define lane_as_long(x) as_long(x)
#define lane_as_double(x) as_double(x)
#define lane_full_mask_l(m) (-(long)((m) != 0)) /* 1/0 -> all ones / 0 */
#else
#define lane_as_int(x) MC_CAT(as_int, LANE_SUFFIX)(x)
#define lane_as_uint(x) MC_CAT(as_uint, LANE_SUFFIX)(x)
#define lane_as_float(x) MC_CAT(as_float, LANE_SUFFIX)(x)
#define lane_as_long(x) MC_CAT(as_long, LANE_SUFFIX)(x)
#define lane_as_double(x) MC_CAT(as_double, LANE_SUFFIX)(x)
#define lane_full_mask_l(m) (m)
#endif

/* m ? b : a, lane by lane, for floatv, uintv and intv (int mask) and doublev
 * (long mask, a comparison of doubles).  In vector builds the mask's bits
 * pick the bits of a or b: measured 1.5 % faster in the walk kernel than a
 * vector ?: (which is also inline, but goes through a sign test); select()
 * would be a library call on the wheel's PoCL.  Overloads (clang's
 * overloadable attribute) keep one name for every lane type. */
#if LANES == 1
#define lane_select(a, b, m) ((m) ? (b) : (a))
#else
MC_INLINE __attribute__((overloadable)) floatv lane_select(floatv a, floatv b, intv m) {
    return lane_as_float((lane_as_int(a) & ~m) | (lane_as_int(b) & m));
}
MC_INLINE __attribute__((overloadable)) uintv lane_select(uintv a, uintv b, intv m) {
    const uintv f = lane_as_uint(m);
    return (a & ~f) | (b & f);
}
MC_INLINE __attribute__((overloadable)) intv lane_select(intv a, intv b, intv m) { return (a & ~m) | (b & m); }
MC_INLINE __attribute__((overloadable)) doublev lane_select(doublev a, doublev b, longv m) {
    return lane_as_double((lane_as_long(a) & ~m) | (lane_as_long(b) & m));
}
#endif

/* a * b + c (contracted to an fma where the compiler may; no fma() call) */
#define lane_mad(a, b, c) ((a) * (b) + (c))

/* neither Inf nor NaN */
MC_INLINE intv lane_finite(floatv x) { return (lane_as_int(x) & 0x7f800000) != 0x7f800000; }

MC_INLINE floatv lane_abs(floatv x) { return lane_as_float(lane_as_int(x) & 0x7fffffff); }

/* min(a, b); b when a is NaN (as fmin) */
MC_INLINE floatv lane_min(floatv a, floatv b) { return lane_select(b, a, a < b); }

MC_INLINE uintv lane_min_u(uintv a, uintv b) { return lane_select(b, a, a < b); }

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

/* x clamped into the open interval (0, 1): [the smallest normal float, the
 * largest float below 1] (sampling/unit_interval.cl's clamp_open01).  The
 * lower end is FLT_MIN, not 2^-24: a point (cell + u) / m in the first
 * stratum, or a power-law warp u^(1/(a+1)), is far below 2^-24, and clamping
 * it there removed the mass of (0, 2^-24) from singular integrands (x^-1/2:
 * -1.2e-4 relative, issue 12 part 3).  Zero, NaN and subnormals (which PoCL
 * may flush to zero) become FLT_MIN. */
MC_INLINE floatv lane_open01(floatv x) {
    return lane_select(lane_min(x, (floatv)(0x1.fffffep-1f)), (floatv)(0x1p-126f), !(x >= 0x1p-126f));
}

/* sqrt lane by lane through the compiler's scalar builtin, which LLVM turns
 * into one inline vector square root (vsqrtps) instead of a call that spills
 * every live vector register. */
#if defined(__clang__)
#define LANE_SQRT1(x) __builtin_sqrtf(x)
#else
#define LANE_SQRT1(x) sqrt(x)
#endif
#if LANES == 1
#define lane_sqrt(x) LANE_SQRT1(x)
#elif LANES == 2
MC_INLINE floatv lane_sqrt(floatv x) { return (floatv)(LANE_SQRT1(x.s0), LANE_SQRT1(x.s1)); }
#elif LANES == 4
MC_INLINE floatv lane_sqrt(floatv x) {
    return (floatv)(LANE_SQRT1(x.s0), LANE_SQRT1(x.s1), LANE_SQRT1(x.s2), LANE_SQRT1(x.s3));
}
#elif LANES == 8
MC_INLINE floatv lane_sqrt(floatv x) {
    return (floatv)(LANE_SQRT1(x.s0), LANE_SQRT1(x.s1), LANE_SQRT1(x.s2), LANE_SQRT1(x.s3), LANE_SQRT1(x.s4),
                    LANE_SQRT1(x.s5), LANE_SQRT1(x.s6), LANE_SQRT1(x.s7));
}
#else
MC_INLINE floatv lane_sqrt(floatv x) {
    return (floatv)(LANE_SQRT1(x.s0), LANE_SQRT1(x.s1), LANE_SQRT1(x.s2), LANE_SQRT1(x.s3), LANE_SQRT1(x.s4),
                    LANE_SQRT1(x.s5), LANE_SQRT1(x.s6), LANE_SQRT1(x.s7), LANE_SQRT1(x.s8), LANE_SQRT1(x.s9),
                    LANE_SQRT1(x.sa), LANE_SQRT1(x.sb), LANE_SQRT1(x.sc), LANE_SQRT1(x.sd), LANE_SQRT1(x.se),
                    LANE_SQRT1(x.sf));
}
#endif
#define lane_rsqrt(x) (1.0f / lane_sqrt(x))

/* true if any / every lane of the mask is set.  From 4 lanes on the lanes are narrowed to bytes
 * (m != 0: -1 or 0) and tested as one integer: LLVM emits a compare into a mask register and a
 * byte narrowing instead of a chain of shuffles and ORs over vector halves, which made the
 * megakernel 5-10 % faster (CPU seconds per spp on scenes/veach_mis.json and many_lights.json).
 * lane_all expects a mask (every lane 0 or -1), as every caller passes. */
#if LANES == 1
#define lane_any(m) ((m) != 0)
#define lane_all(m) ((m) != 0)
#elif LANES == 2
#define lane_any(m) (((m).s0 | (m).s1) != 0)
#define lane_all(m) (((m).s0 & (m).s1) != 0)
#elif LANES == 4
#define lane_any(m) (as_uint(convert_char4((m) != 0)) != 0u)
#define lane_all(m) (as_uint(convert_char4((m) != 0)) == ~0u)
#elif LANES == 8
#define lane_any(m) (as_ulong(convert_char8((m) != 0)) != 0ul)
#define lane_all(m) (as_ulong(convert_char8((m) != 0)) == ~0ul)
#else
MC_INLINE int lane_any(intv m) {
    const ulong2 a = as_ulong2(convert_char16(m != 0));
    return (a.s0 | a.s1) != 0ul;
}
MC_INLINE int lane_all(intv m) {
    const ulong2 a = as_ulong2(convert_char16(m != 0));
    return (a.s0 & a.s1) == ~0ul;
}
#endif

/* The lanes of a mask as the bits of a uint (bit k: lane k set), OR-ed over vector halves; with
 * popcount and clz it replaces loops over the lanes whose branch on each lane the CPU mispredicts. */
#if LANES == 1
#define lane_bits(m) ((uint)((m) != 0))
#else
MC_INLINE uint lane_bits(intv m) {
    const uintv b = lane_as_uint(m) & ((uintv)(1u) << LANE_IOTA);
#if LANES == 2
    return b.s0 | b.s1;
#elif LANES == 4
    const uint2 a = b.lo | b.hi;
    return a.s0 | a.s1;
#elif LANES == 8
    const uint4 c = b.lo | b.hi;
    const uint2 a = c.lo | c.hi;
    return a.s0 | a.s1;
#else
    const uint8 d = b.lo | b.hi;
    const uint4 c = d.lo | d.hi;
    const uint2 a = c.lo | c.hi;
    return a.s0 | a.s1;
#endif
}
#endif

/* A lane vector seen as an array (type punning through a union: no vstore call). */
typedef union { floatv v; float a[LANES]; } float_lanes;
typedef union { uintv v; uint a[LANES]; } uint_lanes;
typedef union { intv v; int a[LANES]; } int_lanes;
typedef union { doublev v; double a[LANES]; } double_lanes;

/* ---- doubles ---------------------------------------------------------- */

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


/* ---- division by a divisor that every lane shares ------------------------ */

/* x / d for unsigned lanes x and one d > 0, exact, by a multiply-high with a magic number
 * (Granlund & Montgomery 1994, "Division by invariant integers using multiplication", fig. 4.1:
 * m = floor(2^32 (2^l - d) / d) + 1 with l = ceil(log2 d), then q = (t + ((x - t) >> min(l, 1))) >> max(l - 1, 0)
 * where t = mulhi(m, x)).  x86 has no vector integer divide: `x / d` on a 16-lane vector compiles to 16
 * scalar divides, which took 4 to 6 % of the path tracer's time in its per-path pixel arithmetic
 * (render/integrator.cl).  The divisor's constants are computed once (lane_divisor_of). */
typedef struct { uint m, sh1, sh2; } lane_divisor;

MC_INLINE lane_divisor lane_divisor_of(uint d) {
    const uint l = d > 1u ? 32u - clz(d - 1u) : 0u; /* ceil(log2 d) */
    lane_divisor v;
    v.m = (uint)((((1ul << l) - (ulong)d) << 32) / (ulong)d) + 1u;
    v.sh1 = min(l, 1u);
    v.sh2 = l > 0u ? l - 1u : 0u;
    return v;
}

MC_INLINE uintv lane_div(uintv x, lane_divisor v) {
    const uintv t = to_uintv((to_ulongv(x) * (ulong)v.m) >> 32);
    return (t + ((x - t) >> v.sh1)) >> v.sh2;
}

#endif
