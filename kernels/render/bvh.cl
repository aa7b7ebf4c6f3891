/* bvh.cl — BVH traversal of one ray: closest hit and any hit (shadow rays).
 *
 * Layout of the bvh_nodes table (mcocl/render/bvh.py, bvh_leaves.py,
 * bvh_wide.py; records in layouts.cl): nodes[0] = header (nprims, K, depth,
 * leaf_row) as uint bits; the binary tree's internal node k at nodes[1 + 4k ..]
 * (the packet traversal's, trace_packet.cl); from leaf_row one leaf_prim per
 * slot of bvh_prims, in leaf order (a leaf is a run of them: no gather
 * through bvh_prims and the triangle table); after those the 8-wide nodes
 * (bvh_wide_node) this single-ray traversal walks.
 *
 * Traversal: a node's eight child boxes are slab-tested in float8 lanes (one
 * AVX register) and the children hit are taken nearest first; leaf children
 * are intersected, internal children beyond the closest hit so far are dropped, the
 * nearest internal child is visited next and the others go on a stack with
 * their entry distances, so that they are skipped when popped if a closer hit
 * was found meanwhile (pbrt-v4 §7.3.5, Aila & Laine 2009; wide nodes: Wald
 * et al. 2008, Dammertz et al. 2008).  Any-hit returns at the first hit.  A
 * leaf's triangles are intersected four at a time in float4 lanes
 * (bvh_leaf_tris4), their hits then taken in leaf order.  The
 * slab test's far distance is scaled by 1 + 2γ₃ (pbrt-v4 §6.1.2) so that
 * rounding never misses a box a ray grazes, e.g. the flat box of an
 * axis-aligned wall; a zero direction component is replaced by a tiny one so
 * that 0·∞ cannot produce a NaN slab.
 */
#ifndef MCOCL_RENDER_BVH_CL
#define MCOCL_RENDER_BVH_CL

#include "layouts.cl"
#include "render/intersect.cl"

#define BVH_WIDE_STACK 168 /* 7 pushes per wide level × MAX_DEPTH / 2 (bvh.py MAX_DEPTH = 48; a wide level spans >= 2 binary ones) */
#define BVH_EMPTY_SLOT 0xffffffffu /* bvh_wide.py EMPTY_SLOT */
#define BVH_TFAR_SCALE 1.0000004f /* 1 + 2 γ3, γn = n ε / (1 − n ε), ε = 2^-24 */

MC_INLINE float3 bvh_inv_dir(float3 d)
{
    /* A zero component would make (lo − o)·inv = 0·∞ = NaN; 1e-30 keeps it finite and signed. */
    float3 dd = (float3)(d.x != 0.0f ? d.x : 1e-30f, d.y != 0.0f ? d.y : 1e-30f, d.z != 0.0f ? d.z : 1e-30f);
    return 1.0f / dd;
}

/* Four triangles' Möller–Trumbore in float4 lanes: the operations of
 * intersect.cl's intersect_triangle_edges (g3_cross, g3_dot, written the same
 * way so that each lane gives its t, u, v bit for bit), over leaf records
 * r[0 .. 3] (lanes past `live` repeat the last live record: no read past the
 * leaf).  Returns -1 in the lanes whose triangle is hit with 0 < t < tmax;
 * the sphere lanes (prim >= ntris) come back in *sphere. */
#define BVH_CROSS4(ax, ay, az, bx, by, bz, cx, cy, cz) \
    float4 cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx
