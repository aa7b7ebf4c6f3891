/* rng_api.cl — kernels behind mcocl.rng: the raw generator and the uniforms
 * of the engine's addressing (drawn through the sampler, as every estimator
 * draws them), exposed so that tests and users can check the numbers any
 * estimator sees.  Built with LANES=1. */
#include "samplers/sampler.cl"

/* Philox4x32-10 of arbitrary (counter, key) pairs: the known-answer test. */
kernel void philox_raw(global const uint4 *ctr, global const uint2 *key, global uint4 *out) {
    size_t i = get_global_id(0);
    philox_ctr c;
    uint4 v = ctr[i];
    c.v0 = v.x; c.v1 = v.y; c.v2 = v.z; c.v3 = v.w;
    uint2 k = key[i];
    philox_ctr r = philox4x32_10(c, k.x, k.y);
    out[i] = (uint4)(r.v0, r.v1, r.v2, r.v3);
}

/* u[i * dims + j] = uniform of sample first + i, dimension j, in `stream`. */
kernel void uniforms(ulong first, ulong seed, uint stream, uint dims, global float *out) {
    size_t i = get_global_id(0);
    mc_sampler_t s = sampler_start(seed, first + i, stream);
    for (uint j = 0; j < dims; ++j) out[i * dims + j] = sampler_next_1d(&s);
}

/* The uint32 -> (0, 1) conversion of arbitrary bit patterns (extremes included). */
kernel void unit_floats(global const uint *bits, global float *out) {
    size_t i = get_global_id(0);
    out[i] = u01(bits[i]);
}

/* The sampler's group draws against its one-by-one draws, for sample first + i
 * from dimension `start` on: out[(i * 3 + g) * SAMPLER_DRAWS + j] is dimension
 * start + j drawn by sampler_next_1d (g = 0), by sampler_next_2d pairs (g = 1)
 * and by one sampler_next_nd (g = 2). */
#define SAMPLER_DRAWS 6
kernel void sampler_draws(ulong first, ulong seed, uint stream, uint start, global float *out) {
    size_t i = get_global_id(0);
    float u[3][SAMPLER_DRAWS];
    mc_sampler_t s = sampler_start(seed, first + i, stream);
    sampler_seek(&s, start);
    for (int j = 0; j < SAMPLER_DRAWS; ++j) u[0][j] = sampler_next_1d(&s);
    s = sampler_start(seed, first + i, stream);
    sampler_seek(&s, start);
    for (int j = 0; j < SAMPLER_DRAWS; j += 2) sampler_next_2d(&s, u[1] + j);
    s = sampler_start(seed, first + i, stream);
    sampler_seek(&s, start);
    sampler_next_nd(&s, SAMPLER_DRAWS, u[2]);
    for (int g = 0; g < 3; ++g)
        for (int j = 0; j < SAMPLER_DRAWS; ++j) out[(i * 3 + g) * SAMPLER_DRAWS + j] = u[g][j];
}
