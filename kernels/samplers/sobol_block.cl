/* sobol_block.cl — the scrambled Sobol' points of sampler="sobol" integration
 * (integrate/integrate.cl), computed per block, with one of two scramblings
 * (SOBOL_SCRAMBLE_LINEAR, the host's ``scrambling``):
 *
 * 0 ("hash", the default): the Laine-Karras hash of samplers/sobol_sampler.cl,
 *   bit for bit the numbers of sampler_start_at + sampler_next_nd (or _d) on
 *   the same sample indices, the path walks, renders and the other kernels use.
 * 1 ("linear"): random linear (matrix) scrambling with a digital shift
 *   (Matoušek 1998, "On the L2-discrepancy for anchored boxes", J. Complexity
 *   14; the scrambling of scipy.stats.qmc.Sobol): coordinate j of replicate r is
 *       y = M x ^ e
 *   with x the 32-bit Sobol' coordinate (most significant bit first), M a
 *   random nonsingular lower-triangular matrix over GF(2) (output digit i is
 *   digit i of x plus a random combination of the digits above it) and e a
 *   random shift, both drawn per (seed, replicate, coordinate): 32 Philox
 *   words from RNG_STREAM_SOBOL_SCRAMBLE (rng/streams.cl).  Like nested
 *   uniform scrambling it keeps the (t, m, s)-net property of every 2^m-point
 *   block and makes each point uniform on the 2^-32 grid; Owen (2003,
 *   "Variance with alternative scramblings of digital nets", ACM TOMACS
 *   13(4)) shows its variance is that of nested uniform scrambling.  The hash
 *   randomises the low-order digits less well: at 2^20 points its median
 *   error on smooth Genz integrands was 10-30x that of this scrambling
 *   (README, "Quasi-Monte Carlo").
 *
 * Cost.  A block of integrate.cl is nunits <= UNITS_PER_BLOCK consecutive
 * units of one design, starting at unit0 (a multiple of UNITS_PER_BLOCK); a
 * design is one replicate of DESIGN_UNITS = 2^SOBOL_LOG2_POINTS points, unit
 * u being point u.  So every packet of a block has the same scrambling (its
 * seeds, or M and e, are drawn once per block), and, the Sobol' coordinate
 * being linear over GF(2) in the point's bits, the packet of units
 * unit0 + k + lane (k a multiple of LANES; the three have disjoint bits) has
 * x = x(unit0) ^ x(k) ^ x(lane): x(unit0) once per block, x(k) over the set
 * bits of k alone, x(lane) as in sobol_reversed_packet.  M being linear too,
 * the linear scrambling keeps y(unit0) = M x(unit0) ^ e and the scrambled
 * direction numbers M V_k of the SOBOL_BLOCK_BITS bits that vary in a block,
 * and needs no hash and no bit reversal per sample.  The numbers depend on
 * (seed, replicate, point, coordinate) alone, not on LANES, the work-group
 * size or the launch split.  Lanes past the block's last unit get numbers
 * that are never used (integrate.cl masks them out).
 */
#ifndef MCOCL_SOBOL_BLOCK_CL
#define MCOCL_SOBOL_BLOCK_CL

#include "samplers/sobol_sampler.cl"

#ifndef SOBOL_SCRAMBLE_LINEAR
#define SOBOL_SCRAMBLE_LINEAR 0
#endif
#define SOBOL_BLOCK_BITS 12 /* log2 of the largest UNITS_PER_BLOCK: the point bits that vary in a block */

#if (UNITS_PER_BLOCK & (UNITS_PER_BLOCK - 1)) != 0 || UNITS_PER_BLOCK % LANES != 0
#error "sobol_block.cl: UNITS_PER_BLOCK must be a power of two and a multiple of LANES"
#endif
#if UNITS_PER_BLOCK > (1 << SOBOL_BLOCK_BITS)
#error "sobol_block.cl: UNITS_PER_BLOCK must be at most 2^SOBOL_BLOCK_BITS"
#endif
#if DESIGN_UNITS != (1ul << SOBOL_LOG2_POINTS)
#error "sobol_block.cl: a design must be one replicate of 2^SOBOL_LOG2_POINTS points"
#endif
#if NCOORD > SOBOL_TABLE_DIMS
#error "sobol_block.cl: every coordinate must be in the Sobol' table"
#endif

#if SOBOL_SCRAMBLE_LINEAR
typedef struct {
    uint base[NCOORD];                   /* y(unit0) = M x(unit0) ^ e of each coordinate */
    uint dir[NCOORD * SOBOL_BLOCK_BITS]; /* M V_k, k < SOBOL_BLOCK_BITS (0 past SOBOL_LOG2_POINTS) */
} sobol_block_t;

MC_INLINE uint sobol_reverse1(uint x) {
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
    return (x >> 16) | (x << 16);
}

/* M x: column b of M (what input bit b adds) is bit b itself plus random bits below it. */
MC_INLINE uint sobol_lms_apply(const uint *col, uint x) {
    uint y = 0u;
    for (int b = 0; b < 32; ++b) y ^= col[b] & (0u - ((x >> b) & 1u));
    return y;
}

