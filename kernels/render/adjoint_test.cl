/* adjoint_test.cl — the adjoint queries exposed to the tests: light rays
 * drawn by sample_emitter_ray (render/lights_emit.cl), the camera's
 * importance and raster position of given directions (render/camera.cl), and
 * BSDF samples in both transport modes (render/bsdf.cl).
 * Outputs are structure of arrays (component c of item i at c * n + i). */
#include "samplers/sampler.cl"
#include "render/lane_io.cl"
#include "render/lights_emit.cl"
#include "render/camera.cl"
#include "render/bsdf.cl"

/* out: pos.xyz, n.xyz, d.xyz, radiance.rgb, pdf_area, pdf_solid_angle, cos, env, valid (17 components) */
kernel void emitter_ray_samples(const render_params scene, global const float4 *emitter_radiance,
                                global const float4 *light_rec, global const float *light_cdf, float4 bsphere,
                                ulong seed, uint n, global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    const light_tables lt = light_tables_of(&scene, light_rec, light_cdf, emitter_radiance, 0, 0);
    mc_sampler_t smp = sampler_start(seed, to_ulongv((uintv)(base) + LANE_IOTA), RNG_STREAM_LIGHT_TEST);
    floatv u[8];
    sampler_next_nd(&smp, 8, u);
    intv all = (intv)(0) == (intv)(0);
    emitter_ray_v r = sample_emitter_ray(&lt, bsphere, u, all);
    floatv comp[17] = {r.pos.x, r.pos.y, r.pos.z, r.n.x, r.n.y, r.n.z, r.d.x, r.d.y, r.d.z,
                       r.radiance.x, r.radiance.y, r.radiance.z, r.pdf_area, r.pdf_solid_angle, r.cos_theta,
                       to_floatv(mask_bit(r.env)), to_floatv(mask_bit(r.valid))};
    for (int c = 0; c < 17; ++c) store_floatv(comp[c], out + c * n + base);
}

/* For unit directions d from the lens point of the uniforms (lens_u.x, lens_u.y): raster x, y, pixel,
 * importance, pdf_solid_angle, cos, valid (7) */
kernel void camera_directions(global const float4 *camera, uint width, uint height, float4 lens_u, uint n,
                              global const float *dirs, global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    vec3v d = v3(load_floatv(dirs + 0 * n + base), load_floatv(dirs + 1 * n + base), load_floatv(dirs + 2 * n + base));
    vec3v xl = camera_lens_point(camera, (floatv)(lens_u.x), (floatv)(lens_u.y));
    const camera_settings plain = {0.0f, INFINITY, {PIXEL_FILTER_BOX, 0.5f, 0.0f}}; /* no clip, the box */
    camera_direction_v c = camera_importance(camera, &plain, xl, d, width, height);
    floatv comp[7] = {c.raster_x, c.raster_y, to_floatv(c.pixel), c.importance, c.pdf_solid_angle, c.cos_theta,
                      to_floatv(mask_bit(c.valid))};
    for (int k = 0; k < 7; ++k) store_floatv(comp[k], out + k * n + base);
}

/* The same uniforms sampled in radiance and in importance mode:
 * wo.xyz (radiance), weight.rgb (radiance), wo.xyz (importance), weight.rgb (importance) (12) */
kernel void bsdf_sample_modes(global const float4 *mats, float4 wi4, ulong seed, uint n, global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    material_v m = material_load(mats, (uintv)(0u));
    vec3v wi = v3((floatv)(wi4.x), (floatv)(wi4.y), (floatv)(wi4.z));
    mc_sampler_t smp = sampler_start(seed, to_ulongv((uintv)(base) + LANE_IOTA), RNG_STREAM_BSDF_TEST);
    floatv u[3];
    sampler_next_nd(&smp, 3, u);
    bsdf_sample_v r = bsdf_sample(&m, wi, u[0], u[1], u[2], TRANSPORT_RADIANCE);
    bsdf_sample_v i = bsdf_sample(&m, wi, u[0], u[1], u[2], TRANSPORT_IMPORTANCE);
    floatv comp[12] = {r.wo.x, r.wo.y, r.wo.z, r.weight.x, r.weight.y, r.weight.z,
                       i.wo.x, i.wo.y, i.wo.z, i.weight.x, i.weight.y, i.weight.z};
    for (int c = 0; c < 12; ++c) store_floatv(comp[c], out + c * n + base);
}

/* Primary rays through uniform film points: film sx, sy, origin.xyz, direction.xyz (8) */
kernel void camera_rays(global const float4 *camera, uint width, uint height, ulong seed, uint n, global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    mc_sampler_t smp = sampler_start(seed, to_ulongv((uintv)(base) + LANE_IOTA), RNG_STREAM_LIGHT_TEST);
    floatv u[4];
    sampler_next_nd(&smp, 4, u);
    floatv sx = u[0] * (float)width, sy = u[1] * (float)height;
    vec3v o;
    vec3v d = camera_ray_lens(camera, sx, sy, 1.0f / (float)width, 1.0f / (float)height, u[2], u[3], &o);
    floatv comp[8] = {sx, sy, o.x, o.y, o.z, d.x, d.y, d.z};
    for (int c = 0; c < 8; ++c) store_floatv(comp[c], out + c * n + base);
}