#define BVH_DOT4(ax, ay, az, bx, by, bz) (ax * bx + ay * by + az * bz)
MC_INLINE int4 bvh_leaf_tris4(const scene_geom *g, global const float4 *r, uint live, float3 o, float3 d,
                              float tmax, float4 *t_out, float4 *u_out, float4 *v_out, int4 *sphere)
{
    uint l1 = live > 1u ? 1u : 0u, l2 = live > 2u ? 2u : live - 1u, l3 = live > 3u ? 3u : live - 1u;
    global const float4 *r0 = r, *r1 = r + LEAF_PRIM_QUADS * l1, *r2 = r + LEAF_PRIM_QUADS * l2,
                        *r3 = r + LEAF_PRIM_QUADS * l3;
    float4 a0 = r0[0], a1 = r1[0], a2 = r2[0], a3 = r3[0];
    float4 b0 = r0[1], b1 = r1[1], b2 = r2[1], b3 = r3[1];
    float4 c0 = r0[2], c1 = r1[2], c2 = r2[2], c3 = r3[2];
    float4 v0x = (float4)(a0.x, a1.x, a2.x, a3.x), v0y = (float4)(a0.y, a1.y, a2.y, a3.y),
           v0z = (float4)(a0.z, a1.z, a2.z, a3.z);
    uint4 prim = as_uint4((float4)(a0.w, a1.w, a2.w, a3.w));
    float4 e1x = (float4)(b0.x, b1.x, b2.x, b3.x), e1y = (float4)(b0.y, b1.y, b2.y, b3.y),
           e1z = (float4)(b0.z, b1.z, b2.z, b3.z);
    float4 e2x = (float4)(c0.x, c1.x, c2.x, c3.x), e2y = (float4)(c0.y, c1.y, c2.y, c3.y),
           e2z = (float4)(c0.z, c1.z, c2.z, c3.z);
    float4 dx = (float4)(d.x), dy = (float4)(d.y), dz = (float4)(d.z);
    BVH_CROSS4(dx, dy, dz, e2x, e2y, e2z, pvx, pvy, pvz);
    float4 det = BVH_DOT4(e1x, e1y, e1z, pvx, pvy, pvz);
    float4 inv = 1.0f / det;
    float4 tvx = (float4)(o.x) - v0x, tvy = (float4)(o.y) - v0y, tvz = (float4)(o.z) - v0z;
    float4 udot = BVH_DOT4(tvx, tvy, tvz, pvx, pvy, pvz);
    float4 u = udot * inv;
    BVH_CROSS4(tvx, tvy, tvz, e1x, e1y, e1z, qvx, qvy, qvz);
    float4 vdot = BVH_DOT4(dx, dy, dz, qvx, qvy, qvz);
    float4 v = vdot * inv;
    float4 tdot = BVH_DOT4(e2x, e2y, e2z, qvx, qvy, qvz);
    float4 t = tdot * inv;
    int4 valid = (uint4)(0u, 1u, 2u, 3u) < (uint4)(live);
    int4 tri = prim < (uint4)(g->ntris);
    *sphere = valid & ~tri;
    *t_out = t;
    *u_out = u;
    *v_out = v;
    return valid & tri & (u >= (float4)(-TRI_EDGE_EPS)) & (v >= (float4)(-TRI_EDGE_EPS))
           & (u + v <= (float4)(1.0f + TRI_EDGE_EPS)) & (t > (float4)(0.0f)) & (t < (float4)(tmax))
           & (det != (float4)(0.0f));
}
#undef BVH_CROSS4
#undef BVH_DOT4

/* Intersect the primitives of a leaf (leaf records first .. first + count, in
 * leaf order: no gather through prims); the closest hit so far is (*tbest, h).
 * Triangles four at a time (bvh_leaf_tris4); the hits are then taken in leaf
 * order with the running tbest, so the result is that of testing them one by
 * one (the first of equal t wins). */
