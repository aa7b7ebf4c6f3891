/* philox.cl — Philox4x32-10, the counter-based generator of Salmon et al.,
 * "Parallel random numbers: as easy as 1, 2, 3" (SC'11), as specified by
 * Random123.  Counter-based means the numbers of a sample depend on
 * (key, counter) alone: no state to carry, split or merge, so any index range
 * can be computed by any device in any order and give the same bits.
 *
 * The engine's convention (see rng/uniform.cl):
 *   key     = (seed low 32 bits, seed high 32 bits)
 *   counter = (sample index low, sample index high, dimension / 4, stream)
 * Word (dimension % 4) of the output is the dimension's uint32.
 *
 * Written over lane types (lanes.cl): with LANES=16 one call generates the
 * blocks of 16 samples at once.  The 32x32->64 high multiply is written out by
 * hand through a 64-bit product: PoCL's wheel does not inline mul_hi(), which
 * made it about 9x slower (docs/pocl-notes.md).
 */
#ifndef MCOCL_PHILOX_CL
#define MCOCL_PHILOX_CL

#include "lanes.cl"

#define PHILOX_M0 0xD2511F53u
#define PHILOX_M1 0xCD9E8D57u
#define PHILOX_W0 0x9E3779B9u /* golden ratio */
#define PHILOX_W1 0xBB67AE85u /* sqrt(3) - 1 */

typedef struct {
    uintv v0, v1, v2, v3;
} philox_ctr;

MC_INLINE uintv philox_mulhi(uint m, uintv a) {
    return to_uintv((to_ulongv(a) * (ulong)m) >> 32);
}

/* One Philox round: two multiplies, a swap and the key xor (Random123
 * philox4x32round). */
#define PHILOX_ROUND(c0, c1, c2, c3, k0, k1)              \
    do {                                                  \
        uintv hi0_ = philox_mulhi(PHILOX_M0, c0);         \
        uintv lo0_ = (c0) * PHILOX_M0;                    \
        uintv hi1_ = philox_mulhi(PHILOX_M1, c2);         \
        uintv lo1_ = (c2) * PHILOX_M1;                    \
        c0 = hi1_ ^ (c1) ^ (k0);                          \
        c1 = lo1_;                                        \
        c2 = hi0_ ^ (c3) ^ (k1);                          \
        c3 = lo0_;                                        \
    } while (0)

/* Philox4x32 with 10 rounds; the key is bumped by the Weyl constants between
 * rounds.  The key is uniform across lanes (one seed per launch). */
MC_INLINE philox_ctr philox4x32_10(philox_ctr c, uint k0, uint k1) {
    uintv c0 = c.v0, c1 = c.v1, c2 = c.v2, c3 = c.v3;
    PHILOX_ROUND(c0, c1, c2, c3, k0, k1); k0 += PHILOX_W0; k1 += PHILOX_W1;
    PHILOX_ROUND(c0, c1, c2, c3, k0, k1); k0 += PHILOX_W0; k1 += PHILOX_W1;
    PHILOX_ROUND(c0, c1, c2, c3, k0, k1); k0 += PHILOX_W0; k1 += PHILOX_W1;
    PHILOX_ROUND(c0, c1, c2, c3, k0, k1); k0 += PHILOX_W0; k1 += PHILOX_W1;
    PHILOX_ROUND(c0, c1, c2, c3, k0, k1); k0 += PHILOX_W0; k1 += PHILOX_W1;
    PHILOX_ROUND(c0, c1, c2, c3, k0, k1); k0 += PHILOX_W0; k1 += PHILOX_W1;
    PHILOX_ROUND(c0, c1, c2, c3, k0, k1); k0 += PHILOX_W0; k1 += PHILOX_W1;
    PHILOX_ROUND(c0, c1, c2, c3, k0, k1); k0 += PHILOX_W0; k1 += PHILOX_W1;
    PHILOX_ROUND(c0, c1, c2, c3, k0, k1); k0 += PHILOX_W0; k1 += PHILOX_W1;
    PHILOX_ROUND(c0, c1, c2, c3, k0, k1);
    philox_ctr r;
    r.v0 = c0; r.v1 = c1; r.v2 = c2; r.v3 = c3;
    return r;
}

/* The same function on one counter, in scalar registers: for words every
 * lane shares (a Sobol' replicate's scrambling seeds), one call instead of
 * LANES.  Gives the words of philox4x32_10 bit for bit. */
MC_INLINE uint4 philox4x32_10_1(uint4 c, uint k0, uint k1) {
    for (int r = 0; r < 10; ++r) {
        const ulong p0 = (ulong)c.x * (ulong)PHILOX_M0, p1 = (ulong)c.z * (ulong)PHILOX_M1;
        c = (uint4)((uint)(p1 >> 32) ^ c.y ^ k0, (uint)p1, (uint)(p0 >> 32) ^ c.w ^ k1, (uint)p0);
        k0 += PHILOX_W0;
        k1 += PHILOX_W1;
    }
    return c;
}

#endif
