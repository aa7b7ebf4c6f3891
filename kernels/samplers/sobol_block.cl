/* sobol_block.cl — integrate.cl's per-block shortcut for the Sobol' back end
 * (samplers/sobol_sampler.cl): what every packet of a block shares, computed
 * once per block.
 *
 * A block of integrate.cl is nunits <= UNITS_PER_BLOCK consecutive units of
 * one design, starting at unit0 (a multiple of UNITS_PER_BLOCK), and with the
 * Sobol' back end a design is one replicate of DESIGN_UNITS = 2^SOBOL_LOG2_POINTS
 * points, unit u of the design being point u.  Hence, for the packet of units
 * unit0 + k + lane (k a multiple of LANES, lane < LANES):
 *   - every lane of every packet has the same replicate, so the same
 *     scrambling seeds: one Philox call per four coordinates per block
 *     instead of per packet (sobol_seed_block);
 *   - unit0, k and lane have disjoint bits (UNITS_PER_BLOCK and LANES are
 *     powers of two), so by the linearity of step 1 over GF(2) the reversed
 *     Sobol' coordinate is x(unit0) ^ x(k) ^ x(lane): x(unit0) once per block,
 *     x(k) per packet over the set bits of k alone (at most
 *     log2(UNITS_PER_BLOCK / LANES) of them, instead of a loop over all
 *     SOBOL_LOG2_POINTS bits of the point), x(lane) as in
 *     sobol_reversed_packet.
 * The coordinates, seeds and uniforms are bit for bit those of
 * sampler_start_at + sampler_next_nd (or sampler_next_nd_d) on the same
 * sample indices, the path the other kernels keep using.  Lanes past the
 * block's last unit get other numbers, as they are never used (integrate.cl
 * masks them out).
 */
#ifndef MCOCL_SOBOL_BLOCK_CL
#define MCOCL_SOBOL_BLOCK_CL

#include "samplers/sobol_sampler.cl"

#if (UNITS_PER_BLOCK & (UNITS_PER_BLOCK - 1)) != 0 || UNITS_PER_BLOCK % LANES != 0
#error "sobol_block.cl: UNITS_PER_BLOCK must be a power of two and a multiple of LANES"
#endif
#if DESIGN_UNITS != (1ul << SOBOL_LOG2_POINTS)
#error "sobol_block.cl: a design must be one replicate of 2^SOBOL_LOG2_POINTS points"
#endif
#if NCOORD > SOBOL_TABLE_DIMS
#error "sobol_block.cl: every coordinate must be in the Sobol' table"
#endif

typedef struct {
    uint seed[NCOORD]; /* the scrambling seed of each coordinate in this block's replicate */
    uint base[NCOORD]; /* the reversed Sobol' coordinate of the block's first point, x(unit0) */
} sobol_block_t;

/* The block of design (= replicate) `design` starting at unit0 of it. */
MC_INLINE void sobol_block_init(sobol_block_t *b, ulong seed, ulong design, ulong unit0) {
    for (uint j = 0; j < NCOORD; j += 4u) {
        /* rng_block's counter and key (rng/uniform.cl) with the replicate as the index */
        const uint4 w = philox4x32_10_1((uint4)((uint)design, (uint)(design >> 32), j >> 2, RNG_STREAM_SAMPLE),
                                        (uint)(seed & 0xffffffffu), (uint)(seed >> 32));
        b->seed[j] = w.x;
        if (j + 1u < NCOORD) b->seed[j + 1u] = w.y;
        if (j + 2u < NCOORD) b->seed[j + 2u] = w.z;
        if (j + 3u < NCOORD) b->seed[j + 3u] = w.w;
    }
    for (uint j = 0; j < NCOORD; ++j) b->base[j] = sobol_reversed1((uint)unit0, j);
}

/* The scrambled bits of coordinate j of the packet whose first unit is
 * unit0 + k (k a multiple of LANES, below DESIGN_UNITS). */
MC_INLINE uintv sobol_block_bits(const sobol_block_t *b, uint k, uint j) {
    constant uint *rv = SOBOL_RV + 32u * j;
    uint xh = b->base[j];
    for (uint h = k >> SOBOL_LANE_BITS; h != 0u; h &= h - 1u) xh ^= rv[SOBOL_LANE_BITS + 31 - clz(h & (0u - h))];
    uintv x = (uintv)(xh);
    for (int t = 0; t < SOBOL_LANE_BITS && t < SOBOL_LOG2_POINTS; ++t)
        x ^= (uintv)(rv[t]) & ((uintv)(0u) - ((LANE_IOTA >> t) & 1u));
    return owen_bits(x, (uintv)(b->seed[j]));
}

/* The uniforms of that packet, coordinates 0 .. NCOORD-1: u01 (float) or
 * u01d (double), as sampler_next_nd and sampler_next_nd_d. */
MC_INLINE void sobol_block_uniforms(const sobol_block_t *b, uint k, floatv *u) {
    for (uint j = 0; j < NCOORD; ++j) u[j] = u01(sobol_block_bits(b, k, j));
}

MC_INLINE void sobol_block_uniforms_d(const sobol_block_t *b, uint k, doublev *u) {
    for (uint j = 0; j < NCOORD; ++j) u[j] = u01d(sobol_block_bits(b, k, j));
}

#endif
