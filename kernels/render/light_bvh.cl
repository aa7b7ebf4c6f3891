/* light_bvh.cl — choosing an area light from the shading point through the
 * light BVH (Conty Estevez & Kulla 2018; pbrt-v4's BVHLightSampler), and
 * the probability of that choice for a given light (the MIS weight of an
 * emitter found by BSDF sampling).
 *
 * The tree is built on the host (mcocl/render/light_bvh.py): node records
 * light_bvh_node (layouts.cl) with a bounding sphere, power, orientation
 * cone (axis, cos theta_o), cos theta_e and the number of lights below;
 * node 0 is the root, the children of an internal node are nodes ref and
 * ref + 1, a leaf (count 1) has a light as ref (light_record index).  light_trail[prim] is the root-to-leaf path of an
 * emitting primitive (bit d: second child at depth d).
 *
 * Importance of a node seen from p with normal n (pbrt-v4 §12.6.3,
 * LightBounds::Importance): with the node's bounding sphere (centre c,
 * radius r), w the unit direction from c to p, theta_w the angle between the
 * cone axis and w, theta_b the half-angle the sphere subtends from p (pi
 * when p is inside), theta' = max(0, theta_w - theta_o - theta_b):
 *     I = power * cos(theta') / max(|p - c|^2, r^2) * cos(max(0, theta_i - theta_b))
 * and 0 when theta' >= theta_e (no emitter below faces p); theta_i is the
 * angle between n and w (taken two-sided; n = 0 drops the factor).  I is a
 * heuristic: any value is unbiased as long as it is 0 only for lights that
 * cannot reach p.
 *
 * Exact probabilities.  The walk does not rescale the uniform u.  The
 * uniforms are the 2^23 cell centres of rng/uniform.cl; the walk keeps the
 * range [A, B) of cells (integers) that reach the current node and gives the
 * first child the cells below M = A + round((B - A) I0 / (I0 + I1)): cell
 * m = floor(u 2^23) takes the first child when m < M.  The probability of a
 * light is then exactly (B - A) 2^-23 at its leaf.  M is clamped so that a
 * child with I > 0 keeps at least as many cells as it has lights (count of
 * the node record; the root has 2^23 >= the number of lights), so every light
 * the importance does not rule out gets at least one cell: a light that can
 * reach the point is never given probability 0 by rounding.  light_bvh_pmf
 * walks the same nodes by the light's trail with the same arithmetic (one
 * function, light_bvh_walk), so it reproduces the sampling probability bit
 * for bit.
 *
 * Flat trees.  A tree of 2..16 area lights is a root (its count carrying
 * LIGHT_BVH_FLAT_FLAG) and the leaves 1..L in light order, the trail of a
 * light its index (mcocl/render/light_bvh.py).  light_bvh_flat weighs every
 * leaf at once: the records are the same for all lanes (read once, no
 * gathers, no lanes waiting for the deepest walk), and the cells are dealt
 * out in proportion to the leaf importances with the same exactness.
 */
#ifndef MCOCL_RENDER_LIGHT_BVH_CL
#define MCOCL_RENDER_LIGHT_BVH_CL

#include "layouts.cl"
#include "rng/uniform.cl"
#include "render/vec3.cl"
#include "render/lane_io.cl"
#include "sampling/gather.cl"

/* A flat tree (mcocl/render/light_bvh.py, FLAT_LIGHTS and FLAT_FLAG): the root's count carries
 * the flag bit beside its at most LIGHT_BVH_FLAT_MAX lights, leaves 1..L follow it. */
#define LIGHT_BVH_FLAT_MAX 16u
#define LIGHT_BVH_FLAT_FLAG 0x80000000u

/* The choice probability of every leaf of a flat tree at one shading point, lane by lane, as
 * light_bvh_flat dealt them out while sampling (pmf[k]: exactly what light_bvh_pmf returns for leaf k
 * there), so that the MIS weight of an emitter hit found from the same point (integrator.cl: the
 * previous vertex's prev_up and prev_n are the point and normal its light sample used) reads it instead
 * of weighing the leaves again.  valid: set by the sampling, cleared by the integrator before each vertex. */
typedef struct {
    floatv pmf[LIGHT_BVH_FLAT_MAX];
    int valid;
} light_choice_memo;

/* cos(max(0, alpha - beta)) from the sines and cosines of alpha and beta in [0, pi]. */
MC_INLINE floatv cos_sub_clamped(floatv sin_a, floatv cos_a, floatv sin_b, floatv cos_b) {
    return lane_select(cos_a * cos_b + sin_a * sin_b, (floatv)(1.0f), cos_a > cos_b);
}

