/* piecewise.cl — tabulated piecewise-constant densities on [0, 1] and
 * [0, 1]^2, sampled by inverting their CDF (pbrt-v4 §A.4, PiecewiseConstant1D
 * and PiecewiseConstant2D: marginal over the first axis, then the conditional
 * row).
 *
 * Tables are cumulative counts out of 2^23, the resolution of the engine's
 * uniforms (rng/uniform.cl): cum[0] = 0, cum[nbins] = 2^23, bin b has mass
 * (cum[b+1] - cum[b]) / 2^23.  The host quantises the user's weights so that
 * every bin with positive weight keeps at least one count; with the CDF on
 * the uniforms' own grid, the probability of choosing a bin is exactly the
 * mass the pdf reports, and the estimate f/p stays unbiased whatever the
 * rounding.  The position inside the bin reuses the fraction of u (so
 * stratification of u carries over), uniform within the bin.
 */
#ifndef MCOCL_PIECEWISE_CL
#define MCOCL_PIECEWISE_CL

#include "rng/uniform.cl"
#include "sampling/gather.cl"
#include "sampling/unit_interval.cl"

#define PC_TOTAL ((float)UNIFORM_CELLS)
#define PC_INV_TOTAL UNIFORM_CELL_WIDTH

/* Largest b in [0, nbins - 1] with cum[b] <= c; `top` = largest power of 2 <= nbins. */
MC_INLINE uintv pc_find(global const uint *cum, uint nbins, uint top, uintv c) {
    uintv b = (uintv)(0u);
    for (uint step = top; step > 0u; step >>= 1) {
        uintv cand = b + step;
        uintv safe = lane_min_u(cand, (uintv)(nbins - 1u));
        intv take = (cand < (uintv)(nbins)) & (gather_uint(cum, safe) <= c);
        b = lane_select(b, cand, take);
    }
    return b;
}

/* (b + frac) / n rounded to float may land in a neighbouring bin; move x by one
 * float towards bin b so that the bin a pdf lookup finds at x is the bin that
 * was sampled (sampling and evaluation must agree for combined estimators). */
MC_INLINE floatv pc_keep_in_bin(floatv x, uintv b, uint nbins) {
    uintv bx = to_uintv_rtz(x * (float)nbins);
    return lane_step_positive(x, bx < b, bx > b);
}

/* Sample a 1-D table; returns x and writes its bin mass in *mass (probability, not density). */
MC_INLINE floatv pc1_sample_mass(global const uint *cum, uint nbins, uint top, floatv u, floatv *mass) {
    floatv t = u * PC_TOTAL;
    uintv c = lane_min_u(to_uintv_rtz(t), (uintv)(UNIFORM_CELLS - 1u));
    uintv b = pc_find(cum, nbins, top, c);
    uintv lo = gather_uint(cum, b);
    uintv hi = gather_uint(cum, b + 1u);
    floatv cnt = to_floatv(hi - lo);
    floatv frac = lane_clamp((t - to_floatv(lo)) / cnt, 0.0f, ONE_MINUS_EPS);
    *mass = cnt * PC_INV_TOTAL;
    return pc_keep_in_bin(clamp_open01((to_floatv(b) + frac) / (float)nbins), b, nbins);
}

/* The bin of x and its mass. */
MC_INLINE floatv pc1_mass(global const uint *cum, uint nbins, floatv x) {
    uintv b = lane_min_u(to_uintv_rtz(x * (float)nbins), (uintv)(nbins - 1u));
    return to_floatv(gather_uint(cum, b + 1u) - gather_uint(cum, b)) * PC_INV_TOTAL;
}

MC_INLINE floatv pc1_warp(global const uint *cum, uint nbins, uint top, floatv u, floatv *pdf) {
    floatv mass;
    floatv x = pc1_sample_mass(cum, nbins, top, u, &mass);
    *pdf = mass * (float)nbins;
    return x;
}

MC_INLINE floatv pc1_pdf(global const uint *cum, uint nbins, floatv x) {
    return pc1_mass(cum, nbins, x) * (float)nbins;
}

/* 2-D: `marg` has na + 1 entries (marginal over the first axis), `cond` holds
 * na rows of nb + 1 entries (the conditional of the second axis given the row). */
MC_INLINE void pc2_warp(global const uint *marg, global const uint *cond, uint na, uint topa, uint nb, uint topb,
                     floatv ua, floatv ub, floatv *xa, floatv *xb, floatv *pdf) {
    floatv ma;
    *xa = pc1_sample_mass(marg, na, topa, ua, &ma);
    uintv row = lane_min_u(to_uintv_rtz(*xa * (float)na), (uintv)(na - 1u));
    /* sample the conditional of that row: gather through a per-lane row offset */
    floatv t = ub * PC_TOTAL;
    uintv c = lane_min_u(to_uintv_rtz(t), (uintv)(UNIFORM_CELLS - 1u));
    uintv base = row * (nb + 1u);
    uintv b = (uintv)(0u);
    for (uint step = topb; step > 0u; step >>= 1) {
        uintv cand = b + step;
        uintv safe = lane_min_u(cand, (uintv)(nb - 1u));
        intv take = (cand < (uintv)(nb)) & (gather_uint(cond, base + safe) <= c);
        b = lane_select(b, cand, take);
    }
    uintv lo = gather_uint(cond, base + b);
    uintv hi = gather_uint(cond, base + b + 1u);
    floatv cnt = to_floatv(hi - lo);
    floatv frac = lane_clamp((t - to_floatv(lo)) / cnt, 0.0f, ONE_MINUS_EPS);
    *xb = pc_keep_in_bin(clamp_open01((to_floatv(b) + frac) / (float)nb), b, nb);
    *pdf = ma * cnt * PC_INV_TOTAL * (float)na * (float)nb;
}

MC_INLINE floatv pc2_pdf(global const uint *marg, global const uint *cond, uint na, uint nb, floatv xa, floatv xb) {
    uintv row = lane_min_u(to_uintv_rtz(xa * (float)na), (uintv)(na - 1u));
    uintv col = lane_min_u(to_uintv_rtz(xb * (float)nb), (uintv)(nb - 1u));
    uintv base = row * (nb + 1u);
    floatv ma = to_floatv(gather_uint(marg, row + 1u) - gather_uint(marg, row));
    floatv mb = to_floatv(gather_uint(cond, base + col + 1u) - gather_uint(cond, base + col));
    return ma * mb * (PC_INV_TOTAL * PC_INV_TOTAL) * (float)na * (float)nb;
}

#endif
