/* envmap_test.cl — the environment map exposed to the tests (render/envmap.cl):
 * directions drawn by envmap_sample with their reported density, the density
 * envmap_pdf gives the same directions, and the radiance of given
 * directions.  Outputs are structure of arrays (component c of item i at c * n + i). */
#include "samplers/sampler.cl"
#include "render/lane_io.cl"
#include "render/envmap.cl"

/* out: d.xyz, pdf (sampling), pdf (evaluated at d), radiance.rgb (8 components) */
kernel void envmap_samples(global const float4 *env_map, global const uint *env_cdf, ulong seed, uint n,
                           global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    const envmap_t m = envmap_of(env_map, env_cdf);
    mc_sampler_t smp = sampler_start(seed, to_ulongv((uintv)(base) + LANE_IOTA), RNG_STREAM_LIGHT_TEST);
    floatv u[2];
    sampler_next_2d(&smp, u);
    intv all = (intv)(0) == (intv)(0);
    floatv pdf;
    vec3v d = envmap_sample(&m, u[0], u[1], &pdf);
    vec3v le = envmap_radiance(&m, d, all);
    floatv comp[8] = {d.x, d.y, d.z, pdf, envmap_pdf(&m, d, all), le.x, le.y, le.z};
    for (int c = 0; c < 8; ++c) store_floatv(comp[c], out + c * n + base);
}

/* For unit directions dirs (3 components): pdf, radiance.rgb (4 components) */
kernel void envmap_eval(global const float4 *env_map, global const uint *env_cdf, uint n, global const float *dirs,
                        global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    const envmap_t m = envmap_of(env_map, env_cdf);
    vec3v d = v3(load_floatv(dirs + 0 * n + base), load_floatv(dirs + 1 * n + base), load_floatv(dirs + 2 * n + base));
    intv all = (intv)(0) == (intv)(0);
    vec3v le = envmap_radiance(&m, d, all);
    floatv comp[4] = {envmap_pdf(&m, d, all), le.x, le.y, le.z};
    for (int c = 0; c < 4; ++c) store_floatv(comp[c], out + c * n + base);
}
