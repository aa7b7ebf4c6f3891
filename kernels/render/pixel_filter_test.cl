/* pixel_filter_test.cl — the pixel filter's sampling exposed to the tests
 * (tests/test_pixel_filter.py): offsets from the pixel centre drawn by
 * filter_offset (render/pixel_filter.cl) for the chi-square test against the
 * filter, built with the same -DPIXEL_FILTER options as the render kernel.
 * Work-item k handles items k*LANES ... */
#include "samplers/sampler.cl"
#include "render/lane_io.cl"
#include "render/pixel_filter.cl"

/* The offsets of given uniforms u[i] (for the test of the inverse CDF's accuracy). */
kernel void filter_offsets_of(uint n, global const float *u, global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    store_floatv(filter_offset(load_floatv(u + base)), out + base);
}

kernel void filter_offsets(ulong seed, uint n, global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    mc_sampler_t smp = sampler_start(seed, to_ulongv((uintv)(base) + LANE_IOTA), RNG_STREAM_BSDF_TEST);
    floatv u[1];
    sampler_next_nd(&smp, 1, u);
    store_floatv(film_coordinate((floatv)(0.0f), u[0]) - 0.5f, out + base);
}
