/* lanes.cl — one source, scalar or SIMD-packet build: the lane types, the
 * one force-inline macro (MC_INLINE) and, in lane_ops.cl (included at the
 * end), the one set of lane operations every kernel uses.
 *
 * Every estimator kernel is written once over the "lane" types below and built
 * with -DLANES=1 (scalar) or -DLANES=16 (a packet of 16 samples in the lanes of
 * OpenCL vector types).  PoCL's wheel build does not vectorise across
 * work-items (docs/pocl-notes.md), so explicit 16-lane vectors are what
 * reaches the SIMD units; the scalar build exists for user code that is not
 * valid on vectors (an `if` on a coordinate, an int cast) and for devices
 * where vectors do not pay (GPUs vectorise across work-items themselves).
 *
 * Masks follow OpenCL's vector convention: a true lane is all ones (-1) in a
 * vector build and 1 in a scalar build; use the helpers here, never compare
 * a mask with 1.
 */
#ifndef MCOCL_LANES_CL
#define MCOCL_LANES_CL

#ifndef LANES
#define LANES 16
#endif

#pragma OPENCL EXTENSION cl_khr_fp64 : enable

/* Every helper that takes or returns lane vectors is forced inline: PoCL's
 * LLVM otherwise keeps some as calls, and a call passes 256-bit and wider
 * vectors through memory on AVX2 (the "changes the ABI" note).  Measured on
 * the integration kernel: 97 -> 139 M samples per CPU-second. */
#define MC_INLINE inline __attribute__((always_inline))

#define MC_CAT_(a, b) a##b
#define MC_CAT(a, b) MC_CAT_(a, b)

#if LANES == 1
#define LANE_SUFFIX
#elif LANES == 2 || LANES == 4 || LANES == 8 || LANES == 16
#define LANE_SUFFIX LANES
#else
#error "LANES must be 1, 2, 4, 8 or 16"
#endif

typedef MC_CAT(float, LANE_SUFFIX) floatv;
typedef MC_CAT(double, LANE_SUFFIX) doublev;
typedef MC_CAT(uint, LANE_SUFFIX) uintv;
typedef MC_CAT(int, LANE_SUFFIX) intv;
typedef MC_CAT(ulong, LANE_SUFFIX) ulongv;
typedef MC_CAT(long, LANE_SUFFIX) longv;

#define to_floatv(x) MC_CAT(convert_float, LANE_SUFFIX)(x)
#define to_doublev(x) MC_CAT(convert_double, LANE_SUFFIX)(x)
#define to_uintv(x) MC_CAT(convert_uint, LANE_SUFFIX)(x)
#define to_intv(x) MC_CAT(convert_int, LANE_SUFFIX)(x)
#define to_ulongv(x) MC_CAT(convert_ulong, LANE_SUFFIX)(x)
#define to_longv(x) MC_CAT(convert_long, LANE_SUFFIX)(x)
#define to_uintv_rtz(x) MC_CAT(MC_CAT(convert_uint, LANE_SUFFIX), _rtz)(x)
#define to_intv_rtz(x) MC_CAT(MC_CAT(convert_int, LANE_SUFFIX), _rtz)(x)

/* Lane index 0..LANES-1 as a uint vector. */
#if LANES == 1
#define LANE_IOTA ((uint)0)
#elif LANES == 2
#define LANE_IOTA ((uint2)(0, 1))
#elif LANES == 4
#define LANE_IOTA ((uint4)(0, 1, 2, 3))
#elif LANES == 8
#define LANE_IOTA ((uint8)(0, 1, 2, 3, 4, 5, 6, 7))
#else
#define LANE_IOTA ((uint16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15))
#endif

/* A comparison result (intv mask) as 0/1 integers, the same in both builds. */
#if LANES == 1
#define mask_bit(m) ((m) ? 1 : 0)
#else
#define mask_bit(m) (-(m))
#endif

/* Horizontal sums of lane vectors in a fixed order (lane 0 first), so that
 * the result is the same however the work is split. */
#if LANES == 1
#define MC_LANE_SUM(name, T, TV) MC_INLINE T name(TV v) { return v; }
#else
#define MC_LANE_SUM(name, T, TV)                         \
    MC_INLINE T name(TV v) {                             \
        T t[LANES];                                      \
        MC_CAT(vstore, LANE_SUFFIX)(v, 0, t);            \
        T s = 0;                                         \
        for (int k = 0; k < LANES; ++k) s += t[k];       \
        return s;                                        \
    }
#endif
MC_LANE_SUM(lane_sum_d, double, doublev)
MC_LANE_SUM(lane_sum_u, uint, uintv)
MC_LANE_SUM(lane_sum_ul, ulong, ulongv)

#include "lane_ops.cl"

#endif
