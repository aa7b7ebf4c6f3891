/* raycast.cl — one ray per work-item through trace_closest / trace_any, for
 * tests and the traversal benchmark (mcocl/render/raycast.py). */
#include "render/bvh.cl"

/* hits[i] = (t, prim bits, b1, b2) of the closest hit, (INFINITY, 0xffffffff, 0, 0) on a miss;
 * any[i] = trace_any(...).  Each work-item handles a contiguous run of about n / nitems rays
 * (a work-item per ray would make PoCL pay its per-work-group overhead per ray; neighbouring
 * rays, e.g. a camera's, in one run reuse the nodes they share while they are in cache). */
kernel void raycast(SCENE_GEOM_PARAMS, global const float4 *orig, global const float4 *dir,
                    global const float *tmax, global float4 *hits, global uint *any, const uint n, const uint mode,
                    const uint nitems)
{
    uint id = get_global_id(0);
    if (id >= nitems) return;
    SCENE_GEOM_MAKE(g);
    uint first = (uint)(((ulong)n * id) / nitems), last = (uint)(((ulong)n * (id + 1u)) / nitems);
    for (uint i = first; i < last; ++i) {
        float3 o = orig[i].xyz, d = dir[i].xyz;
        if (mode & 1u) {
            hit_info h;
            if (trace_closest(&g, o, d, tmax[i], &h))
                hits[i] = (float4)(h.t, as_float(h.prim), h.b1, h.b2);
            else
                hits[i] = (float4)(INFINITY, as_float(0xffffffffu), 0.0f, 0.0f);
        }
        if (mode & 2u) any[i] = trace_any(&g, o, d, tmax[i]) ? 1u : 0u;
    }
}

/* For primitive prims[i]: normal at points[i] (xyz) and area (w); a uniform
 * area sample for u[i] (xyz) with its normal (in nsamp[i]). */
kernel void prim_query(SCENE_GEOM_PARAMS, global const uint *prims, global const float4 *points,
                       global const float2 *u, global float4 *normal_area, global float4 *samples,
                       global float4 *sample_normals, const uint n)
{
    uint i = get_global_id(0);
    if (i >= n) return;
    SCENE_GEOM_MAKE(g);
    uint p = prims[i];
    normal_area[i] = (float4)(prim_normal(&g, p, points[i].xyz), prim_area(&g, p));
    float3 nn;
    float3 s = prim_sample_area(&g, p, u[i], &nn);
    samples[i] = (float4)(s, 0.0f);
    sample_normals[i] = (float4)(nn, 0.0f);
}
