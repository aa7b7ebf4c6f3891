/* trace_test.cl — the packet traversal of trace_packet.cl next to bvh.cl's
 * scalar traversal, ray by ray, for tests/test_render_trace.py.  Built with
 * LANES > 1; work-item k traces rays k*LANES ... as one packet.
 * rays: o.xyz, d.xyz, tmax (7 components of n); out: packet t, prim, any,
 * scalar t, prim, any (6 components; prim = -1 on a miss). */
#include "render/lane_io.cl"
#include "render/trace.cl"

kernel void trace_compare(SCENE_GEOM_PARAMS, uint n, global const float *rays, global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    SCENE_GEOM_MAKE(g);
    vec3v o = v3(load_floatv(rays + 0 * n + base), load_floatv(rays + 1 * n + base), load_floatv(rays + 2 * n + base));
    vec3v d = v3(load_floatv(rays + 3 * n + base), load_floatv(rays + 4 * n + base), load_floatv(rays + 5 * n + base));
    floatv tmax = load_floatv(rays + 6 * n + base);
    intv all = (intv)(0) == (intv)(0);
    floatv t;
    uintv prim;
    floatv b1, b2;
    packet_closest(&g, o, d, all, &t, &prim, &b1, &b2);
    intv hit = t < INFINITY;
    store_floatv(t, out + 0 * n + base);
    store_floatv(lane_select((floatv)(-1.0f), to_floatv(prim), hit), out + 1 * n + base);
    store_floatv(to_floatv(mask_bit(packet_any(&g, o, d, tmax, all))), out + 2 * n + base);
    for (uint k = 0; k < LANES; ++k) {
        uint i = base + k;
        float3 ok = (float3)(rays[0 * n + i], rays[1 * n + i], rays[2 * n + i]);
        float3 dk = (float3)(rays[3 * n + i], rays[4 * n + i], rays[5 * n + i]);
        hit_info h;
        bool ht = trace_closest(&g, ok, dk, INFINITY, &h);
        out[3 * n + i] = ht ? h.t : INFINITY;
        out[4 * n + i] = ht ? (float)h.prim : -1.0f;
        out[5 * n + i] = trace_any(&g, ok, dk, rays[6 * n + i]) ? 1.0f : 0.0f;
    }
}
