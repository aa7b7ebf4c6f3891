/* light_sample_test.cl — emitter sampling exposed to the tests: draw light
 * samples from a point (sample_light) and evaluate, for given directions
 * from the same point, the solid-angle density with which those samples
 * arrive there (light_pdf_hit at the emitter the direction hits, plus the
 * environment's share), for a chi-square test.  Outputs are structure of
 * arrays (component c of item i at c * n + i). */
#include "samplers/sampler.cl"
#include "render/lane_io.cl"
#include "render/lights.cl"
#include "render/trace.cl"

/* The scene's counts and emitter choice come in a render_params (layouts.cl;
 * host: mcocl/render/device_scene.py, scene_params), the tables as buffers. */
#define LIGHT_TEST_PARAMS                                                                                      \
    const render_params scene, SCENE_GEOM_BUFFERS, global const float4 *prim_rec,                              \
    global const float4 *emitter_radiance, global const float4 *light_rec, global const float *light_cdf,      \
    global const float4 *light_bvh, global const uint *light_trail

#define LIGHT_TEST_SETUP                                                                                       \
    const uint scene_ntris = scene.ntris, scene_nspheres = scene.nspheres;                                    \
    SCENE_GEOM_MAKE(geom);                                                                                     \
    const prim_tables pt = prim_tables_of(&scene, scene_spheres, prim_rec);                                    \
    const light_tables lt = light_tables_of(&scene, light_rec, light_cdf, emitter_radiance, light_bvh, light_trail)

/* out: wo.xyz, pdf, radiance.rgb, valid, env, prim, pos.xyz (13 components) */
kernel void light_sample_dirs(LIGHT_TEST_PARAMS, float4 p4, ulong seed, uint n, global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    LIGHT_TEST_SETUP;
    vec3v p = v3((floatv)(p4.x), (floatv)(p4.y), (floatv)(p4.z));
    mc_sampler_t smp = sampler_start(seed, to_ulongv((uintv)(base) + LANE_IOTA), RNG_STREAM_LIGHT_TEST);
    floatv u[4];
    sampler_next_nd(&smp, 4, u);
    intv all = (intv)(0) == (intv)(0);
    light_sample_v s = sample_light(&lt, &pt, p, u[0], u[1], u[2], u[3], all);
    store_floatv(s.wo.x, out + 0 * n + base);
    store_floatv(s.wo.y, out + 1 * n + base);
    store_floatv(s.wo.z, out + 2 * n + base);
    store_floatv(s.pdf, out + 3 * n + base);
    store_floatv(s.radiance.x, out + 4 * n + base);
    store_floatv(s.radiance.y, out + 5 * n + base);
    store_floatv(s.radiance.z, out + 6 * n + base);
    store_floatv(to_floatv(mask_bit(s.valid)), out + 7 * n + base);
    store_floatv(to_floatv(mask_bit(s.env)), out + 8 * n + base);
    store_floatv(to_floatv(s.prim), out + 9 * n + base);
    store_floatv(s.pos.x, out + 10 * n + base);
    store_floatv(s.pos.y, out + 11 * n + base);
    store_floatv(s.pos.z, out + 12 * n + base);
}

/* For directions wo from p: the pdf with which sample_light would pick the
 * first emitter point the ray meets (front side only; 0 if none), that
 * primitive (-1 if none), and whether the ray escapes (3 components). */
kernel void light_pdf_dirs(LIGHT_TEST_PARAMS, float4 p4, uint n, global const float *wo, global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    LIGHT_TEST_SETUP;
    vec3v p = v3((floatv)(p4.x), (floatv)(p4.y), (floatv)(p4.z));
    vec3v d = v3(load_floatv(wo + 0 * n + base), load_floatv(wo + 1 * n + base), load_floatv(wo + 2 * n + base));
    intv all = (intv)(0) == (intv)(0);
    hitv h = trace_closest_v(&geom, p, d, all);
    surface_v sf = surface_at(&pt, h.prim, h.t, p, d, h.hit);
    intv emitting = h.hit & (sf.emitter >= 0) & (v3_dot(sf.n, d) < 0.0f);
    floatv pdf = light_pdf_hit(&lt, &pt, p, d, h.prim, &sf, emitting);
    store_floatv(pdf, out + 0 * n + base);
    store_floatv(lane_select((floatv)(-1.0f), to_floatv(h.prim), emitting), out + 1 * n + base);
    store_floatv(to_floatv(mask_bit(!h.hit)), out + 2 * n + base);
}

