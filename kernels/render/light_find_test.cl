/* light_find_test.cl — the power table's light choice (light_find, render/lights.cl) exposed to the
 * tests (tests/test_render_light_find.py): out[i] = light_find of u[i] over the CDF light_cdf of
 * nlights lights, LANES items per work-item. */
#include "layouts.cl"
#include "samplers/sampler.cl"
#include "render/vec3.cl"
#include "render/lane_io.cl"
#include "render/prims.cl"
#include "render/lights.cl"

kernel void find_lights(uint nlights, uint light_top, global const float *light_cdf, uint n, global const float *u,
                        global uint *out) {
    const uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    light_tables lt;
    lt.light_cdf = light_cdf;
    lt.nlights = nlights;
    lt.light_top = light_top;
#if LANES == 1
    out[base] = light_find(&lt, u[base]);
#else
    MC_CAT(vstore, LANE_SUFFIX)(light_find(&lt, load_floatv(u + base)), 0, out + base);
#endif
}
