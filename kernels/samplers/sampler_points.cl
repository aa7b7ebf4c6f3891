/* sampler_points.cl — the uniforms a sampler back end gives, for inspection
 * and tests: coordinates 0 .. DIM-1 of samples first .. first + n - 1 of
 * stream RNG_STREAM_SAMPLE, exactly as integrate/integrate.cl draws them.
 * Built with LANES=1, DIM and the back end's -D options (samplers/sampler.cl). */
#include "samplers/sampler.cl"

kernel void sampler_points(ulong first, uint n, ulong seed, global float *out) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    float u[DIM];
    mc_sampler_t s = sampler_start(seed, first + i, RNG_STREAM_SAMPLE);
    sampler_next_nd(&s, DIM, u);
    for (uint a = 0; a < DIM; ++a) out[(ulong)i * DIM + a] = u[a];
}
