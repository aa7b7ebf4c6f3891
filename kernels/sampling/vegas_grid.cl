/* vegas_grid.cl — the VEGAS map (Lepage 1978, J. Comput. Phys. 27, 192): a
 * separable piecewise-constant density on [0, 1]^DIM, applied to the uniforms
 * of a sample, and the training sums from which the host refines it
 * (mcocl/integration/vegas.py).
 *
 * Each dimension d has VEGAS_BINS bins of equal probability 1/VEGAS_BINS;
 * bin b spans [e_db, e_db + w_db) of x.  The inverse CDF of uniform u is
 *     y = u * VEGAS_BINS,  b = floor(y),  x = e_db + (y - b) w_db,
 * so x has density 1 / (VEGAS_BINS w_db) in bin b, and the Jacobian of the
 * whole map is J = prod_d VEGAS_BINS w_db: E[f(x) J] = integral of f.
 * VEGAS_BINS is a power of two, so y is exact on the uniforms' 2^-23 grid.
 *
 * The grid buffer holds DIM * VEGAS_BINS bin starts e, then as many widths w
 * (float; the host rounds the edges once and takes widths from the rounded
 * edges, so the bins tile [0, 1]).
 *
 * Training: for every valid sample, (f J)^2 is added to row[d * VEGAS_BINS + b_d]
 * for each d — per dimension, the sum over the samples in a bin of the
 * squared weighted value (Lepage 1978: the bin weights before smoothing).  A
 * work-item owns its row of one block and adds the samples in unit order,
 * lane by lane, so the sums do not depend on the lane width.
 */
#ifndef MCOCL_VEGAS_GRID_CL
#define MCOCL_VEGAS_GRID_CL

#include "sampling/gather.cl"
#include "sampling/unit_interval.cl"

#define VEGAS_ROW (DIM * VEGAS_BINS)

/* Map the uniforms tau[0 .. DIM-1] through the grid in place; the bin of each
 * coordinate goes to bin[d]; returns the Jacobian J. */
MC_INLINE floatv vegas_warp(floatv *tau, global const float *grid, uintv *bin) {
    floatv jac = (floatv)(1.0f);
    for (uint d = 0; d < DIM; ++d) {
        const floatv y = tau[d] * (float)VEGAS_BINS;
        const uintv b = lane_min_u(to_uintv_rtz(y), (uintv)(VEGAS_BINS - 1u));
        const uintv i = b + (uintv)(d * VEGAS_BINS);
        const floatv e = gather_float(grid, i);
        const floatv w = gather_float(grid + VEGAS_ROW, i);
        tau[d] = clamp_open01(e + (y - to_floatv(b)) * w);
        jac *= (float)VEGAS_BINS * w;
        bin[d] = b;
    }
    return jac;
}

/* Zero the training row of one block. */
MC_INLINE void vegas_train_clear(global double *row) {
    for (uint i = 0; i < VEGAS_ROW; ++i) row[i] = 0.0;
}

/* Add v^2 of every lane (v = f J, 0 in invalid lanes) to the bins its
 * coordinates fell in: lane 0 first, and within a lane the `count` (1 or 2:
 * the two samples of a stratum) values in order, so the order of the adds is
 * the order of the samples whatever the lane width. */
MC_INLINE void vegas_train_add_n(global double *row, int count, const uintv *bin0, floatv v0,
                                 const uintv *bin1, floatv v1) {
#if LANES == 1
    const double w0 = (double)v0 * (double)v0;
    for (uint d = 0; d < DIM; ++d) row[d * VEGAS_BINS + bin0[d]] += w0;
    if (count > 1) {
        const double w1 = (double)v1 * (double)v1;
        for (uint d = 0; d < DIM; ++d) row[d * VEGAS_BINS + bin1[d]] += w1;
    }
#else
    float vl[2][LANES];
    uint bl[2][DIM][LANES];
    MC_CAT(vstore, LANE_SUFFIX)(v0, 0, vl[0]);
    MC_CAT(vstore, LANE_SUFFIX)(v1, 0, vl[1]);
    for (uint d = 0; d < DIM; ++d) {
        MC_CAT(vstore, LANE_SUFFIX)(bin0[d], 0, bl[0][d]);
        MC_CAT(vstore, LANE_SUFFIX)(bin1[d], 0, bl[1][d]);
    }
    for (int l = 0; l < LANES; ++l) {
        for (int t = 0; t < count; ++t) {
            const double w = (double)vl[t][l] * (double)vl[t][l];
            for (uint d = 0; d < DIM; ++d) row[d * VEGAS_BINS + bl[t][d][l]] += w;
        }
    }
#endif
}

/* One sample per lane. */
MC_INLINE void vegas_train_add(global double *row, const uintv *bin, floatv v) {
    vegas_train_add_n(row, 1, bin, v, bin, v);
}

/* The two samples of a stratum per lane. */
MC_INLINE void vegas_train_add_pair(global double *row, const uintv *bin0, floatv v0, const uintv *bin1, floatv v1) {
    vegas_train_add_n(row, 2, bin0, v0, bin1, v1);
}

#endif
