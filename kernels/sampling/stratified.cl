/* stratified.cl — jittered stratification of the unit cube (lecture:
 * "Vzorkování po částech").
 *
 * A design has H = m^d strata, the cube split into m equal slabs per axis.
 * Stratum h has base-m digits (c_0, ..., c_{d-1}), c_j = floor(h / m^j) mod m,
 * and a sample in it is x_j = (c_j + u_j) / m with u_j uniform.  The engine
 * puts TWO independent samples in every stratum: then
 *     I_strat = 1/(2H) sum_h (f_h1 + f_h2),
 *     Var(I_strat) = 1/H^2 sum_h sigma_h^2 / 2,
 * and (f_h1 - f_h2)^2 / 2 is an unbiased estimate of sigma_h^2, so
 *     Var_hat = sum_h (f_h1 - f_h2)^2 / (4 H^2)
 * is an unbiased estimate of the variance of the stratified estimator itself
 * (the plain sample variance of f would ignore the stratification and
 * overstate the error).
 *
 * Digits are extracted in double precision (exact for h < 2^52 after a +-1
 * correction): vector integer division does not exist on x86.
 */
#ifndef MCOCL_STRATIFIED_CL
#define MCOCL_STRATIFIED_CL

#include "sampling/unit_interval.cl"

/* cell[j] = digit j of h in base m, as doubles. */
MC_INLINE void stratum_cells(uintv h, int d, double m, double inv_m, doublev *cell) {
    doublev rest = to_doublev(h);
    for (int j = 0; j < d; ++j) {
        doublev q = lane_floor_nonneg_d(rest * inv_m);
        doublev r = rest - q * m;
        /* the product rest * inv_m may land one below or above an integer */
        const doublev hi = lane_indicator_d(r >= m), lo = lane_indicator_d(r < 0.0);
        r += (lo - hi) * m;
        q += hi - lo;
        cell[j] = r;
        rest = q;
    }
}

#endif