MC_INLINE bool bvh_leaf_closest(const scene_geom *g, uint first, uint count, float3 o,
                                                             float3 d, float *tbest, hit_info *h)
{
    bool hit = false;
    global const float4 *r = g->leaves + LEAF_PRIM_QUADS * first;
    for (uint k = 0; k < count; k += 4u, r += 4u * LEAF_PRIM_QUADS) {
        uint live = count - k < 4u ? count - k : 4u;
        float4 t4, u4, v4;
        int4 sph;
        int4 ok = bvh_leaf_tris4(g, r, live, o, d, *tbest, &t4, &u4, &v4, &sph);
        if (!((ok.x | ok.y | ok.z | ok.w | sph.x | sph.y | sph.z | sph.w) & 0x80000000)) continue;
        float ta[4], ua[4], va[4];
        int oka[4], spa[4];
        vstore4(t4, 0, ta);
        vstore4(u4, 0, ua);
        vstore4(v4, 0, va);
        vstore4(ok, 0, oka);
        vstore4(sph, 0, spa);
        for (uint j = 0; j < live; ++j) {
            float t = ta[j], b1 = ua[j], b2 = va[j];
            bool okj;
            if (spa[j]) {
                okj = intersect_sphere(r[LEAF_PRIM_QUADS * j + 1u], o, d, *tbest, &t);
                b1 = b2 = 0.0f;
            } else {
                okj = oka[j] && t < *tbest;
            }
            if (okj) {
                *tbest = t;
                h->t = t;
                h->prim = as_uint(r[LEAF_PRIM_QUADS * j].w);
                h->b1 = b1;
                h->b2 = b2;
                hit = true;
            }
        }
    }
    return hit;
}

MC_INLINE bool bvh_leaf_any(const scene_geom *g, uint first, uint count, float3 o,
                                                         float3 d, float tmax)
{
    global const float4 *r = g->leaves + LEAF_PRIM_QUADS * first;
    for (uint k = 0; k < count; k += 4u, r += 4u * LEAF_PRIM_QUADS) {
        uint live = count - k < 4u ? count - k : 4u;
        float4 t4, u4, v4;
        int4 sph;
        int4 ok = bvh_leaf_tris4(g, r, live, o, d, tmax, &t4, &u4, &v4, &sph);
        if ((ok.x | ok.y | ok.z | ok.w) & 0x80000000) return true;
        if ((sph.x | sph.y | sph.z | sph.w) & 0x80000000) {
            int spa[4];
            vstore4(sph, 0, spa);
            for (uint j = 0; j < live; ++j) {
                float t;
                if (spa[j] && intersect_sphere(r[LEAF_PRIM_QUADS * j + 1u], o, d, tmax, &t)) return true;
            }
        }
    }
    return false;
}

/* Lane-wise a < b ? a : b and a > b ? a : b (g_min, g_max): the wide node test
 * gives the distances of the binary slab test (trace_packet.cl's packet_box) bit
 * for bit.  Vector ?: rather than select(), which the PoCL wheel calls out of line. */
MC_INLINE float8 bvh_min8(float8 a, float8 b) { return a < b ? a : b; }
MC_INLINE float8 bvh_max8(float8 a, float8 b) { return a > b ? a : b; }

/* Start loading what a child hit will read — the leaf's records (up to three
 * cache lines), or the wide node (its four) — so that the loads of all
 * children hit overlap instead of each stalling when it is reached (on a big
 * mesh these loads are cache misses and dominated traversal time,
 * bench/trace_bench.py). */
#if defined(__clang__) && defined(__x86_64__)
/* A CPU device (PoCL): global memory is the process's, so the address can go through an
 * integer to clang's prefetch builtin; OpenCL's own prefetch() is a no-op there. */
#define BVH_PREFETCH(p) __builtin_prefetch((const void *)(ulong)(p))
#else
#define BVH_PREFETCH(p) prefetch((p), 1)
#endif
MC_INLINE void bvh_prefetch_child(const scene_geom *g, uint ref, uint cnt)
{
    if (cnt) {
        global const float4 *pl = g->leaves + LEAF_PRIM_QUADS * ref;
        BVH_PREFETCH(pl);
        BVH_PREFETCH(pl + 4);
        if (cnt > 2u) BVH_PREFETCH(pl + 8);
    } else {
        global const float4 *pn = g->wide + BVH_WIDE_NODE_QUADS * ref;
        BVH_PREFETCH(pn);
        BVH_PREFETCH(pn + 4);
        BVH_PREFETCH(pn + 8);
        BVH_PREFETCH(pn + 12);
    }
}

