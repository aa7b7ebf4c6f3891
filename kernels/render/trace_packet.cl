/* trace_packet.cl — packet traversal: the LANES rays of a lane build walk the
 * BVH together (Wald et al., "Interactive Rendering with Coherent Ray
 * Tracing", 2001; the "any lane" rule of packet tracers).
 *
 * A node's two child boxes are slab-tested against every ray of the packet
 * at once; a child is entered when at least one active ray hits its box, and
 * a leaf's primitives are intersected with all those rays in vector
 * registers.  Each ray keeps its own closest distance, so the rays that do
 * not need a subtree simply fail its box tests.  For the scenes this
 * renderer targets (tens to thousands of primitives, incoherent secondary
 * rays) this replaces LANES scalar traversals — whose branches and scalar
 * arithmetic dominated the megakernel (measured: about 96 % of its time at
 * LANES = 8) — by one traversal of vector instructions.
 *
 * Closest hits walk bvh.cl's binary tree (layout in mcocl/render/bvh.py:
 * internal node k at nodes[1 + 4k ..] holds its two children's boxes and
 * references), the child most of the packet reaches first going first, so
 * that ties between primitives resolve as they always have.  Shadow rays
 * walk the 8-wide tree of the single-ray traversal (mcocl/render/bvh_wide.py):
 * a visit tests up to eight child boxes for the whole packet, so a packet
 * makes fewer visits (the wide tree is about a third as deep), and a visit
 * ends in branches the CPU mispredicts; occlusion is an "or" over the
 * primitives, so the walk cannot change the answer (5-6 % less CPU per spp
 * on scenes/many_lights.json, 4-5 % on veach_mis.json).  The ray–primitive
 * tests reproduce intersect.cl's (Möller–Trumbore with the same widened
 * edges, the same stable sphere quadratic) over lanes, and
 * tests/test_render_trace.py checks the packet traversal against bvh.cl's
 * trace_closest / trace_any ray by ray.
 */
#ifndef MCOCL_RENDER_TRACE_PACKET_CL
#define MCOCL_RENDER_TRACE_PACKET_CL

#include "render/vec3.cl"
#include "render/bvh.cl"

#define PACKET_STACK 64 /* > bvh.py MAX_DEPTH */

/* Möller–Trumbore for every lane against one triangle: v0 = a, edges e1, e2 (intersect_triangle_edges). */
MC_INLINE intv packet_triangle(float4 a, float4 e1, float4 e2, vec3v o, vec3v d, floatv tmax, floatv *t_out,
                               floatv *u_out, floatv *v_out) {
    vec3v pv = v3(d.y * e2.z - d.z * e2.y, d.z * e2.x - d.x * e2.z, d.x * e2.y - d.y * e2.x);
    floatv det = e1.x * pv.x + e1.y * pv.y + e1.z * pv.z;
    floatv inv = 1.0f / det;
    vec3v tv = v3(o.x - a.x, o.y - a.y, o.z - a.z);
    floatv u = v3_dot(tv, pv) * inv;
    vec3v qv = v3(tv.y * e1.z - tv.z * e1.y, tv.z * e1.x - tv.x * e1.z, tv.x * e1.y - tv.y * e1.x);
    floatv v = v3_dot(d, qv) * inv;
    floatv t = (e2.x * qv.x + e2.y * qv.y + e2.z * qv.z) * inv;
    intv ok = (u >= -TRI_EDGE_EPS) & (v >= -TRI_EDGE_EPS) & (u + v <= 1.0f + TRI_EDGE_EPS) & (t > 0.0f) &
              (t < tmax) & (det != 0.0f);
    *t_out = t;
    *u_out = u;
    *v_out = v;
    return ok;
}

/* The nearest sphere root in (0, tmax) for every lane (intersect_sphere). */
MC_INLINE intv packet_sphere(float4 s, vec3v o, vec3v d, floatv tmax, floatv *t_out) {
    vec3v f = v3(o.x - s.x, o.y - s.y, o.z - s.z);
    floatv a = v3_dot(d, d);
    floatv b = v3_dot(f, d);
    floatv c = v3_dot(f, f) - s.w * s.w;
    vec3v l = v3_sub(f, v3_scale(d, b / a));
    floatv disc = a * (s.w * s.w - v3_dot(l, l));
    floatv q = -(b + lane_copysign(lane_sqrt(lane_max(disc, 0.0f)), b));
    floatv t0 = q / a, t1 = c / q;
    floatv tn = lane_min(t0, t1), tf = lane_max(t0, t1);
    floatv t = lane_select(tf, tn, tn > 0.0f);
    *t_out = t;
    return (disc >= 0.0f) & (t > 0.0f) & (t < tmax);
}

