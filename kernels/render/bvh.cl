/* bvh.cl — BVH traversal: closest hit and any hit (shadow rays).
 *
 * Layout (mcocl/render/bvh.py): nodes[0] = header (nprims, K, depth, 0) as
 * uint bits; internal node k at nodes[1 + 4k ..]: (lo0, ref0) (hi0, cnt0)
 * (lo1, ref1) (hi1, cnt1) — the two children's boxes live in the parent, so
 * one visit tests both.  cnt == 0: child is internal node ref; cnt > 0: a
 * leaf with prims[ref .. ref + cnt), whose primitives the kernels read from the
 * leaf records at rows leaf_row + 3 ref .. of the same table (mcocl/render/bvh_leaves.py).
 *
 * Traversal: both child boxes are tested, leaf children are intersected on
 * the spot (the nearer first), and of two internal children the nearer is
 * visited first while the farther goes on a small stack with its entry
 * distance, so that it is skipped when popped if a closer hit was found
 * meanwhile (pbrt-v4 §7.3.5, Aila & Laine 2009).  Any-hit returns at the
 * first hit.  The slab test's far distance is scaled by 1 + 2γ₃ (pbrt-v4
 * §6.1.2) so that rounding never misses a box a ray grazes, e.g. the flat
 * box of an axis-aligned wall; a zero direction component is replaced by a
 * tiny one so that 0·∞ cannot produce a NaN slab.
 */
#ifndef MCOCL_RENDER_BVH_CL
#define MCOCL_RENDER_BVH_CL

#include "layouts.cl"
#include "render/intersect.cl"

#define BVH_STACK 64 /* > bvh.py MAX_DEPTH */
#define BVH_TFAR_SCALE 1.0000004f /* 1 + 2 γ3, γn = n ε / (1 − n ε), ε = 2^-24 */

/* Slab test of box [lo, hi]: entry distance in *tnear when the ray enters it before tmax. */
MC_INLINE bool bvh_box(float3 lo, float3 hi, float3 o, float3 inv, float tmax, float *tnear)
{
    float3 t0 = (lo - o) * inv, t1 = (hi - o) * inv;
    float tn = g_max(g_max(g_min(t0.x, t1.x), g_min(t0.y, t1.y)), g_max(g_min(t0.z, t1.z), 0.0f));
    float tf = g_min(g_min(g_max(t0.x, t1.x), g_max(t0.y, t1.y)), g_min(g_max(t0.z, t1.z), tmax)) * BVH_TFAR_SCALE;
    *tnear = tn;
    return tn <= tf;
}

MC_INLINE float3 bvh_inv_dir(float3 d)
{
    /* A zero component would make (lo − o)·inv = 0·∞ = NaN; 1e-30 keeps it finite and signed. */
    float3 dd = (float3)(d.x != 0.0f ? d.x : 1e-30f, d.y != 0.0f ? d.y : 1e-30f, d.z != 0.0f ? d.z : 1e-30f);
    return 1.0f / dd;
}

/* Intersect the primitives of a leaf (leaf records first .. first + count, in
 * leaf order: no gather through prims); the closest hit so far is (*tbest, h). */
MC_INLINE bool bvh_leaf_closest(const scene_geom *g, uint first, uint count, float3 o,
                                                             float3 d, float *tbest, hit_info *h)
{
    bool hit = false;
    global const float4 *r = g->leaves + LEAF_PRIM_QUADS * first;
    for (uint k = 0; k < count; ++k, r += LEAF_PRIM_QUADS) {
        float4 r0 = r[0], r1 = r[1];
        uint p = as_uint(r0.w);
        float t, b1 = 0.0f, b2 = 0.0f;
        bool ok;
        if (p < g->ntris) {
            ok = intersect_triangle_edges(r0.xyz, r1.xyz, r[2].xyz, o, d, *tbest, &t, &b1, &b2);
        } else {
            ok = intersect_sphere(r1, o, d, *tbest, &t);
        }
        if (ok) {
            *tbest = t;
            h->t = t;
            h->prim = p;
            h->b1 = b1;
            h->b2 = b2;
            hit = true;
        }
    }
    return hit;
}

MC_INLINE bool bvh_leaf_any(const scene_geom *g, uint first, uint count, float3 o,
                                                         float3 d, float tmax)
{
    global const float4 *r = g->leaves + LEAF_PRIM_QUADS * first;
    for (uint k = 0; k < count; ++k, r += LEAF_PRIM_QUADS) {
        float4 r0 = r[0], r1 = r[1];
        uint p = as_uint(r0.w);
        float t, b1, b2;
        bool ok = (p < g->ntris) ? intersect_triangle_edges(r0.xyz, r1.xyz, r[2].xyz, o, d, tmax, &t, &b1, &b2)
                                 : intersect_sphere(r1, o, d, tmax, &t);
        if (ok) return true;
    }
    return false;
}

