/* pixel_filter_test.cl — the pixel filter's sampling exposed to the tests
 * (tests/test_pixel_filter.py): offsets from the pixel centre drawn by
 * filter_offset (render/pixel_filter.cl) for the chi-square test against the
 * filter, built with the same options as the render kernel (-DPIXEL_FILTER_SHAPED
 * for a tent or a Gaussian) and given the filter's kind, radius and stddev as
 * the render kernel takes them from render_params.
 * Work-item k handles items k*LANES ... */
#include "samplers/sampler.cl"
#include "render/lane_io.cl"
#include "render/pixel_filter.cl"

/* The offsets of given uniforms u[i] (for the test of the inverse CDF's accuracy). */
kernel void filter_offsets_of(int kind, float radius, float stddev, uint n, global const float *u, global float *out) {
    const pixel_filter f = {kind, radius, stddev};
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    store_floatv(filter_offset(&f, load_floatv(u + base)), out + base);
}

kernel void filter_offsets(int kind, float radius, float stddev, ulong seed, uint n, global float *out) {
    const pixel_filter f = {kind, radius, stddev};
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    mc_sampler_t smp = sampler_start(seed, to_ulongv((uintv)(base) + LANE_IOTA), RNG_STREAM_BSDF_TEST);
    floatv u[1];
    sampler_next_nd(&smp, 1, u);
    store_floatv(film_coordinate(&f, (floatv)(0.0f), u[0]) - 0.5f, out + base);
}