/* Index of the lowest set bit of b != 0 (ctz is OpenCL 2.0; popcount is 1.2). */
MC_INLINE uint bvh_lowest_bit(uint b) { return popcount((b & (0u - b)) - 1u); }

/* The children of wide node n (mcocl/render/bvh_wide.py) hit before tmax, by the
 * slab test on eight boxes in float8 lanes (one AVX register): entry distances
 * into ct[], refs into cr[], counts into cc[]; returns a bit per child hit. */
MC_INLINE uint bvh_wide_children(global const float4 *n, float8 ox, float8 oy, float8 oz, float8 ix, float8 iy,
                                 float8 iz, float tmax, float *ct, uint *cr, uint *cc)
{
#define BVH_ROW8(k) ((float8)(n[2 * (k)], n[2 * (k) + 1])) /* field k: children 0-3, then 4-7 */
    float8 x0 = (BVH_ROW8(0) - ox) * ix, x1 = (BVH_ROW8(3) - ox) * ix;
    float8 y0 = (BVH_ROW8(1) - oy) * iy, y1 = (BVH_ROW8(4) - oy) * iy;
    float8 z0 = (BVH_ROW8(2) - oz) * iz, z1 = (BVH_ROW8(5) - oz) * iz;
    float8 tn = bvh_max8(bvh_max8(bvh_min8(x0, x1), bvh_min8(y0, y1)), bvh_max8(bvh_min8(z0, z1), (float8)(0.0f)));
    float8 tf = bvh_min8(bvh_min8(bvh_max8(x0, x1), bvh_max8(y0, y1)), bvh_min8(bvh_max8(z0, z1), (float8)(tmax)))
                * BVH_TFAR_SCALE;
    uint8 ref = as_uint8(BVH_ROW8(6)), cnt = as_uint8(BVH_ROW8(7));
#undef BVH_ROW8
    int8 hit = (tn <= tf) & (cnt != (uint8)(BVH_EMPTY_SLOT));
    /* the hit lanes as bits: a horizontal sum of lane weights */
    uint8 w = as_uint8(hit) & (uint8)(1u, 2u, 4u, 8u, 16u, 32u, 64u, 128u);
    uint4 w4 = w.lo + w.hi;
    uint2 w2 = w4.lo + w4.hi;
    vstore8(tn, 0, ct);
    vstore8(ref, 0, cr);
    vstore8(cnt, 0, cc);
    return w2.x + w2.y;
}

/* The children hit (bits of bvh_wide_children) sorted by entry distance into
 * st/sr/sc by insertion (ties keep slot order): nearest first, or farthest
 * first with `farthest` (a compile-time constant at each call); prefetches
 * each.  Returns how many. */
MC_INLINE uint bvh_sort_children(const scene_geom *g, uint bits, const float *ct, const uint *cr, const uint *cc,
                                 const int farthest, float *st, uint *sr, uint *sc)
{
    uint m = 0;
    while (bits) {
        uint j = bvh_lowest_bit(bits);
        bits &= bits - 1u;
        float t = ct[j];
        uint r = cr[j], c = cc[j];
        bvh_prefetch_child(g, r, c);
        uint k = m++;
        while (k > 0u && (farthest ? st[k - 1u] < t : st[k - 1u] > t)) {
            st[k] = st[k - 1u];
            sr[k] = sr[k - 1u];
            sc[k] = sc[k - 1u];
            --k;
        }
        st[k] = t;
        sr[k] = r;
        sc[k] = c;
    }
    return m;
}

/* The closest hit with 0 < t < tmax; fills *h and returns true, or returns false (h untouched).
 * Walks the 8-wide tree: the children hit are sorted nearest first (insertion
 * sort; ties keep slot order); leaves are intersected in that order unless
 * they lie beyond the closest hit so far, then internal children are pushed
 * farthest first with their entry distances, the nearest being visited next;
 * a popped subtree is skipped if a closer hit was found meanwhile. */
