/* sampler_points.cl — the uniforms a sampler back end gives, for inspection
 * and tests: coordinates 0 .. DIM-1 of samples first .. first + n - 1 of
 * stream RNG_STREAM_SAMPLE, as integrate/integrate.cl draws them (how = 0,
 * one sampler_next_nd) or one at a time (how = 1, sampler_next_1d) or in
 * pairs (how = 2, sampler_next_2d); a back end must give the same numbers
 * all three ways.  Built with LANES=1, DIM and the back end's -D options
 * (samplers/sampler.cl); a lane build has sampler_points_at instead. */
#include "samplers/sampler.cl"

#if LANES == 1
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
#else
/* Lanes at different samples and dimensions, as the render's packets draw: lane l of packet i
 * draws sample index[LANES i + l] from dimension dim[LANES i + l] on (a multiple of 4), `count`
 * coordinates (2: sampler_next_2d; 4 or 8: one sampler_next_nd) into
 * out[(count i + a) LANES + l], a < count (the lane builds). */
kernel void sampler_points_at(global const ulong *index, global const uint *dim, uint count, ulong seed,
                              global float *out) {
    const uint i = get_global_id(0);
    mc_sampler_t s = sampler_start(seed, MC_CAT(vload, LANES)(i, index), RNG_STREAM_SAMPLE);
    sampler_seek(&s, MC_CAT(vload, LANES)(i, dim));
    floatv u[8];
    if (count == 2u) {
        sampler_next_2d(&s, u);
    } else if (count == 4u) {
        sampler_next_nd(&s, 4, u);
    } else {
        sampler_next_nd(&s, 8, u);
    }
    for (uint a = 0; a < count; ++a) MC_CAT(vstore, LANES)(u[a], (size_t)i * count + a, out);
}
#endif
