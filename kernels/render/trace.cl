/* trace.cl — ray queries for a packet of LANES paths, on top of bvh.cl's
 * scalar traversal (trace_closest / trace_any of the renderer's contract).
 *
 * The scalar build calls the traversal directly.  A lane build traces the
 * packet together (trace_packet.cl); with -DTRACE_PER_LANE it walks its
 * active lanes one by one through the scalar traversal instead (slower;
 * kept for comparison and as a reference).
 */
#ifndef MCOCL_RENDER_TRACE_CL
#define MCOCL_RENDER_TRACE_CL

#include "render/vec3.cl"
#include "render/lane_io.cl"
#include "render/bvh.cl"
#include "render/trace_packet.cl"

typedef struct {
    floatv t, b1, b2;
    uintv prim;
    intv hit;
} hitv;

MC_INLINE hitv trace_closest_v(const scene_geom *g, vec3v o, vec3v d, intv active) {
    hitv h;
#if LANES == 1
    h.hit = 0;
    h.t = INFINITY;
    h.b1 = h.b2 = 0.0f;
    h.prim = 0u;
    if (active) {
        hit_info hi;
        if (trace_closest(g, (float3)(o.x, o.y, o.z), (float3)(d.x, d.y, d.z), INFINITY, &hi)) {
            h.hit = 1;
            h.t = hi.t;
            h.b1 = hi.b1;
            h.b2 = hi.b2;
            h.prim = hi.prim;
        }
    }
#elif !defined(TRACE_PER_LANE)
    packet_closest(g, o, d, active, &h.t, &h.prim, &h.b1, &h.b2);
    h.hit = active & (h.t < INFINITY);
#else
    float ox[LANES], oy[LANES], oz[LANES], dx[LANES], dy[LANES], dz[LANES];
    float ht[LANES], hb1[LANES], hb2[LANES];
    uint hp[LANES];
    int act[LANES], hh[LANES];
    store_floatv(o.x, ox); store_floatv(o.y, oy); store_floatv(o.z, oz);
    store_floatv(d.x, dx); store_floatv(d.y, dy); store_floatv(d.z, dz);
    MC_CAT(vstore, LANE_SUFFIX)(active, 0, act);
    for (int k = 0; k < LANES; ++k) {
        hh[k] = 0; ht[k] = INFINITY; hb1[k] = 0.0f; hb2[k] = 0.0f; hp[k] = 0u;
        if (act[k]) {
            hit_info hi;
            if (trace_closest(g, (float3)(ox[k], oy[k], oz[k]), (float3)(dx[k], dy[k], dz[k]), INFINITY, &hi)) {
                hh[k] = -1; ht[k] = hi.t; hb1[k] = hi.b1; hb2[k] = hi.b2; hp[k] = hi.prim;
            }
        }
    }
    h.hit = MC_CAT(vload, LANE_SUFFIX)(0, hh);
    h.t = load_floatv(ht);
    h.b1 = load_floatv(hb1);
    h.b2 = load_floatv(hb2);
    h.prim = MC_CAT(vload, LANE_SUFFIX)(0, hp);
#endif
    return h;
}

/* Occlusion of the segments o + t d, 0 < t < tmax; inactive lanes report 0. */
MC_INLINE intv trace_any_v(const scene_geom *g, vec3v o, vec3v d, floatv tmax, intv active) {
#if LANES == 1
    return active && trace_any(g, (float3)(o.x, o.y, o.z), (float3)(d.x, d.y, d.z), tmax);
#elif !defined(TRACE_PER_LANE)
    return packet_any(g, o, d, tmax, active);
#else
    float ox[LANES], oy[LANES], oz[LANES], dx[LANES], dy[LANES], dz[LANES], tm[LANES];
    int act[LANES], occ[LANES];
    store_floatv(o.x, ox); store_floatv(o.y, oy); store_floatv(o.z, oz);
    store_floatv(d.x, dx); store_floatv(d.y, dy); store_floatv(d.z, dz);
    store_floatv(tmax, tm);
    MC_CAT(vstore, LANE_SUFFIX)(active, 0, act);
    for (int k = 0; k < LANES; ++k)
        occ[k] = (act[k] && trace_any(g, (float3)(ox[k], oy[k], oz[k]), (float3)(dx[k], dy[k], dz[k]), tm[k])) ? -1 : 0;
    return MC_CAT(vload, LANE_SUFFIX)(0, occ);
#endif
}

#endif