/* Slab test of one box for every lane (bvh.cl's, bvh_wide_children); lanes with tmax < 0 never hit. */
MC_INLINE intv packet_box(float4 lo, float4 hi, vec3v o, vec3v inv, floatv tmax, floatv *tnear) {
    floatv tx0 = (lo.x - o.x) * inv.x, tx1 = (hi.x - o.x) * inv.x;
    floatv ty0 = (lo.y - o.y) * inv.y, ty1 = (hi.y - o.y) * inv.y;
    floatv tz0 = (lo.z - o.z) * inv.z, tz1 = (hi.z - o.z) * inv.z;
    floatv tn = lane_max(lane_max(lane_min(tx0, tx1), lane_min(ty0, ty1)), lane_max(lane_min(tz0, tz1), (floatv)(0.0f)));
    floatv tf = lane_min(lane_min(lane_max(tx0, tx1), lane_max(ty0, ty1)), lane_min(lane_max(tz0, tz1), tmax)) * BVH_TFAR_SCALE;
    *tnear = tn;
    return tn <= tf;
}

MC_INLINE vec3v packet_inv_dir(vec3v d) {
    return v3(1.0f / lane_select(d.x, (floatv)(1e-30f), d.x == 0.0f), 1.0f / lane_select(d.y, (floatv)(1e-30f), d.y == 0.0f),
              1.0f / lane_select(d.z, (floatv)(1e-30f), d.z == 0.0f));
}

/* Intersect the leaf prims[first .. first + count) (its leaf records, bvh.cl) with the lanes in `m`. */
MC_INLINE void packet_leaf_closest(const scene_geom *g, uint first, uint count, vec3v o, vec3v d, intv m,
                                   floatv *tbest, uintv *prim, floatv *b1, floatv *b2) {
    for (uint k = first; k < first + count; ++k) {
        global const float4 *r = g->leaves + LEAF_PRIM_QUADS * k;
        float4 r0 = r[0], r1 = r[1];
        uint p = as_uint(r0.w);
        floatv t, u = (floatv)(0.0f), v = (floatv)(0.0f);
        intv ok;
        if (p < g->ntris) {
            ok = packet_triangle(r0, r1, r[2], o, d, *tbest, &t, &u, &v);
        } else {
            ok = packet_sphere(r1, o, d, *tbest, &t);
        }
        ok &= m;
        *tbest = lane_select(*tbest, t, ok);
        *prim = lane_select(*prim, (uintv)(p), ok);
        *b1 = lane_select(*b1, u, ok);
        *b2 = lane_select(*b2, v, ok);
    }
}

MC_INLINE intv packet_leaf_any(const scene_geom *g, uint first, uint count, vec3v o, vec3v d, intv m, floatv tmax) {
    intv occ = m & (intv)(0);
    for (uint k = first; k < first + count; ++k) {
        global const float4 *r = g->leaves + LEAF_PRIM_QUADS * k;
        float4 r0 = r[0], r1 = r[1];
        uint p = as_uint(r0.w);
        floatv t, u, v;
        intv ok;
        if (p < g->ntris) {
            ok = packet_triangle(r0, r1, r[2], o, d, tmax, &t, &u, &v);
        } else {
            ok = packet_sphere(r1, o, d, tmax, &t);
        }
        occ |= ok & m;
        if (lane_all(occ | !m)) break;
    }
    return occ;
}

/* Number of true lanes of a mask, by adding vector halves (lane_sum_u stores
 * the vector to memory through a library call on PoCL's wheel). */
#if LANES == 1
#define mask_count(m) ((uint)((m) != 0))
#elif LANES == 2
#define mask_count(m) ((uint)(-((m).x + (m).y)))
#elif LANES == 4
MC_INLINE uint mask_count(int4 m) { int2 a = m.lo + m.hi; return (uint)(-(a.x + a.y)); }
#elif LANES == 8
MC_INLINE uint mask_count(int8 m) { int4 b = m.lo + m.hi; int2 a = b.lo + b.hi; return (uint)(-(a.x + a.y)); }
#else
MC_INLINE uint mask_count(int16 m) {
    int8 c = m.lo + m.hi; int4 b = c.lo + c.hi; int2 a = b.lo + b.hi;
    return (uint)(-(a.x + a.y));
}
#endif

