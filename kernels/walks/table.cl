/* table.cl — sampling the walk's tabulated piecewise-constant densities.
 *
 * A table is a density over NB = 2^k bins of the cube [0,1]^DIM, each bin a
 * box of side 1/nya (nya bins per axis, NB = nya^DIM, bin index = row-major
 * digits, axis 0 most significant), quantised to counts out of 2^23 and
 * stored as an alias table (Walker 1977, Vose 1991; built by
 * mcocl/walks/tabulate.py) followed by the counts:
 *     tab[base + c]       = threshold_c * NB + alias_c   (column c, c < NB)
 *     tab[base + NB + b]  = counts_b                     (sum = 2^23)
 * A 23-bit uniform integer picks column c = top k bits and keeps column c
 * when the remaining bits are below the threshold, else takes its alias.
 * With the uniforms' own 23-bit grid (rng/uniform.cl) bin b is chosen with
 * probability exactly counts_b / 2^23, the mass the returned pdf reports,
 * so f/p stays unbiased whatever the tabulation.
 *
 * Unlike sampling/piecewise.cl the table differs from lane to lane: the
 * transition density of a walk depends on the cell of its current vertex, so
 * every lane reads its own table (a per-lane base offset into one buffer).
 * Two reads per sample, no search: the log2(NB)-step CDF search this
 * replaced was half the time of a subcritical walk.
 */
#ifndef MCOCL_WALK_TABLE_CL
#define MCOCL_WALK_TABLE_CL

#include "rng/uniform.cl"
#include "sampling/gather.cl"
#include "lanes.cl"

/* Sample the table at `base` (NB = 2^k bins) with the uniform ub (bin) and
 * ux[0..DIM-1] (position inside the bin's box); writes y and returns p(y). */
MC_INLINE floatv wt_sample(global const uint *tab, uintv base, uint nya, uint nb, uint k, floatv ub,
                        const floatv *ux, floatv *y) {
    const uintv c = lane_min_u(to_uintv_rtz(ub * (float)UNIFORM_CELLS), (uintv)(UNIFORM_CELLS - 1u));
    const uintv col = c >> ((uint)UNIFORM_GRID_BITS - k);
    const uintv rest = c & (uintv)((UNIFORM_CELLS >> k) - 1u);
    const uintv word = gather_uint(tab, base + col);
    const uintv b = lane_select(word & (uintv)(nb - 1u), col, rest < (word >> k));
    const floatv cnt = to_floatv(gather_uint(tab, base + nb + b));
    uintv left = b;
    const float inv = 1.0f / (float)nya;
    for (int d = DIM - 1; d >= 0; --d) {
        const uintv digit = left % (uintv)(nya);
        left = left / (uintv)(nya);
        y[d] = lane_open01((to_floatv(digit) + ux[d]) * inv);
    }
    return cnt * (UNIFORM_CELL_WIDTH * (float)nb);
}

/* The cell (of nxa per axis, row-major) holding the point x. */
MC_INLINE uintv wt_cell(const floatv *x, uint nxa) {
    uintv c = (uintv)(0u);
    for (int d = 0; d < DIM; ++d)
        c = c * nxa + lane_min_u(to_uintv_rtz(x[d] * (float)nxa), (uintv)(nxa - 1u));
    return c;
}

#endif
