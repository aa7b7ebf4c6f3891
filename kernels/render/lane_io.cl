/* lane_io.cl — moving lane vectors to and from memory.
 *
 * - store_floatv / load_floatv: whole vectors to and from structure-of-arrays
 *   buffers (component c of item i at c * n + i);
 * - gather_rec4: every lane's record of 4 floats from an
 *   array of records, loaded as whole float4s and transposed into lane
 *   vectors.  Scalar gathers (one insert per lane per float) cost several
 *   instructions per float; a record load costs one per four floats plus a
 *   shuffle network the compiler builds.
 */
#ifndef MCOCL_RENDER_LANE_IO_CL
#define MCOCL_RENDER_LANE_IO_CL

#include "lanes.cl"

#if LANES == 1
#define store_floatv(v, p) (*(p) = (v))
#define load_floatv(p) (*(p))
#else
#define store_floatv(v, p) MC_CAT(vstore, LANE_SUFFIX)((v), 0, (p))
#define load_floatv(p) MC_CAT(vload, LANE_SUFFIX)(0, (p))
#endif

/* A record of 4 floats per lane: a[i] = t[idx][i] (lanes must hold valid indices). */
typedef struct {
    floatv x, y, z, w;
} rec4v;

#if LANES == 1
MC_INLINE rec4v gather_rec4(global const float4 *t, uintv idx) {
    float4 r = t[idx];
    rec4v o;
    o.x = r.x; o.y = r.y; o.z = r.z; o.w = r.w;
    return o;
}
#elif LANES == 4
MC_INLINE rec4v gather_rec4(global const float4 *t, uintv idx) {
    float4 r0 = t[idx.s0], r1 = t[idx.s1], r2 = t[idx.s2], r3 = t[idx.s3];
    rec4v o;
    o.x = (float4)(r0.x, r1.x, r2.x, r3.x);
    o.y = (float4)(r0.y, r1.y, r2.y, r3.y);
    o.z = (float4)(r0.z, r1.z, r2.z, r3.z);
    o.w = (float4)(r0.w, r1.w, r2.w, r3.w);
    return o;
}
#elif LANES == 8
MC_INLINE rec4v gather_rec4(global const float4 *t, uintv idx) {
    float4 r0 = t[idx.s0], r1 = t[idx.s1], r2 = t[idx.s2], r3 = t[idx.s3];
    float4 r4 = t[idx.s4], r5 = t[idx.s5], r6 = t[idx.s6], r7 = t[idx.s7];
    rec4v o;
    o.x = (float8)(r0.x, r1.x, r2.x, r3.x, r4.x, r5.x, r6.x, r7.x);
    o.y = (float8)(r0.y, r1.y, r2.y, r3.y, r4.y, r5.y, r6.y, r7.y);
    o.z = (float8)(r0.z, r1.z, r2.z, r3.z, r4.z, r5.z, r6.z, r7.z);
    o.w = (float8)(r0.w, r1.w, r2.w, r3.w, r4.w, r5.w, r6.w, r7.w);
    return o;
}
#elif LANES == 16
MC_INLINE rec4v gather_rec4(global const float4 *t, uintv idx) {
    float4 r0 = t[idx.s0], r1 = t[idx.s1], r2 = t[idx.s2], r3 = t[idx.s3];
    float4 r4 = t[idx.s4], r5 = t[idx.s5], r6 = t[idx.s6], r7 = t[idx.s7];
    float4 r8 = t[idx.s8], r9 = t[idx.s9], ra = t[idx.sa], rb = t[idx.sb];
    float4 rc = t[idx.sc], rd = t[idx.sd], re = t[idx.se], rf = t[idx.sf];
    rec4v o;
    o.x = (float16)(r0.x, r1.x, r2.x, r3.x, r4.x, r5.x, r6.x, r7.x, r8.x, r9.x, ra.x, rb.x, rc.x, rd.x, re.x, rf.x);
    o.y = (float16)(r0.y, r1.y, r2.y, r3.y, r4.y, r5.y, r6.y, r7.y, r8.y, r9.y, ra.y, rb.y, rc.y, rd.y, re.y, rf.y);
    o.z = (float16)(r0.z, r1.z, r2.z, r3.z, r4.z, r5.z, r6.z, r7.z, r8.z, r9.z, ra.z, rb.z, rc.z, rd.z, re.z, rf.z);
    o.w = (float16)(r0.w, r1.w, r2.w, r3.w, r4.w, r5.w, r6.w, r7.w, r8.w, r9.w, ra.w, rb.w, rc.w, rd.w, re.w, rf.w);
    return o;
}
#else
MC_INLINE rec4v gather_rec4(global const float4 *t, uintv idx) {
    uint_lanes iu;
    iu.v = idx;
    float_lanes x, y, z, w;
    for (int k = 0; k < LANES; ++k) {
        float4 r = t[iu.a[k]];
        x.a[k] = r.x; y.a[k] = r.y; z.a[k] = r.z; w.a[k] = r.w;
    }
    rec4v o;
    o.x = x.v; o.y = y.v; o.z = z.v; o.w = w.v;
    return o;
}
#endif

#endif
