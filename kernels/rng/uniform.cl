/* uniform.cl — the engine's random numbers: which Philox counter a sample's
 * dimension uses, and how 32 random bits become a float in (0, 1).
 *
 * Addressing.  Sample index i (64-bit), dimension j, seed s (64-bit) and a
 * stream tag t (which consumer: integration, jitter, light sampling, ...):
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
 * a 25-bit significand.
 */
#ifndef MCOCL_UNIFORM_CL
#define MCOCL_UNIFORM_CL

#include "rng/philox.cl"

/* Stream tags: independent families of numbers for the same sample index. */
#define RNG_STREAM_SAMPLE 0u   /* the sample's own coordinates */
#define RNG_STREAM_JITTER 1u   /* stratum jitter */
#define RNG_STREAM_AUX 2u      /* roulette, technique choice, ... */

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

/* The samples base + stride * lane of a packet, without 64-bit lane arithmetic
 * (the low word can carry at most once within a packet). */
MC_INLINE rng_t rng_init_packet(ulong base, uint stride, ulong seed, uint stream) {
    rng_t r;
    uint lo0 = (uint)base;
    r.lo = (uintv)(lo0) + stride * LANE_IOTA;
    r.hi = (uintv)((uint)(base >> 32)) + to_uintv(mask_bit(r.lo < (uintv)(lo0)));
    r.k0 = (uint)(seed & 0xffffffffu);
    r.k1 = (uint)(seed >> 32);
    r.stream = stream;
    return r;
}

/* The four 32-bit words of dimensions 4*block .. 4*block + 3. */
MC_INLINE philox_ctr rng_block(rng_t r, uint block) {
    philox_ctr c;
    c.v0 = r.lo;
    c.v1 = r.hi;
    c.v2 = (uintv)(block);
    c.v3 = (uintv)(r.stream);
    return philox4x32_10(c, r.k0, r.k1);
}

/* 32 random bits -> cell centre in (0, 1); see the header for why. */
MC_INLINE floatv u01(uintv bits) {
    return (to_floatv(bits >> 9) + 0.5f) * 0x1p-23f;
}

/* 64 random bits -> cell centre in (0, 1) in double precision (52-bit cells). */
MC_INLINE doublev u01d(uintv hi, uintv lo) {
    ulongv b = (to_ulongv(hi) << 20) | to_ulongv(lo >> 12);
    return (to_doublev(b) + 0.5) * 0x1p-52;
}

/* One uniform of dimension `dim`; costs a whole Philox call, so prefer
 * rng_block when several consecutive dimensions are needed. */
MC_INLINE floatv rng_uniform(rng_t r, uint dim) {
    philox_ctr c = rng_block(r, dim >> 2);
    uint w = dim & 3u;
    return u01(w == 0u ? c.v0 : w == 1u ? c.v1 : w == 2u ? c.v2 : c.v3);
}

/* Fill u[0 .. n-1] with dimensions first .. first+n-1 (first % 4 == 0). */
MC_INLINE void rng_uniforms(rng_t r, uint first, int n, floatv *u) {
    for (int j = 0; j < n; j += 4) {
        philox_ctr c = rng_block(r, (first >> 2) + (uint)(j >> 2));
        u[j] = u01(c.v0);
        if (j + 1 < n) u[j + 1] = u01(c.v1);
        if (j + 2 < n) u[j + 2] = u01(c.v2);
        if (j + 3 < n) u[j + 3] = u01(c.v3);
    }
}

#endif
