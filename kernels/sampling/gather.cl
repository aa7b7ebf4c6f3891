/* gather.cl — per-lane loads from a table: t[idx] for every lane.
 * OpenCL C has no vector gather; spelled out per width, which LLVM turns into
 * a hardware gather where the target has one. */
#ifndef MCOCL_GATHER_CL
#define MCOCL_GATHER_CL

#include "lanes.cl"

#if LANES == 1
#define GATHER(T, t, i) ((t)[(i)])
#elif LANES == 2
#define GATHER(T, t, i) ((MC_CAT(T, 2))((t)[(i).s0], (t)[(i).s1]))
#elif LANES == 4
#define GATHER(T, t, i) ((MC_CAT(T, 4))((t)[(i).s0], (t)[(i).s1], (t)[(i).s2], (t)[(i).s3]))
#elif LANES == 8
#define GATHER(T, t, i) ((MC_CAT(T, 8))((t)[(i).s0], (t)[(i).s1], (t)[(i).s2], (t)[(i).s3], \
                                         (t)[(i).s4], (t)[(i).s5], (t)[(i).s6], (t)[(i).s7]))
#else
#define GATHER(T, t, i) ((MC_CAT(T, 16))((t)[(i).s0], (t)[(i).s1], (t)[(i).s2], (t)[(i).s3], \
                                          (t)[(i).s4], (t)[(i).s5], (t)[(i).s6], (t)[(i).s7], \
                                          (t)[(i).s8], (t)[(i).s9], (t)[(i).sa], (t)[(i).sb], \
                                          (t)[(i).sc], (t)[(i).sd], (t)[(i).se], (t)[(i).sf]))
#endif

MC_INLINE uintv gather_uint(global const uint *t, uintv i) { return GATHER(uint, t, i); }
MC_INLINE floatv gather_float(global const float *t, uintv i) { return GATHER(float, t, i); }

#endif
