/* table.cl — sampling the walk's tabulated piecewise-constant densities.
 *
 * A table is a CDF over NB bins of the cube [0,1]^DIM, each bin a box of
 * side 1/nya (nya bins per axis, NB = nya^DIM, bin index = row-major digits,
 * axis 0 most significant), stored as cumulative counts out of 2^23 like
 * sampling/piecewise.cl (cum[0] = 0, cum[NB] = 2^23).  With the CDF on the
 * uniforms' own 23-bit grid, bin b is chosen with probability exactly
 * (cum[b+1] - cum[b]) / 2^23, which is the mass the returned pdf reports, so
 * f/p stays unbiased whatever the tabulation (pbrt-v4 §A.4 for the idea).
 *
 * Unlike piecewise.cl the table differs from lane to lane: the transition
 * density of a walk depends on the cell of its current vertex, so every lane
 * searches its own CDF (a per-lane base offset into one buffer).  The box is
 * flattened to one index, so one binary search serves every dimension.
 */
#ifndef MCOCL_WALK_TABLE_CL
#define MCOCL_WALK_TABLE_CL

#include "sampling/gather.cl"
#include "sampling/unit_interval.cl"

#define WT_TOTAL 8388608.0f /* 2^23 */
#define WT_INV_TOTAL 0x1p-23f

#if LANES == 1
#define as_floatv(v) as_float(v)
#else
#define as_floatv(v) MC_CAT(as_float, LANE_SUFFIX)(v)
#endif

/* Largest b in [0, nb-1] with cum[base + b] <= c; top = largest power of 2 <= nb. */
inline uintv wt_find(global const uint *tab, uintv base, uint nb, uint top, uintv c) {
    uintv b = (uintv)(0u);
    for (uint step = top; step > 0u; step >>= 1) {
        uintv cand = b + step;
        uintv safe = min(cand, (uintv)(nb - 1u));
        intv take = (cand < (uintv)(nb)) & (gather_uint(tab, base + safe) <= c);
        b = select(b, cand, take);
    }
    return b;
}

/* Sample the table at `base` with the uniform ub (bin) and ux[0..DIM-1]
 * (position inside the bin's box); writes y and returns the density p(y). */
inline floatv wt_sample(global const uint *tab, uintv base, uint nya, uint nb, uint top, floatv ub,
                        const floatv *ux, floatv *y) {
    uintv c = min(to_uintv_rtz(ub * WT_TOTAL), (uintv)(8388607u));
    uintv b = wt_find(tab, base, nb, top, c);
    floatv cnt = to_floatv(gather_uint(tab, base + b + 1u) - gather_uint(tab, base + b));
    uintv rem = b;
    const float inv = 1.0f / (float)nya;
    for (int k = DIM - 1; k >= 0; --k) {
        uintv d = rem % (uintv)(nya);
        rem = rem / (uintv)(nya);
        y[k] = clamp_open01((to_floatv(d) + ux[k]) * inv);
    }
    return cnt * (WT_INV_TOTAL * (float)nb);
}

/* The cell (of nxa per axis, row-major) holding the point x. */
inline uintv wt_cell(const floatv *x, uint nxa) {
    uintv c = (uintv)(0u);
    for (int k = 0; k < DIM; ++k)
        c = c * nxa + min(to_uintv_rtz(x[k] * (float)nxa), (uintv)(nxa - 1u));
    return c;
}

#endif