/* The light BVH's choice from p with normal n4 (render/light_bvh.cl): the
 * light chosen with a uniform, the probability the walk reports, and the
 * probability light_bvh_pmf recomputes for that light's primitive (which must
 * be the same float; for a flat tree also the one the walk left in its
 * light_choice_memo, NaN where the two differ); -1 and 0 where no light was
 * chosen (3 components). */
kernel void light_bvh_choices(LIGHT_TEST_PARAMS, float4 p4, float4 n4, ulong seed, uint n, global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    LIGHT_TEST_SETUP;
    vec3v p = v3((floatv)(p4.x), (floatv)(p4.y), (floatv)(p4.z));
    vec3v nn = v3((floatv)(n4.x), (floatv)(n4.y), (floatv)(n4.z));
    mc_sampler_t smp = sampler_start(seed, to_ulongv((uintv)(base) + LANE_IOTA), RNG_STREAM_LIGHT_TEST);
    floatv u[1];
    sampler_next_nd(&smp, 1, u);
    intv all = (intv)(0) == (intv)(0);
    floatv pmf;
    light_choice_memo memo;
    memo.valid = 0;
    uintv k = light_bvh_sample_memo(lt.light_bvh, p, nn, u[0], all, &pmf, &memo);
    intv ok = pmf > 0.0f;
    LIGHT_RECORD_GATHER(q, lt.light_rec, k);
    uintv prim = lane_as_uint(REC_FIELD(q, LIGHT_RECORD_PRIM));
    uintv trail = gather_uint(lt.light_trail, prim);
    floatv again = light_bvh_pmf(lt.light_bvh, p, nn, trail, ok);
    if (memo.valid) {
        floatv memo_pmf = light_bvh_memo_pmf(&memo, lt.light_bvh, trail, ok);
        again = lane_select((floatv)(NAN), again, lane_as_uint(memo_pmf) == lane_as_uint(again));
    }
    store_floatv(lane_select((floatv)(-1.0f), to_floatv(k), ok), out + 0 * n + base);
    store_floatv(pmf, out + 1 * n + base);
    store_floatv(again, out + 2 * n + base);
}

/* For every light k and a point p with normal n4: light_bvh_pmf of its primitive (1 component). */
kernel void light_bvh_pmfs(LIGHT_TEST_PARAMS, float4 p4, float4 n4, uint n, global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    LIGHT_TEST_SETUP;
    vec3v p = v3((floatv)(p4.x), (floatv)(p4.y), (floatv)(p4.z));
    vec3v nn = v3((floatv)(n4.x), (floatv)(n4.y), (floatv)(n4.z));
    uintv k = min((uintv)(base) + LANE_IOTA, (uintv)(scene.nlights - 1u));
    LIGHT_RECORD_GATHER(q, lt.light_rec, k);
    uintv prim = lane_as_uint(REC_FIELD(q, LIGHT_RECORD_PRIM));
    intv all = (intv)(0) == (intv)(0);
    store_floatv(light_bvh_pmf(lt.light_bvh, p, nn, gather_uint(lt.light_trail, prim), all), out + base);
}

/* The light the BVH walk chooses from p (normal n4) for given uniforms u (-1: none; 1 component),
 * so that a test can push every uniform of the grid through it. */
kernel void light_bvh_choose_u(LIGHT_TEST_PARAMS, float4 p4, float4 n4, global const float *u, uint n,
                               global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    LIGHT_TEST_SETUP;
    vec3v p = v3((floatv)(p4.x), (floatv)(p4.y), (floatv)(p4.z));
    vec3v nn = v3((floatv)(n4.x), (floatv)(n4.y), (floatv)(n4.z));
    intv all = (intv)(0) == (intv)(0);
    floatv pmf;
    uintv k = light_bvh_sample(lt.light_bvh, p, nn, load_floatv(u + base), all, &pmf);
    store_floatv(lane_select((floatv)(-1.0f), to_floatv(k), pmf > 0.0f), out + base);
}
