/* philox_sampler.cl — the sampler back end of independent uniforms
 * (samplers/sampler.cl): dimension j of sample i in stream t is word j % 4 of
 * Philox4x32-10(counter = (lo32(i), hi32(i), j / 4, t), key = seed), converted
 * to the uniform grid (rng/uniform.cl).  The numbers of (seed, i, j, t)
 * depend on nothing else: not the device, the lane, nor the launch split.
 */
#ifndef MCOCL_PHILOX_SAMPLER_CL
#define MCOCL_PHILOX_SAMPLER_CL

#include "rng/uniform.cl"

typedef struct {
    rng_t rng;  /* which sample: index, seed, stream */
    uintv dim;  /* the next dimension, per lane */
} mc_sampler_t;

MC_INLINE mc_sampler_t sampler_start(ulong seed, ulongv index, uint stream) {
    mc_sampler_t s;
    s.rng = rng_init(index, seed, stream);
    s.dim = (uintv)(0u);
    return s;
}

MC_INLINE mc_sampler_t sampler_start_at(ulong seed, ulong base, uintv offset, uint stream) {
    mc_sampler_t s;
    s.rng = rng_init_offset(base, offset, seed, stream);
    s.dim = (uintv)(0u);
    return s;
}

MC_INLINE void sampler_seek(mc_sampler_t *s, uintv dim) { s->dim = dim; }

/* Dimension j is word j % 4 of Philox block j / 4: one Philox call. */
MC_INLINE floatv sampler_next_1d(mc_sampler_t *s) {
    const philox_ctr c = rng_block(s->rng, s->dim >> 2);
    const uintv w = s->dim & 3u;
    s->dim += 1u;
    return u01(lane_select(lane_select(c.v0, c.v1, w == 1u), lane_select(c.v2, c.v3, w == 3u), w >= 2u));
}

/* n consecutive dimensions.  When the counter is a multiple of 4 in every
 * lane (as every present consumer arranges, rng/streams.cl, and the compiler
 * can usually prove) they take one Philox call per four dimensions; else one
 * call each. */
MC_INLINE void sampler_next_nd(mc_sampler_t *s, int n, floatv *u) {
    if (lane_any((s->dim & 3u) != 0u)) {
        for (int j = 0; j < n; ++j) u[j] = sampler_next_1d(s);
        return;
    }
    const uintv block = s->dim >> 2;
    for (int j = 0; j < n; j += 4) {
        const philox_ctr c = rng_block(s->rng, block + (uint)(j >> 2));
        u[j] = u01(c.v0);
        if (j + 1 < n) u[j + 1] = u01(c.v1);
        if (j + 2 < n) u[j + 2] = u01(c.v2);
        if (j + 3 < n) u[j + 3] = u01(c.v3);
    }
    s->dim += (uint)n;
}

/* sampler_next_nd in double (u01d: all 32 bits of each word), for
 * precision="double" integration; the words are those of sampler_next_nd. */
MC_INLINE void sampler_next_nd_d(mc_sampler_t *s, int n, doublev *u) {
    if (lane_any((s->dim & 3u) != 0u)) {
        for (int j = 0; j < n; ++j) {
            const uintv d = s->dim + (uint)j;
            u[j] = u01d(philox_word(rng_block(s->rng, d >> 2), d & 3u));
        }
        s->dim += (uint)n;
        return;
    }
    const uintv block = s->dim >> 2;
    for (int j = 0; j < n; j += 4) {
        const philox_ctr c = rng_block(s->rng, block + (uint)(j >> 2));
        u[j] = u01d(c.v0);
        if (j + 1 < n) u[j + 1] = u01d(c.v1);
        if (j + 2 < n) u[j + 2] = u01d(c.v2);
        if (j + 3 < n) u[j + 3] = u01d(c.v3);
    }
    s->dim += (uint)n;
}

/* Two consecutive dimensions: one Philox call when the counter is even in
 * every lane (the pair is words 0-1 or 2-3 of one block). */
MC_INLINE void sampler_next_2d(mc_sampler_t *s, floatv *u) {
    if (lane_any((s->dim & 1u) != 0u)) {
        u[0] = sampler_next_1d(s);
        u[1] = sampler_next_1d(s);
        return;
    }
    const philox_ctr c = rng_block(s->rng, s->dim >> 2);
    const intv upper = (s->dim & 2u) != 0u;
    u[0] = u01(lane_select(c.v0, c.v2, upper));
    u[1] = u01(lane_select(c.v1, c.v3, upper));
    s->dim += 2u;
}

MC_INLINE mc_sampler_t sampler_select(mc_sampler_t a, mc_sampler_t b, intv m) {
    a.rng.lo = lane_select(a.rng.lo, b.rng.lo, m);
    a.rng.hi = lane_select(a.rng.hi, b.rng.hi, m);
    a.dim = lane_select(a.dim, b.dim, m);
    return a;
}

#endif
