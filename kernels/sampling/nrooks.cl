/* nrooks.cl — N-rooks (Latin hypercube) designs with permutations computed
 * on the device (lecture: "vzorkování N věží").
 *
 * A design of n points puts exactly one point in each of the n slabs of every
 * axis: x_kj = (pi_j(k) + u_kj) / n with pi_j a random permutation of
 * [0, n), independent across axes and designs.  pi_j is a keyed bijection of
 * [0, 2^w) (2^w >= n) restricted to [0, n) by cycle walking: apply it again
 * until the value falls below n.  Since it is a bijection of [0, 2^w), walking
 * from a start below n returns below n before it could revisit the start, so
 * the restriction is a bijection of [0, n).  O(1) memory, no host shuffle.
 *
 * The bijection is a few rounds of invertible steps on w-bit words: xor or
 * add a key, multiply by an odd constant (invertible mod 2^w), xorshift right
 * by s >= 1 (invertible).  The 4 round keys of (seed, design, axis) come from
 * Philox (stream RNG_STREAM_PERMUTATION, rng/streams.cl), so permutations of
 * different axes and designs are independent.  They are hashes, not sample
 * coordinates: they come from rng/uniform.cl whatever the sampler back end.
 */
#ifndef MCOCL_NROOKS_CL
#define MCOCL_NROOKS_CL

#include "rng/uniform.cl"

typedef struct {
    uint k0, k1, k2, k3;
} perm_key;

/* Round keys of the permutation of `axis` in `design`. */
MC_INLINE perm_key nrooks_key(ulong seed, ulong design, uint axis) {
    const philox_ctr r = rng_block(rng_init((ulongv)(design), seed, RNG_STREAM_PERMUTATION), (uintv)(axis));
#if LANES == 1
    perm_key k = {r.v0, r.v1, r.v2, r.v3};
#else
    perm_key k = {r.v0.s0, r.v1.s0, r.v2.s0, r.v3.s0};
#endif
    return k;
}

/* One application of the keyed bijection of [0, mask + 1). */
MC_INLINE uintv nrooks_mix(uintv x, uint mask, uint s1, uint s2, perm_key k) {
    x = (x ^ (k.k0 & mask)) & mask;
    x = (x * 0x2C1B3C6Du) & mask;
    x ^= x >> s1;
    x = (x + k.k1) & mask;
    x = (x * 0x297A2D39u) & mask;
    x ^= x >> s2;
    x = (x ^ (k.k2 & mask)) & mask;
    x = (x * 0x9E3779B1u) & mask;
    x ^= x >> s1;
    x = (x + k.k3) & mask;
    x = (x * 0x85EBCA77u) & mask;
    x ^= x >> s2;
    return x;
}

/* pi(i) for i < n, a permutation of [0, n); mask = 2^w - 1 >= n - 1. */
MC_INLINE uintv nrooks_permute(uintv i, uint n, uint mask, uint s1, uint s2, perm_key k) {
    uintv x = nrooks_mix(i, mask, s1, s2, k);
    intv out = x >= (uintv)(n);
    while (lane_any(out)) {
        x = lane_select(x, nrooks_mix(x, mask, s1, s2, k), out);
        out = x >= (uintv)(n);
    }
    return x;
}

#endif