/* sin(max(0, alpha - beta)), as above. */
MC_INLINE floatv sin_sub_clamped(floatv sin_a, floatv cos_a, floatv sin_b, floatv cos_b) {
    return lane_select(sin_a * cos_b - cos_a * sin_b, (floatv)(0.0f), cos_a > cos_b);
}

/* The importance of node record q (LIGHT_BVH_NODE_GATHER) for point p with normal n (see the header). */
#define LIGHT_BVH_IMPORTANCE(q, p, n, has_n) \
    light_bvh_importance(REC_VEC3(q, LIGHT_BVH_NODE_CENTER), REC_FIELD(q, LIGHT_BVH_NODE_RADIUS2), \
                         REC_FIELD(q, LIGHT_BVH_NODE_POWER), REC_VEC3(q, LIGHT_BVH_NODE_AXIS), \
                         REC_FIELD(q, LIGHT_BVH_NODE_COS_O), REC_FIELD(q, LIGHT_BVH_NODE_COS_E), p, n, has_n)

MC_INLINE floatv light_bvh_importance(vec3v c, floatv r2, floatv power, vec3v axis, floatv cos_o, floatv cos_e,
                                      vec3v p, vec3v n, intv has_n) {
    vec3v dv = v3_sub(p, c);
    floatv d2 = v3_len2(dv);
    vec3v w = v3_scale(dv, lane_rsqrt(lane_max(d2, (floatv)(1e-30f))));
    floatv cos_w = v3_dot(axis, w);
    floatv sin_w = safe_sqrt(1.0f - cos_w * cos_w);
    intv inside = d2 < r2;
    floatv sin2_b = lane_min(r2 / d2, (floatv)(1.0f));
    floatv cos_b = lane_select(safe_sqrt(1.0f - sin2_b), (floatv)(-1.0f), inside);
    floatv sin_b = lane_select(lane_sqrt(sin2_b), (floatv)(0.0f), inside);
    floatv sin_o = safe_sqrt(1.0f - cos_o * cos_o);
    floatv cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, cos_o);
    floatv sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, cos_o);
    floatv cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
    floatv imp = power * cos_p / lane_max(d2, r2);
    floatv cos_i = lane_abs(v3_dot(w, n));
    floatv sin_i = safe_sqrt(1.0f - cos_i * cos_i);
    floatv recv = lane_max(cos_sub_clamped(sin_i, cos_i, sin_b, cos_b), (floatv)(0.0f));
    imp = lane_select(imp, imp * recv, has_n);
    return lane_select((floatv)(0.0f), imp, (cos_p > cos_e) & (imp > 0.0f));
}

/* light_bvh_importance of a leaf with cos theta_o = -1 (a sphere or another emitter that shines every way,
 * mcocl/render/light_bvh.py), for which the cone terms drop out: with theta_o = pi (sin_o = 0),
 * cos(max(0, theta_w - theta_o)) = 1 and its sine 0 for every finite cos theta_w (cos_sub_clamped's
 * select gives 1 for cos_w > -1; for cos_w <= -1, sin_w = 0 and cos_w cos_o + sin_w sin_o = -cos_w >= 1,
 * sin_x = +-0), so cos theta' = 1 (1 > cos_b, or 1 * 1 + (+-0) sin_b when cos_b = 1) and
 * power * cos theta' = power: the same floats as the general function without the two square roots of
 * sin_w and sin_o.  A NaN cos_w (a NaN or infinite p - c) gave a NaN cos theta' and so importance 0: the
 * test cos_w == cos_w keeps that. */
MC_INLINE floatv light_bvh_importance_omni(vec3v c, floatv r2, floatv power, vec3v axis, float cos_e, vec3v p,
                                           vec3v n, intv has_n) {
    vec3v dv = v3_sub(p, c);
    floatv d2 = v3_len2(dv);
    vec3v w = v3_scale(dv, lane_rsqrt(lane_max(d2, (floatv)(1e-30f))));
    floatv cos_w = v3_dot(axis, w);
    intv inside = d2 < r2;
    floatv sin2_b = lane_min(r2 / d2, (floatv)(1.0f));
    floatv cos_b = lane_select(safe_sqrt(1.0f - sin2_b), (floatv)(-1.0f), inside);
    floatv sin_b = lane_select(lane_sqrt(sin2_b), (floatv)(0.0f), inside);
    floatv imp = power / lane_max(d2, r2);
    floatv cos_i = lane_abs(v3_dot(w, n));
    floatv sin_i = safe_sqrt(1.0f - cos_i * cos_i);
    floatv recv = lane_max(cos_sub_clamped(sin_i, cos_i, sin_b, cos_b), (floatv)(0.0f));
    imp = lane_select(imp, imp * recv, has_n);
    return lane_select((floatv)(0.0f), imp, (intv)(1.0f > cos_e ? -1 : 0) & (cos_w == cos_w) & (imp > 0.0f));
}