bool trace_closest(const scene_geom *g, float3 o, float3 d, float tmax, hit_info *h)
{
    if (as_uint(g->nodes[0].x) == 0u) return false; /* empty scene */
    float3 inv = bvh_inv_dir(d);
    float8 ox = (float8)(o.x), oy = (float8)(o.y), oz = (float8)(o.z);
    float8 ix = (float8)(inv.x), iy = (float8)(inv.y), iz = (float8)(inv.z);
    float tbest = tmax;
    bool hit = false;
    uint stack[BVH_WIDE_STACK];
    float stack_t[BVH_WIDE_STACK];
    uint sp = 0;
    uint node = 0;
    for (;;) {
        float ct[8], st[8];
        uint cr[8], cc[8], sr[8], sc[8];
        uint bits = bvh_wide_children(g->wide + BVH_WIDE_NODE_QUADS * node, ox, oy, oz, ix, iy, iz, tbest, ct, cr, cc);
        uint m = bvh_sort_children(g, bits, ct, cr, cc, 0, st, sr, sc);
        for (uint k = 0; k < m; ++k)
            if (sc[k] && st[k] <= tbest * BVH_TFAR_SCALE) hit |= bvh_leaf_closest(g, sr[k], sc[k], o, d, &tbest, h);
        uint next = BVH_EMPTY_SLOT;
        float next_t = 0.0f;
        for (uint k = m; k-- > 0u;) {
            if (sc[k] || st[k] > tbest * BVH_TFAR_SCALE) continue;
            if (next != BVH_EMPTY_SLOT && sp < BVH_WIDE_STACK) {
                stack[sp] = next;
                stack_t[sp] = next_t;
                ++sp;
            }
            next = sr[k];
            next_t = st[k];
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
 * The same walk, returning at the first hit, with the children taken
 * farthest first: a shadow ray leaves a surface, and the subtrees it enters
 * first hold that surface, which cannot occlude it.  Measured on the shadow
 * rays of bench/trace_bench.py (M rays per CPU-second, 8-wide tree): slot
 * order 0.55 / 0.59 (soup / terrain), nearest first 0.36 / 0.65, farthest
 * first 0.71 / 0.59; with float4 leaves (bvh_leaf_tris4) slot order 0.84 / 0.99,
 * farthest first 0.98 / 1.07. */
bool trace_any(const scene_geom *g, float3 o, float3 d, float tmax)
{
    if (as_uint(g->nodes[0].x) == 0u) return false;
    float3 inv = bvh_inv_dir(d);
    float8 ox = (float8)(o.x), oy = (float8)(o.y), oz = (float8)(o.z);
    float8 ix = (float8)(inv.x), iy = (float8)(inv.y), iz = (float8)(inv.z);
    uint stack[BVH_WIDE_STACK];
    uint sp = 0;
    uint node = 0;
    for (;;) {
        float ct[8], st[8];
        uint cr[8], cc[8], sr[8], sc[8];
        uint bits = bvh_wide_children(g->wide + BVH_WIDE_NODE_QUADS * node, ox, oy, oz, ix, iy, iz, tmax, ct, cr, cc);
        uint m = bvh_sort_children(g, bits, ct, cr, cc, 1, st, sr, sc);
        for (uint k = 0; k < m; ++k)
            if (sc[k] && bvh_leaf_any(g, sr[k], sc[k], o, d, tmax)) return true;
        /* internal children nearest first onto the stack, so that the farthest is visited next */
        uint next = BVH_EMPTY_SLOT;
        for (uint k = m; k-- > 0u;) {
            if (sc[k]) continue;
            if (next != BVH_EMPTY_SLOT && sp < BVH_WIDE_STACK) stack[sp++] = next;
            next = sr[k];
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
