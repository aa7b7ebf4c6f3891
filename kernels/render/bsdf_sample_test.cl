/* bsdf_sample_test.cl — BSDF queries exposed to the tests: draw directions
 * with bsdf_sample (for the chi-square goodness-of-fit test) and evaluate
 * f cos / pdf at given directions (to integrate the pdf over the test's
 * bins).  Built with any LANES; work-item k handles items k*LANES ...
 * Outputs are structure of arrays: component c of item i at c * n + i. */
#include "samplers/sampler.cl"
#include "render/bsdf.cl"
#include "render/lane_io.cl"

/* out: wo.xyz, pdf, weight.rgb, delta, eta (9 components) */
kernel void bsdf_sample_dirs(global const float4 *mats, float4 wi4, ulong seed, uint n, global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    material_v m = material_load(mats, (uintv)(0u));
    vec3v wi = v3((floatv)(wi4.x), (floatv)(wi4.y), (floatv)(wi4.z));
    mc_sampler_t smp = sampler_start(seed, to_ulongv((uintv)(base) + LANE_IOTA), RNG_STREAM_BSDF_TEST);
    floatv u[3];
    sampler_next_nd(&smp, 3, u);
    bsdf_sample_v s = bsdf_sample(&m, wi, u[0], u[1], u[2], TRANSPORT_RADIANCE);
    store_floatv(s.wo.x, out + 0 * n + base);
    store_floatv(s.wo.y, out + 1 * n + base);
    store_floatv(s.wo.z, out + 2 * n + base);
    store_floatv(s.pdf, out + 3 * n + base);
    store_floatv(s.weight.x, out + 4 * n + base);
    store_floatv(s.weight.y, out + 5 * n + base);
    store_floatv(s.weight.z, out + 6 * n + base);
    store_floatv(to_floatv(mask_bit(s.delta)), out + 7 * n + base);
    store_floatv(s.eta, out + 8 * n + base);
}

/* wo: x, y, z components (3 n); out: (f cos).rgb, pdf (4 components) */
kernel void bsdf_eval_dirs(global const float4 *mats, float4 wi4, uint n, global const float *wo, global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    material_v m = material_load(mats, (uintv)(0u));
    vec3v wi = v3((floatv)(wi4.x), (floatv)(wi4.y), (floatv)(wi4.z));
    vec3v o = v3(load_floatv(wo + 0 * n + base), load_floatv(wo + 1 * n + base), load_floatv(wo + 2 * n + base));
    floatv pdf;
    vec3v f = bsdf_eval(&m, wi, o, &pdf);
    store_floatv(f.x, out + 0 * n + base);
    store_floatv(f.y, out + 1 * n + base);
    store_floatv(f.z, out + 2 * n + base);
    store_floatv(pdf, out + 3 * n + base);
}