/* Closest hits of the active lanes (t = INFINITY where none). */
MC_INLINE void packet_closest(const scene_geom *g, vec3v o, vec3v d, intv active, floatv *t_out, uintv *prim,
                              floatv *b1, floatv *b2) {
    floatv tbest = lane_select((floatv)(-1.0f), (floatv)(INFINITY), active);
    *prim = (uintv)(0u);
    *b1 = (floatv)(0.0f);
    *b2 = (floatv)(0.0f);
    if (as_uint(g->nodes[0].x) != 0u && lane_any(active)) {
        vec3v inv = packet_inv_dir(d);
        uint stack[PACKET_STACK];
        uint sp = 0, node = 0;
        for (;;) {
            global const float4 *nd = g->nodes + 1 + 4 * node;
            float4 a0 = nd[0], a1 = nd[1], c0 = nd[2], c1 = nd[3];
            floatv tn0, tn1;
            intv h0 = packet_box(a0, a1, o, inv, tbest, &tn0);
            intv h1 = packet_box(c0, c1, o, inv, tbest, &tn1);
            uint r0 = as_uint(a0.w), n0 = as_uint(a1.w), r1 = as_uint(c0.w), n1 = as_uint(c1.w);
            bool any0 = lane_any(h0), any1 = lane_any(h1);
            /* the child most of the packet reaches first goes first */
            if (any0 && any1 && 2u * mask_count(h0 & h1 & (tn1 < tn0)) > mask_count(h0 & h1)) {
                uint tr = r0; r0 = r1; r1 = tr;
                uint tc = n0; n0 = n1; n1 = tc;
                intv th = h0; h0 = h1; h1 = th;
            } else if (!any0) {
                r0 = r1; n0 = n1; h0 = h1; any0 = any1; any1 = false;
            }
            if (any0 && n0) {
                packet_leaf_closest(g, r0, n0, o, d, h0, &tbest, prim, b1, b2);
                any0 = false;
            }
            if (any1 && n1) {
                packet_leaf_closest(g, r1, n1, o, d, h1, &tbest, prim, b1, b2);
                any1 = false;
            }
            if (any0) {
                if (any1 && sp < PACKET_STACK) stack[sp++] = r1;
                node = r0;
                continue;
            }
            if (any1) {
                node = r1;
                continue;
            }
            if (sp == 0) break;
            node = stack[--sp];
        }
    }
    *t_out = lane_select((floatv)(INFINITY), tbest, active);
}

/* The float offset of a wide node's field for child 0 (bvh_wide_node, layouts.cl: each field is two
 * float4 rows, children 0-3 then 4-7, so child c's value is c floats further). */
#define WIDE_FIELD(F) (4u * BVH_WIDE_NODE_##F##_0_QUAD)
#define WIDE_LO_X WIDE_FIELD(LO_X)
#define WIDE_LO_Y WIDE_FIELD(LO_Y)
#define WIDE_LO_Z WIDE_FIELD(LO_Z)
#define WIDE_HI_X WIDE_FIELD(HI_X)
#define WIDE_HI_Y WIDE_FIELD(HI_Y)
#define WIDE_HI_Z WIDE_FIELD(HI_Z)
#define WIDE_REF WIDE_FIELD(REF)
#define WIDE_CNT WIDE_FIELD(CNT)

/* Occlusion of the segments o + t d, 0 < t < tmax, of the active lanes, over the 8-wide tree
 * (bvh.cl's layout, mcocl/render/bvh_wide.py): each visit tests the children one box at a time for
 * the whole packet, intersects the leaves hit at once and stacks the internal children hit. */
MC_INLINE intv packet_any(const scene_geom *g, vec3v o, vec3v d, floatv tmax, intv active) {
    intv occ = active & (intv)(0);
    if (as_uint(g->nodes[0].x) == 0u || !lane_any(active)) return occ;
    vec3v inv = packet_inv_dir(d);
    floatv tm = lane_select((floatv)(-1.0f), tmax, active);
    uint stack[BVH_WIDE_STACK];
    uint sp = 0, node = 0;
    for (;;) {
        global const float *nf = (global const float *)(g->wide + BVH_WIDE_NODE_QUADS * node);
        global const uint *nu = (global const uint *)nf;
        for (uint c = 0; c < 8u; ++c) {
            const uint cnt = nu[WIDE_CNT + c];
            if (cnt == BVH_EMPTY_SLOT) continue;
            float4 lo = (float4)(nf[WIDE_LO_X + c], nf[WIDE_LO_Y + c], nf[WIDE_LO_Z + c], 0.0f);
            float4 hi = (float4)(nf[WIDE_HI_X + c], nf[WIDE_HI_Y + c], nf[WIDE_HI_Z + c], 0.0f);
            floatv tn;
            intv h = packet_box(lo, hi, o, inv, tm, &tn);
            if (!lane_any(h)) continue;
            const uint ref = nu[WIDE_REF + c];
            if (cnt) {
                occ |= packet_leaf_any(g, ref, cnt, o, d, h, tm);
                tm = lane_select(tm, (floatv)(-1.0f), occ);
            } else if (sp < BVH_WIDE_STACK) {
                stack[sp++] = ref;
            }
        }
        if (sp == 0 || lane_all(occ | !active)) break;
        node = stack[--sp];
    }
    return occ;
}

#endif