/* The block of design (= replicate) `design` starting at unit0 of it. */
MC_INLINE void sobol_block_init(sobol_block_t *blk, ulong seed, ulong design, ulong unit0) {
    for (uint j = 0; j < NCOORD; ++j) {
        uint w[32];
        for (uint t = 0; t < 8u; ++t) {
            const uint4 q = philox4x32_10_1((uint4)((uint)design, (uint)(design >> 32), 8u * j + t,
                                                    RNG_STREAM_SOBOL_SCRAMBLE),
                                            (uint)(seed & 0xffffffffu), (uint)(seed >> 32));
            w[4u * t] = q.x; w[4u * t + 1u] = q.y; w[4u * t + 2u] = q.z; w[4u * t + 3u] = q.w;
        }
        uint col[32];
        col[0] = 1u;
        for (int b = 1; b < 32; ++b) col[b] = (1u << b) | (w[b] & ((1u << b) - 1u));
        /* direction numbers most significant bit first (the table holds them reversed) */
        constant uint *rv = SOBOL_RV + 32u * j;
        uint x0 = 0u;
        for (int k = 0; k < SOBOL_LOG2_POINTS; ++k)
            if ((unit0 >> k) & 1ul) x0 ^= rv[k];
        blk->base[j] = sobol_lms_apply(col, sobol_reverse1(x0)) ^ w[0];
        for (int k = 0; k < SOBOL_BLOCK_BITS; ++k)
            blk->dir[SOBOL_BLOCK_BITS * j + (uint)k] = k < SOBOL_LOG2_POINTS ? sobol_lms_apply(col, sobol_reverse1(rv[k])) : 0u;
    }
}

/* The scrambled 32 bits of coordinate j of the packet whose first unit is
 * unit0 + k (k a multiple of LANES, below DESIGN_UNITS). */
MC_INLINE uintv sobol_block_bits(const sobol_block_t *blk, uint k, uint j) {
    const uint *dir = blk->dir + SOBOL_BLOCK_BITS * j;
    uint yh = blk->base[j];
    for (uint h = k >> SOBOL_LANE_BITS; h != 0u; h &= h - 1u) yh ^= dir[SOBOL_LANE_BITS + 31 - clz(h & (0u - h))];
    uintv y = (uintv)(yh);
    for (int t = 0; t < SOBOL_LANE_BITS; ++t) y ^= (uintv)(dir[t]) & ((uintv)(0u) - ((LANE_IOTA >> t) & 1u));
    return y;
}

#else /* the hash */

typedef struct {
    uint seed[NCOORD]; /* the scrambling seed of each coordinate in this block's replicate */
    uint base[NCOORD]; /* the reversed Sobol' coordinate of the block's first point, x(unit0) */
} sobol_block_t;

/* The block of design (= replicate) `design` starting at unit0 of it. */
MC_INLINE void sobol_block_init(sobol_block_t *blk, ulong seed, ulong design, ulong unit0) {
    for (uint j = 0; j < NCOORD; j += 4u) {
        /* rng_block's counter and key (rng/uniform.cl) with the replicate as the index */
        const uint4 w = philox4x32_10_1((uint4)((uint)design, (uint)(design >> 32), j >> 2, RNG_STREAM_SAMPLE),
                                        (uint)(seed & 0xffffffffu), (uint)(seed >> 32));
        blk->seed[j] = w.x;
        if (j + 1u < NCOORD) blk->seed[j + 1u] = w.y;
        if (j + 2u < NCOORD) blk->seed[j + 2u] = w.z;
        if (j + 3u < NCOORD) blk->seed[j + 3u] = w.w;
    }
    for (uint j = 0; j < NCOORD; ++j) blk->base[j] = sobol_reversed1((uint)unit0, j);
}

/* The scrambled 32 bits of coordinate j of the packet whose first unit is
 * unit0 + k (k a multiple of LANES, below DESIGN_UNITS). */
MC_INLINE uintv sobol_block_bits(const sobol_block_t *blk, uint k, uint j) {
    constant uint *rv = SOBOL_RV + 32u * j;
    uint xh = blk->base[j];
    for (uint h = k >> SOBOL_LANE_BITS; h != 0u; h &= h - 1u) xh ^= rv[SOBOL_LANE_BITS + 31 - clz(h & (0u - h))];
    uintv x = (uintv)(xh);
    for (int t = 0; t < SOBOL_LANE_BITS && t < SOBOL_LOG2_POINTS; ++t)
        x ^= (uintv)(rv[t]) & ((uintv)(0u) - ((LANE_IOTA >> t) & 1u));
    return owen_bits(x, (uintv)(blk->seed[j]));
}

#endif

/* The uniforms of that packet, coordinates 0 .. NCOORD-1, on the grids of
 * sampler_next_nd (u01, float) and sampler_next_nd_d (u01d, double). */
MC_INLINE void sobol_block_uniforms(const sobol_block_t *blk, uint k, floatv *u) {
    for (uint j = 0; j < NCOORD; ++j) u[j] = u01(sobol_block_bits(blk, k, j));
}

MC_INLINE void sobol_block_uniforms_d(const sobol_block_t *blk, uint k, doublev *u) {
    for (uint j = 0; j < NCOORD; ++j) u[j] = u01d(sobol_block_bits(blk, k, j));
}

#endif