/* The closest hit with 0 < t < tmax; fills *h and returns true, or returns false (h untouched). */
bool trace_closest(const scene_geom *g, float3 o, float3 d, float tmax, hit_info *h)
{
    if (as_uint(g->nodes[0].x) == 0u) return false; /* empty scene */
    float3 inv = bvh_inv_dir(d);
    float tbest = tmax;
    bool hit = false;
    uint stack[BVH_STACK];
    float stack_t[BVH_STACK];
    uint sp = 0;
    uint node = 0;
    for (;;) {
        global const float4 *nd = g->nodes + 1 + 4 * node;
        float4 a0 = nd[0], a1 = nd[1], c0 = nd[2], c1 = nd[3];
        float tn0, tn1;
        bool h0 = bvh_box(a0.xyz, a1.xyz, o, inv, tbest, &tn0);
        bool h1 = bvh_box(c0.xyz, c1.xyz, o, inv, tbest, &tn1);
        uint r0 = as_uint(a0.w), n0 = as_uint(a1.w), r1 = as_uint(c0.w), n1 = as_uint(c1.w);
        if (h0 && h1 && tn1 < tn0) { /* nearer child first */
            uint tr = r0; r0 = r1; r1 = tr;
            uint tc = n0; n0 = n1; n1 = tc;
            float tt = tn0; tn0 = tn1; tn1 = tt;
        } else if (!h0 && h1) {
            r0 = r1; n0 = n1; tn0 = tn1; h0 = true; h1 = false;
        }
        /* Now child 0 is hit whenever any is, and is the nearer. */
        if (h0 && n0) {
            hit |= bvh_leaf_closest(g, r0, n0, o, d, &tbest, h);
            h0 = false;
        }
        /* A hit in the nearer leaf may put the farther child beyond it. */
        h1 = h1 && tn1 <= tbest * BVH_TFAR_SCALE;
        if (h1 && n1) {
            hit |= bvh_leaf_closest(g, r1, n1, o, d, &tbest, h);
            h1 = false;
        }
        if (h0) {
            if (h1 && sp < BVH_STACK) {
                stack[sp] = r1;
                stack_t[sp] = tn1;
                ++sp;
            }
            node = r0;
            continue;
        }
        if (h1) {
            node = r1;
            continue;
        }
        /* Pop the next subtree that may still hold a closer hit. */
        for (;;) {
            if (sp == 0) return hit;
            --sp;
            if (stack_t[sp] <= tbest * BVH_TFAR_SCALE) break;
        }
        node = stack[sp];
    }
}

/* True when anything is hit with 0 < t < tmax (shadow rays; d need not be normalised). */
bool trace_any(const scene_geom *g, float3 o, float3 d, float tmax)
{
    if (as_uint(g->nodes[0].x) == 0u) return false;
    float3 inv = bvh_inv_dir(d);
    uint stack[BVH_STACK];
    uint sp = 0;
    uint node = 0;
    for (;;) {
        global const float4 *nd = g->nodes + 1 + 4 * node;
        float4 a0 = nd[0], a1 = nd[1], c0 = nd[2], c1 = nd[3];
        float tn0, tn1;
        bool h0 = bvh_box(a0.xyz, a1.xyz, o, inv, tmax, &tn0);
        bool h1 = bvh_box(c0.xyz, c1.xyz, o, inv, tmax, &tn1);
        uint r0 = as_uint(a0.w), n0 = as_uint(a1.w), r1 = as_uint(c0.w), n1 = as_uint(c1.w);
        if (h0 && h1 && tn1 < tn0) { /* nearer child first: occluders near the origin end the search early */
            uint tr = r0; r0 = r1; r1 = tr;
            uint tc = n0; n0 = n1; n1 = tc;
        }
        if (h0 && n0) {
            if (bvh_leaf_any(g, r0, n0, o, d, tmax)) return true;
            h0 = false;
        }
        if (h1 && n1) {
            if (bvh_leaf_any(g, r1, n1, o, d, tmax)) return true;
            h1 = false;
        }
        if (h0) {
            if (h1 && sp < BVH_STACK) stack[sp++] = r1;
            node = r0;
            continue;
        }
        if (h1) {
            node = r1;
            continue;
        }
        if (sp == 0) return false;
        node = stack[--sp];
    }
}

#endif
