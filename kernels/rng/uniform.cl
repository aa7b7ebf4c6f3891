/* uniform.cl — the engine's random numbers: which Philox counter a sample's
 * dimension uses, and how 32 random bits become a float in (0, 1).  This is
 * the one place where Philox counters are built (rng_block) and where the
 * uniform grid is defined (UNIFORM_*, u01); estimators draw through
 * samplers/sampler.cl, and the stream tags are registered in rng/streams.cl.
 *
 * Addressing.  Sample index i (64-bit), dimension j, seed s (64-bit) and a
 * stream tag t (which consumer, rng/streams.cl):
 *     Philox4x32-10( counter = (lo32(i), hi32(i), j / 4, t),
 *                    key     = (lo32(s), hi32(s)) )  word j % 4
 * so the numbers of (s, i, j, t) depend on nothing else: not the device, not
 * the work-group size, not how indices were split into launches.
 *
 * Conversion.  u = (floor(b / 2^9) + 1/2) * 2^-23: the top 23 bits pick one of
 * 2^23 equal cells of [0, 1) and u is the cell's centre.  Hence
 *   - u is never 0 nor 1: the extremes are 2^-24 and 1 - 2^-24, both exact
 *     floats, so inverse CDFs may take log(u), log(1 - u) and 1/u;
 *   - u is unbiased: E[u] = 1/2 exactly, and every cell has the same mass.
 * Truncation (b * 2^-32) would instead bias every coordinate low by half a
 * cell and can return 0 (docs/pocl-notes.md, "Known bias trap").
 * Only 23 bits are used because 24 bits plus the half-cell offset would need
 * a 25-bit significand.  Tabulated densities (sampling/piecewise.cl,
 * walks/table.cl) quantise their masses to the same UNIFORM_CELLS cells, so a
 * uniform picks a bin with exactly the probability the pdf reports.
 */
#ifndef MCOCL_UNIFORM_CL
#define MCOCL_UNIFORM_CL

#include "rng/philox.cl"
#include "rng/streams.cl"

/* The uniform grid: UNIFORM_CELLS equal cells of [0, 1), u = cell centre. */
#define UNIFORM_GRID_BITS 23
#define UNIFORM_CELLS 8388608u     /* 2^UNIFORM_GRID_BITS */
#define UNIFORM_CELL_WIDTH 0x1p-23f /* 1 / UNIFORM_CELLS */

/* Who a sample is: its 64-bit index, the seed (Philox key) and the stream. */
typedef struct {
    uintv lo, hi;   /* sample index, split in two 32-bit words */
    uint k0, k1;    /* seed */
    uint stream;
} rng_t;

MC_INLINE rng_t rng_init(ulongv index, ulong seed, uint stream) {
    rng_t r;
    r.lo = to_uintv(index & (ulong)0xffffffffu);
    r.hi = to_uintv(index >> 32);
    r.k0 = (uint)(seed & 0xffffffffu);
    r.k1 = (uint)(seed >> 32);
    r.stream = stream;
    return r;
}

/* The samples base + offset (per lane) without 64-bit lane arithmetic: the
 * low word carries into the high one exactly when it wraps below the offset. */
MC_INLINE rng_t rng_init_offset(ulong base, uintv offset, ulong seed, uint stream) {
    rng_t r;
    r.lo = (uintv)((uint)base) + offset;
    r.hi = (uintv)((uint)(base >> 32)) + to_uintv(mask_bit(r.lo < offset));
    r.k0 = (uint)(seed & 0xffffffffu);
    r.k1 = (uint)(seed >> 32);
    r.stream = stream;
    return r;
}

/* The four 32-bit words of dimensions 4*block .. 4*block + 3 (block per lane). */
MC_INLINE philox_ctr rng_block(rng_t r, uintv block) {
    philox_ctr c;
    c.v0 = r.lo;
    c.v1 = r.hi;
    c.v2 = block;
    c.v3 = (uintv)(r.stream);
    return philox4x32_10(c, r.k0, r.k1);
}

/* Word w (0..3, per lane) of a Philox block. */
MC_INLINE uintv philox_word(philox_ctr c, uintv w) {
    return lane_select(lane_select(c.v0, c.v1, w == 1u), lane_select(c.v2, c.v3, w == 3u), w >= 2u);
}

/* 32 random bits -> cell centre in (0, 1); see the header for why. */
MC_INLINE floatv u01(uintv bits) {
    return (to_floatv(bits >> (32 - UNIFORM_GRID_BITS)) + 0.5f) * UNIFORM_CELL_WIDTH;
}

/* 32 random bits -> cell centre of the 2^-32 grid, in double: the uniforms
 * of precision="double" integration (sampler_next_nd_d).  All 32 bits count
 * (a double holds b + 1/2 exactly), so the extremes are 2^-33 and 1 - 2^-33
 * and E[u] = 1/2 exactly, as for u01. */
#define UNIFORM_CELL_WIDTH_D 0x1p-32
MC_INLINE doublev u01d(uintv bits) { return (to_doublev(bits) + 0.5) * UNIFORM_CELL_WIDTH_D; }

#endif
