/* bvh.cl — BVH traversal of one ray: closest hit and any hit (shadow rays).
 *
 * Layout of the bvh_nodes table (mcocl/render/bvh.py, bvh_leaves.py,
 * bvh_wide.py; records in layouts.cl): nodes[0] = header (nprims, K, depth,
 * leaf_row) as uint bits; the binary tree's internal node k at nodes[1 + 4k ..]
 * (the packet traversal's, trace_packet.cl); from leaf_row one leaf_prim per
 * slot of bvh_prims, in leaf order (a leaf is a run of them: no gather
 * through bvh_prims and the triangle table); after those the 4-wide nodes
 * (bvh_wide_node) this single-ray traversal walks.
 *
 * Traversal: a node's four child boxes are slab-tested in float4 lanes and
 * the children hit are taken nearest first; leaf children are intersected on
 * the spot, internal children beyond the closest hit so far are dropped, the
 * nearest internal child is visited next and the others go on a stack with
 * their entry distances, so that they are skipped when popped if a closer hit
 * was found meanwhile (pbrt-v4 §7.3.5, Aila & Laine 2009; wide nodes: Wald
 * et al. 2008, Dammertz et al. 2008).  Any-hit returns at the first hit.  The
 * slab test's far distance is scaled by 1 + 2γ₃ (pbrt-v4 §6.1.2) so that
 * rounding never misses a box a ray grazes, e.g. the flat box of an
 * axis-aligned wall; a zero direction component is replaced by a tiny one so
 * that 0·∞ cannot produce a NaN slab.
 */
#ifndef MCOCL_RENDER_BVH_CL
#define MCOCL_RENDER_BVH_CL

#include "layouts.cl"
#include "render/intersect.cl"

#define BVH_WIDE_STACK 80 /* > 3 pushes per wide level × MAX_DEPTH / 2 (bvh.py MAX_DEPTH = 48) */
#define BVH_EMPTY_SLOT 0xffffffffu /* bvh_wide.py EMPTY_SLOT */
#define BVH_TFAR_SCALE 1.0000004f /* 1 + 2 γ3, γn = n ε / (1 − n ε), ε = 2^-24 */

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

/* Lane-wise a < b ? a : b and a > b ? a : b (g_min, g_max): the wide node test
 * gives the distances of the binary slab test (trace_packet.cl's packet_box) bit
 * for bit.  Vector ?: rather than select(), which the PoCL wheel calls out of line. */
MC_INLINE float4 bvh_min4(float4 a, float4 b) { return a < b ? a : b; }
MC_INLINE float4 bvh_max4(float4 a, float4 b) { return a > b ? a : b; }

/* Compare-exchange of two children (entry distance t, ref r, count c) so that
 * the nearer comes first: one step of the sorting network below. */
#define BVH_CX(a, b)                                                                      \
    {                                                                                     \
        bool sw = t##b < t##a;                                                            \
        float tt = sw ? t##b : t##a;                                                      \
        t##b = sw ? t##a : t##b;                                                          \
        t##a = tt;                                                                        \
        uint ur = sw ? r##b : r##a;                                                       \
        r##b = sw ? r##a : r##b;                                                          \
        r##a = ur;                                                                        \
        uint uc = sw ? c##b : c##a;                                                       \
        c##b = sw ? c##a : c##b;                                                          \
        c##a = uc;                                                                        \
    }

/* Start loading what a child hit will read — the leaf's records, or the wide
 * node (its two cache lines) — so that the loads of all children hit overlap
 * instead of each stalling when it is reached (on a big mesh these loads are
 * cache misses and dominated traversal time, bench/trace_bench.py). */
#if defined(__clang__) && defined(__x86_64__)
/* A CPU device (PoCL): global memory is the process's, so the address can go through an
 * integer to clang's prefetch builtin; OpenCL's own prefetch() is a no-op there. */
