/* refine_zero.cl — integration uniforms with the float resolution near 0 that
 * singular integrands need (issue 12, part 3).
 *
 * The uniform grid (rng/uniform.cl) puts u at cell centres of width 2^-23, so
 * the smallest uniform is 2^-24.  For an integrand singular at 0 the whole
 * first cell [0, 2^-23) is then represented by its centre: for x^-1/2 that is
 * a relative bias of (2 - sqrt 2) sqrt(2^-23) / 2 = -1e-4, far above the
 * stderr of a long run.  A float can hold much smaller numbers, so a uniform
 * that lands in the first cell is refined: the cell is split again into 2^23
 * cells and u becomes the centre of a uniformly chosen one, and so on while
 * the choice is again the first cell, REFINE_LEVELS times (down to 2^-116, a
 * normal float).  Each level replaces a cell by the centres of its equal
 * sub-cells, so E[u] stays 1/2 and every cell of the 2^23 grid keeps its
 * mass: tabulated densities still pick their bins exactly.  Near 1 nothing can
 * be done in float (the spacing below 1 is 2^-24): the README tells users to
 * put a singularity at 0 (substitute 1 - x).
 *
 * The refining words come from their own stream (RNG_STREAM_REFINE), one
 * Philox block of four words per (sample, coordinate), so the uniforms of
 * every other cell are unchanged and the extra work happens only for packets
 * where some lane is in the first cell (probability about LANES * 2^-23).
 */
#ifndef MCOCL_REFINE_ZERO_CL
#define MCOCL_REFINE_ZERO_CL

#include "rng/uniform.cl"

#define REFINE_LEVELS 4                   /* one Philox block: four 32-bit words */
#define UNIFORM_FIRST_CENTRE 0x1p-24f     /* u01 of a word whose top 23 bits are 0 */

/* One level: the word's cell centre scaled into the parent cell, or (when the
 * word picks the first sub-cell again) the deeper level's value. */
MC_INLINE floatv refine_level(uintv word, float parent_width, floatv deeper) {
    return lane_select(deeper, u01(word) * parent_width, (word >> (32 - UNIFORM_GRID_BITS)) != 0u);
}

/* u, refined where it is the first cell's centre; r addresses the sample
 * (its stream is replaced by RNG_STREAM_REFINE), coord is its coordinate. */
MC_INLINE floatv refine_first_cell(floatv u, rng_t r, uint coord) {
    const intv first = u == (floatv)(UNIFORM_FIRST_CENTRE);
    if (!lane_any(first)) return u;
    r.stream = RNG_STREAM_REFINE;
    const philox_ctr c = rng_block(r, (uintv)(coord));
    floatv fine = u01(c.v3) * 0x1p-92f; /* the deepest level: a plain cell centre */
    fine = refine_level(c.v2, 0x1p-69f, fine);
    fine = refine_level(c.v1, 0x1p-46f, fine);
    fine = refine_level(c.v0, 0x1p-23f, fine);
    return lane_select(u, fine, first);
}

/* Refine coordinates 0 .. n-1 of one sample (or packet) in place. */
MC_INLINE void refine_first_cells(floatv *u, int n, rng_t r) {
    for (int j = 0; j < n; ++j) u[j] = refine_first_cell(u[j], r, (uint)j);
}

/* The same for precision="double" uniforms (u01d: the 2^-32 grid, first
 * centre 2^-33): four nested levels of 32 bits each, down to 2^-160. */
MC_INLINE doublev refine_level_d(uintv word, double parent_width, doublev deeper) {
    return lane_select(deeper, u01d(word) * parent_width, to_longv(word != 0u));
}

MC_INLINE doublev refine_first_cell_d(doublev u, rng_t r, uint coord) {
    const longv first = u == (doublev)(0x1p-33);
    if (!lane_any(to_intv(first))) return u;
    r.stream = RNG_STREAM_REFINE;
    const philox_ctr c = rng_block(r, (uintv)(coord));
    doublev fine = u01d(c.v3) * 0x1p-96;
    fine = refine_level_d(c.v2, 0x1p-64, fine);
    fine = refine_level_d(c.v1, 0x1p-32, fine);
    fine = refine_level_d(c.v0, 1.0, fine);
    return lane_select(u, fine * 0x1p-32, first);
}

MC_INLINE void refine_first_cells_d(doublev *u, int n, rng_t r) {
    for (int j = 0; j < n; ++j) u[j] = refine_first_cell_d(u[j], r, (uint)j);
}

#endif