/* Field F of node i read once for all lanes (flat trees: every lane evaluates the same leaves). */
#define LIGHT_BVH_SCALAR(nodes, i, F) (nodes)[(i) * LIGHT_BVH_NODE_QUADS + F##_QUAD].F##_COMP
#define LIGHT_BVH_SCALAR3(nodes, i, F)                                                                        \
    v3((floatv)((nodes)[(i) * LIGHT_BVH_NODE_QUADS + F##_QUAD].F##_COMP),                                     \
       (floatv)((nodes)[(i) * LIGHT_BVH_NODE_QUADS + F##_QUAD].F##_COMP1),                                    \
       (floatv)((nodes)[(i) * LIGHT_BVH_NODE_QUADS + F##_QUAD].F##_COMP2))

/* The choice among the leaves 1..L of a flat tree (L <= LIGHT_BVH_FLAT_MAX lights), by u
 * (by_trail 0) or of light trail (by_trail 1); same contract as light_bvh_walk.  With I_k the
 * importance of leaf k, S_k = I_0 + ... + I_{k-1} (summed in this order), T = S_L and P the number of
 * lights with I_k > 0, light k owns the cells [B_k, B_{k+1}) of the 2^23 with
 *     B_k = round((2^23 - P) S_k / T) + #{j < k : I_j > 0},
 * so B_0 = 0, B_L = 2^23 and every light with I_k > 0 owns at least one cell; light_bvh_pmf runs the
 * same arithmetic, so the probability (B_{k+1} - B_k) 2^-23 is reproduced bit for bit. */
MC_INLINE uintv light_bvh_flat(global const float4 *nodes, uint count, vec3v p, vec3v n, uintv cell, uintv trail,
                               const int by_trail, intv active, floatv *pmf, light_choice_memo *memo) {
    intv has_n = v3_len2(n) > 0.0f;
    floatv imp[LIGHT_BVH_FLAT_MAX];
    floatv total = (floatv)(0.0f);
    uintv positive = (uintv)(0u);
    for (uint k = 0u; k < count; ++k) {
        uint i = k + 1u;
        const float cos_o = LIGHT_BVH_SCALAR(nodes, i, LIGHT_BVH_NODE_COS_O);
        if (cos_o == -1.0f) /* the same for every lane: sphere lights skip the cone terms */
            imp[k] = light_bvh_importance_omni(LIGHT_BVH_SCALAR3(nodes, i, LIGHT_BVH_NODE_CENTER),
                                               (floatv)(LIGHT_BVH_SCALAR(nodes, i, LIGHT_BVH_NODE_RADIUS2)),
                                               (floatv)(LIGHT_BVH_SCALAR(nodes, i, LIGHT_BVH_NODE_POWER)),
                                               LIGHT_BVH_SCALAR3(nodes, i, LIGHT_BVH_NODE_AXIS),
                                               LIGHT_BVH_SCALAR(nodes, i, LIGHT_BVH_NODE_COS_E), p, n, has_n);
        else
            imp[k] = light_bvh_importance(LIGHT_BVH_SCALAR3(nodes, i, LIGHT_BVH_NODE_CENTER),
                                          (floatv)(LIGHT_BVH_SCALAR(nodes, i, LIGHT_BVH_NODE_RADIUS2)),
                                          (floatv)(LIGHT_BVH_SCALAR(nodes, i, LIGHT_BVH_NODE_POWER)),
                                          LIGHT_BVH_SCALAR3(nodes, i, LIGHT_BVH_NODE_AXIS), (floatv)(cos_o),
                                          (floatv)(LIGHT_BVH_SCALAR(nodes, i, LIGHT_BVH_NODE_COS_E)), p, n, has_n);
        total += imp[k];
        positive += lane_select((uintv)(0u), (uintv)(1u), imp[k] > 0.0f);
    }
    floatv spread = to_floatv((uintv)(UNIFORM_CELLS) - positive);
    floatv sum = (floatv)(0.0f);
    uintv below = (uintv)(0u), lo = (uintv)(0u), chosen = (uintv)(0u);
    floatv p_chosen = (floatv)(0.0f);
    if (by_trail) {
        /* The probability of light trail: only its bounds B_trail and B_trail+1 are needed, so the
         * sums S_k and counts below it are kept by selects and the two bounds computed once each (the
         * same expressions as below, B_0 = 0 as there) instead of one division per light. */
        floatv sum_lo = sum, sum_hi = sum;
        uintv below_lo = below, below_hi = below;
        intv lit_t = active & (intv)(0);
        for (uint k = 0u; k < count; ++k) {
            intv lit = imp[k] > 0.0f;
            intv at = trail == (uintv)(k);
            sum_lo = lane_select(sum_lo, sum, at);
            below_lo = lane_select(below_lo, below, at);
            sum += imp[k];
            below += lane_select((uintv)(0u), (uintv)(1u), lit);
            sum_hi = lane_select(sum_hi, sum, at);
            below_hi = lane_select(below_hi, below, at);
            lit_t = lit_t | (at & lit);
            chosen = lane_select(chosen, (uintv)(as_uint(LIGHT_BVH_SCALAR(nodes, k + 1u, LIGHT_BVH_NODE_REF))),
                                 at & lit);
        }
        lo = lane_select(to_uintv(spread * (sum_lo / total) + 0.5f) + below_lo, (uintv)(0u), trail == 0u);
        uintv hi = to_uintv(spread * (sum_hi / total) + 0.5f) + below_hi;
        p_chosen = lane_select((floatv)(0.0f), to_floatv(hi - lo) * UNIFORM_CELL_WIDTH, lit_t);
        intv live = active & (total > 0.0f) & (p_chosen > 0.0f);
        *pmf = lane_select((floatv)(0.0f), p_chosen, live);
        return lane_select((uintv)(0u), chosen, live);
    }
    for (uint k = 0u; k < count; ++k) {
        intv lit = imp[k] > 0.0f;
        sum += imp[k];
        below += lane_select((uintv)(0u), (uintv)(1u), lit);
        uintv hi = to_uintv(spread * (sum / total) + 0.5f) + below;
        intv mine = by_trail ? trail == (uintv)(k) : (cell >= lo) & (cell < hi);
        mine = mine & lit;
        chosen = lane_select(chosen, (uintv)(as_uint(LIGHT_BVH_SCALAR(nodes, k + 1u, LIGHT_BVH_NODE_REF))), mine);
        p_chosen = lane_select(p_chosen, to_floatv(hi - lo) * UNIFORM_CELL_WIDTH, mine);
        if (memo) /* light_bvh_pmf's value for leaf k: (hi - lo) 2^-23 where lit, 0 where no light reaches p */
            memo->pmf[k] = lane_select((floatv)(0.0f), to_floatv(hi - lo) * UNIFORM_CELL_WIDTH, lit & (total > 0.0f));
        lo = hi;
    }
    if (memo) memo->valid = 1;
    intv live = active & (total > 0.0f) & (p_chosen > 0.0f);
    *pmf = lane_select((floatv)(0.0f), p_chosen, live);
    return lane_select((uintv)(0u), chosen, live);
}

/* Walk from the root to a leaf, choosing the child by u (by_trail 0) or by
 * the bits of trail (by_trail 1, a compile-time constant at each call).
 * Returns the light (0 for lanes that found none) and its exact probability. */
MC_INLINE uintv light_bvh_walk(global const float4 *nodes, vec3v p, vec3v n, floatv u, uintv trail,
                               const int by_trail, intv active, floatv *pmf, light_choice_memo *memo) {
    uintv cell = by_trail ? (uintv)(0u) : to_uintv(u * (float)UNIFORM_CELLS); /* u = (cell + 1/2) 2^-23 */
    uint root_count = as_uint(LIGHT_BVH_SCALAR(nodes, 0u, LIGHT_BVH_NODE_COUNT));
    if (root_count & LIGHT_BVH_FLAT_FLAG) /* one branch for every lane: the tree is flat or not */
        return light_bvh_flat(nodes, min(root_count & ~LIGHT_BVH_FLAT_FLAG, LIGHT_BVH_FLAT_MAX), p, n, cell, trail,
                              by_trail, active, pmf, memo);
    intv has_n = v3_len2(n) > 0.0f;
    LIGHT_BVH_NODE_GATHER(r, nodes, (uintv)(0u));
    uintv ref = lane_as_uint(REC_FIELD(r, LIGHT_BVH_NODE_REF));
    intv leaf = lane_as_uint(REC_FIELD(r, LIGHT_BVH_NODE_COUNT)) == 1u;
    uintv lo = (uintv)(0u), hi = (uintv)(UNIFORM_CELLS);
    intv live = active;
    for (uint depth = 0u;; ++depth) {
        intv go = live & !leaf;
        if (!lane_any(go)) break;
        uintv c0 = lane_select((uintv)(0u), ref, go);
        uintv c1 = c0 + 1u;
        LIGHT_BVH_NODE_GATHER(q, nodes, c0);
        LIGHT_BVH_NODE_GATHER(s, nodes, c1);
        floatv i0 = LIGHT_BVH_IMPORTANCE(q, p, n, has_n);
        floatv i1 = LIGHT_BVH_IMPORTANCE(s, p, n, has_n);
        floatv total = i0 + i1;
        uintv share = to_uintv(to_floatv(hi - lo) * (i0 / total) + 0.5f);
        uintv least = lo + lane_select((uintv)(0u), lane_as_uint(REC_FIELD(q, LIGHT_BVH_NODE_COUNT)), i0 > 0.0f);
        uintv most = hi - lane_select((uintv)(0u), lane_as_uint(REC_FIELD(s, LIGHT_BVH_NODE_COUNT)), i1 > 0.0f);
        uintv mid = min(max(lo + share, least), most);
        intv second = by_trail ? ((trail >> depth) & 1u) != 0u : !(cell < mid);
        lo = lane_select(lo, mid, go & second);
        hi = lane_select(hi, mid, go & !second);
        ref = lane_select(ref, lane_select(lane_as_uint(REC_FIELD(q, LIGHT_BVH_NODE_REF)),
                                           lane_as_uint(REC_FIELD(s, LIGHT_BVH_NODE_REF)), second), go);
        intv leaf_next = lane_select(lane_as_uint(REC_FIELD(q, LIGHT_BVH_NODE_COUNT)),
                                     lane_as_uint(REC_FIELD(s, LIGHT_BVH_NODE_COUNT)), second) == 1u;
        leaf = lane_select(leaf, leaf_next, go);
        live = live & (!go | (total > 0.0f)); /* no light below can reach p */
    }
    live = live & leaf & (hi > lo);
    *pmf = lane_select((floatv)(0.0f), to_floatv(hi - lo) * UNIFORM_CELL_WIDTH, live);
    return lane_select((uintv)(0u), ref, live);
}

/* The light chosen from p (normal n; 0: no receiver factor) with uniform u, and its probability. */
MC_INLINE uintv light_bvh_sample(global const float4 *nodes, vec3v p, vec3v n, floatv u, intv active,
                                 floatv *pmf) {
    return light_bvh_walk(nodes, p, n, u, (uintv)(0u), 0, active, pmf, 0);
}

/* light_bvh_sample that also fills memo (when not 0) where the tree is flat. */
MC_INLINE uintv light_bvh_sample_memo(global const float4 *nodes, vec3v p, vec3v n, floatv u, intv active,
                                      floatv *pmf, light_choice_memo *memo) {
    return light_bvh_walk(nodes, p, n, u, (uintv)(0u), 0, active, pmf, memo);
}

/* light_bvh_pmf from a memo filled at the same point and normal (memo->valid): the same floats. */
MC_INLINE floatv light_bvh_memo_pmf(const light_choice_memo *memo, global const float4 *nodes, uintv trail,
                                    intv active) {
    uint count = min(as_uint(LIGHT_BVH_SCALAR(nodes, 0u, LIGHT_BVH_NODE_COUNT)) & ~LIGHT_BVH_FLAT_FLAG,
                     LIGHT_BVH_FLAT_MAX);
    floatv p = (floatv)(0.0f);
    for (uint k = 0u; k < count; ++k) p = lane_select(p, memo->pmf[k], trail == (uintv)(k));
    return lane_select((floatv)(0.0f), p, active & (p > 0.0f));
}

/* The probability that light_bvh_sample from p (normal n) chooses the light with root-to-leaf path trail. */
MC_INLINE floatv light_bvh_pmf(global const float4 *nodes, vec3v p, vec3v n, uintv trail, intv active) {
    floatv pmf;
    light_bvh_walk(nodes, p, n, (floatv)(0.0f), trail, 1, active, &pmf, 0);
    return pmf;
}

#endif
