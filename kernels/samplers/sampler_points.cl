/* sampler_points.cl — the uniforms a sampler back end gives, for inspection
 * and tests: coordinates 0 .. DIM-1 of samples first .. first + n - 1 of
 * stream RNG_STREAM_SAMPLE, as integrate/integrate.cl draws them (how = 0,
 * one sampler_next_nd) or one at a time (how = 1, sampler_next_1d) or in
 * pairs (how = 2, sampler_next_2d); a back end must give the same numbers
 * all three ways.  Built with LANES=1, DIM and the back end's -D options
 * (samplers/sampler.cl). */
#include "samplers/sampler.cl"

kernel void sampler_points(ulong first, uint n, ulong seed, uint how, global float *out) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    float u[DIM + 1];
    mc_sampler_t s = sampler_start(seed, first + i, RNG_STREAM_SAMPLE);
    if (how == 0u) {
        sampler_next_nd(&s, DIM, u);
    } else if (how == 1u) {
        for (uint a = 0; a < DIM; ++a) u[a] = sampler_next_1d(&s);
    } else {
        for (uint a = 0; a < DIM; a += 2) sampler_next_2d(&s, u + a);
    }
    for (uint a = 0; a < DIM; ++a) out[(ulong)i * DIM + a] = u[a];
}