#define BVH_PREFETCH(p) __builtin_prefetch((const void *)(ulong)(p))
#else
#define BVH_PREFETCH(p) prefetch((p), 1)
#endif
#define BVH_PREFETCH_CHILD(j)                                                                     \
    if (c##j != BVH_EMPTY_SLOT) {                                                                 \
        if (c##j) {                                                                               \
            BVH_PREFETCH(g->leaves + LEAF_PRIM_QUADS * r##j);                                     \
        } else {                                                                                  \
            global const float4 *pn = g->wide + BVH_WIDE_NODE_QUADS * r##j;                       \
            BVH_PREFETCH(pn);                                                                     \
            BVH_PREFETCH(pn + 4);                                                                 \
        }                                                                                         \
    }

/* The four children of wide node n (mcocl/render/bvh_wide.py) by the slab
 * test on four boxes in float4 lanes: entry distances t0..t3, refs r0..r3 and
 * counts c0..c3, where a child the ray misses before tmax (or an empty slot)
 * has t = INFINITY and c = BVH_EMPTY_SLOT.  With SORT, nearest first, by a
 * five-step sorting network of selects (Knuth, TAOCP vol. 3 §5.3.4): no
 * branches and no indexed private arrays.  Also prefetches the children hit. */
#define BVH_WIDE_CHILDREN(n, tmax, SORT)                                                                        \
    float t0, t1, t2, t3;                                                                                       \
    uint r0, r1, r2, r3, c0, c1, c2, c3;                                                                        \
    {                                                                                                           \
        float4 x0 = (n[0] - ox) * ix, x1 = (n[3] - ox) * ix;                                                    \
        float4 y0 = (n[1] - oy) * iy, y1 = (n[4] - oy) * iy;                                                    \
        float4 z0 = (n[2] - oz) * iz, z1 = (n[5] - oz) * iz;                                                    \
        float4 tn = bvh_max4(bvh_max4(bvh_min4(x0, x1), bvh_min4(y0, y1)), bvh_max4(bvh_min4(z0, z1), (float4)(0.0f))); \
        float4 tf = bvh_min4(bvh_min4(bvh_max4(x0, x1), bvh_max4(y0, y1)), bvh_min4(bvh_max4(z0, z1), (float4)(tmax))) \
                    * BVH_TFAR_SCALE;                                                                           \
        uint4 ref = as_uint4(n[6]), cnt = as_uint4(n[7]);                                                       \
        int4 hit = (tn <= tf) & (cnt != (uint4)(BVH_EMPTY_SLOT));                                               \
        float4 tk = hit ? tn : (float4)(INFINITY);                                                              \
        uint4 ck = hit ? cnt : (uint4)(BVH_EMPTY_SLOT);                                                         \
        t0 = tk.s0; t1 = tk.s1; t2 = tk.s2; t3 = tk.s3;                                                         \
        r0 = ref.s0; r1 = ref.s1; r2 = ref.s2; r3 = ref.s3;                                                     \
        c0 = ck.s0; c1 = ck.s1; c2 = ck.s2; c3 = ck.s3;                                                         \
        if (SORT) { BVH_CX(0, 1) BVH_CX(2, 3) BVH_CX(0, 2) BVH_CX(1, 3) BVH_CX(1, 2) }                          \
        BVH_PREFETCH_CHILD(0) BVH_PREFETCH_CHILD(1) BVH_PREFETCH_CHILD(2) BVH_PREFETCH_CHILD(3)                 \
    }

/* The closest hit with 0 < t < tmax; fills *h and returns true, or returns false (h untouched).
 * Walks the 4-wide tree: of a node's children, nearest first, leaves are
 * intersected on the spot and internal ones beyond the closest hit so far
 * are dropped; the nearest internal child is visited next and the others go
 * on the stack (nearer on top) with their entry distances, skipped when
 * popped if a closer hit was found meanwhile. */
bool trace_closest(const scene_geom *g, float3 o, float3 d, float tmax, hit_info *h)
{
    if (as_uint(g->nodes[0].x) == 0u) return false; /* empty scene */
    float3 inv = bvh_inv_dir(d);
    float4 ox = (float4)(o.x), oy = (float4)(o.y), oz = (float4)(o.z);
    float4 ix = (float4)(inv.x), iy = (float4)(inv.y), iz = (float4)(inv.z);
    float tbest = tmax;
    bool hit = false;
    uint stack[BVH_WIDE_STACK];
    float stack_t[BVH_WIDE_STACK];
    uint sp = 0;
    uint node = 0;
    for (;;) {
        global const float4 *n = g->wide + BVH_WIDE_NODE_QUADS * node;
        BVH_WIDE_CHILDREN(n, tbest, 1)
        uint next = BVH_EMPTY_SLOT, sp0 = sp;
        /* children in order; a child at or beyond the closest hit (and all after it) is dropped */
#define BVH_VISIT_CLOSEST(j)                                                                   \
        if (c##j != BVH_EMPTY_SLOT && t##j <= tbest * BVH_TFAR_SCALE) {                        \
            if (c##j) {                                                                        \
                hit |= bvh_leaf_closest(g, r##j, c##j, o, d, &tbest, h);                       \
            } else if (next == BVH_EMPTY_SLOT) {                                               \
                next = r##j;                                                                   \
            } else if (sp < BVH_WIDE_STACK) {                                                  \
                stack[sp] = r##j;                                                              \
                stack_t[sp] = t##j;                                                            \
                ++sp;                                                                          \
            }                                                                                  \
        }
        BVH_VISIT_CLOSEST(0) BVH_VISIT_CLOSEST(1) BVH_VISIT_CLOSEST(2) BVH_VISIT_CLOSEST(3)
#undef BVH_VISIT_CLOSEST
        /* at most three were pushed, nearest first: swap the ends so that the nearer pops first */
        if (sp - sp0 > 1u) {
            uint a = sp0, b = sp - 1u, tr = stack[a];
            float tt = stack_t[a];
            stack[a] = stack[b]; stack_t[a] = stack_t[b];
            stack[b] = tr; stack_t[b] = tt;
        }
        if (next != BVH_EMPTY_SLOT) {
            node = next;
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

/* True when anything is hit with 0 < t < tmax (shadow rays; d need not be normalised).
 * The same walk, returning at the first hit, with the children in slot order:
 * any hit ends the walk, and skipping the sort measured 7-15 % faster
 * (bench/trace_bench.py, shadow rays). */
bool trace_any(const scene_geom *g, float3 o, float3 d, float tmax)
{
    if (as_uint(g->nodes[0].x) == 0u) return false;
    float3 inv = bvh_inv_dir(d);
    float4 ox = (float4)(o.x), oy = (float4)(o.y), oz = (float4)(o.z);
    float4 ix = (float4)(inv.x), iy = (float4)(inv.y), iz = (float4)(inv.z);
    uint stack[BVH_WIDE_STACK];
    uint sp = 0;
    uint node = 0;
    for (;;) {
        global const float4 *n = g->wide + BVH_WIDE_NODE_QUADS * node;
        BVH_WIDE_CHILDREN(n, tmax, 0)
        uint next = BVH_EMPTY_SLOT, sp0 = sp;
#define BVH_VISIT_ANY(j)                                                                       \
        if (c##j != BVH_EMPTY_SLOT) {                                                          \
            if (c##j) {                                                                        \
                if (bvh_leaf_any(g, r##j, c##j, o, d, tmax)) return true;                      \
            } else if (next == BVH_EMPTY_SLOT) {                                               \
                next = r##j;                                                                   \
            } else if (sp < BVH_WIDE_STACK) {                                                  \
                stack[sp++] = r##j;                                                            \
            }                                                                                  \
        }
        BVH_VISIT_ANY(0) BVH_VISIT_ANY(1) BVH_VISIT_ANY(2) BVH_VISIT_ANY(3)
#undef BVH_VISIT_ANY
        if (sp - sp0 > 1u) {
            uint tr = stack[sp0];
            stack[sp0] = stack[sp - 1u];
            stack[sp - 1u] = tr;
        }
        if (next != BVH_EMPTY_SLOT) {
            node = next;
            continue;
        }
        if (sp == 0) return false;
        node = stack[--sp];
    }
}

#endif
