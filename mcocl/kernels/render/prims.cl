/* prims.cl — per-lane access to the scene's primitives, read straight from
 * the CompiledScene arrays whose layout is the renderer's contract:
 *   tri_vertices float (T, 3, 4): v0, v1, v2 (w unused), front = CCW,
 *                                 n = normalize(cross(v1 - v0, v2 - v0));
 *   spheres      float (S, 4): centre xyz, radius; sphere_flip uint (S,);
 *   primitive p < T is triangle p, p >= T is sphere p - T.
 * (The BVH and ray traversal are bvh.cl's; everything a shading point or a
 * light sample needs besides the traversal is here, over lanes.)
 */
#ifndef MCOCL_RENDER_PRIMS_CL
#define MCOCL_RENDER_PRIMS_CL

#include "render/vec3.cl"
#include "sampling/gather.cl"

typedef struct {
    global const float *tris;       /* T * 12 floats */
    global const float *spheres;    /* S * 4 floats */
    global const uint *sphere_flip; /* S */
    uint ntris, nspheres;
} prim_tables;

RT_INLINE intv prim_is_sphere(const prim_tables *pt, uintv prim) { return prim >= (uintv)(pt->ntris); }

/* Vertex k of triangle `tri` (lanes must hold valid triangle ids). */
RT_INLINE vec3v tri_vertex(const prim_tables *pt, uintv tri, uint k) {
    uintv b = tri * 12u + 4u * k;
    return v3(gather_float(pt->tris, b), gather_float(pt->tris, b + 1u), gather_float(pt->tris, b + 2u));
}

/* Centre and radius of sphere `sph` (an index among spheres). */
RT_INLINE vec3v sphere_center(const prim_tables *pt, uintv sph, floatv *radius) {
    uintv b = sph * 4u;
    *radius = gather_float(pt->spheres, b + 3u);
    return v3(gather_float(pt->spheres, b), gather_float(pt->spheres, b + 1u), gather_float(pt->spheres, b + 2u));
}

/* Triangle area and unit front normal. */
RT_INLINE vec3v tri_normal_area(vec3v v0, vec3v v1, vec3v v2, floatv *area) {
    vec3v c = v3_cross(v3_sub(v1, v0), v3_sub(v2, v0));
    floatv l = rt_sqrt(v3_len2(c));
    *area = 0.5f * l;
    return v3_scale(c, 1.0f / l);
}

/* Position and unit front normal of a ray hit.  Triangles interpolate the
 * vertices with the barycentrics (b1, b2) of v1, v2, which is more accurate
 * than o + t d; sphere hits are projected back onto the sphere (pbrt-v4
 * §6.8.5 does the same to bound the error). */
RT_INLINE vec3v prim_hit_point(const prim_tables *pt, uintv prim, floatv b1, floatv b2, vec3v o, vec3v d, floatv t,
                               intv active, vec3v *n) {
    vec3v p = v3_madd(o, t, d);
    vec3v nn = v3(0.0f, 0.0f, 1.0f);
    intv sph = prim_is_sphere(pt, prim);
    intv tri_lanes = active & !sph;
    if (pt->ntris > 0u && rt_any(tri_lanes)) {
        uintv tri = rt_select((uintv)(0u), prim, tri_lanes);
        vec3v v0 = tri_vertex(pt, tri, 0), v1 = tri_vertex(pt, tri, 1), v2 = tri_vertex(pt, tri, 2);
        vec3v e1 = v3_sub(v1, v0), e2 = v3_sub(v2, v0);
        vec3v pt_ = v3_madd(v3_madd(v0, b1, e1), b2, e2);
        vec3v c = v3_cross(e1, e2);
        p = v3_select(p, pt_, tri_lanes);
        nn = v3_select(nn, v3_scale(c, rt_rsqrt(v3_len2(c))), tri_lanes);
    }
    intv sph_lanes = active & sph;
    if (pt->nspheres > 0u && rt_any(sph_lanes)) {
        uintv s = rt_select((uintv)(0u), prim - pt->ntris, sph_lanes);
        floatv r;
        vec3v c = sphere_center(pt, s, &r);
        vec3v dn = v3_normalize(v3_sub(p, c));
        vec3v ps = v3_madd(c, r, dn);
        intv flip = to_intv(GATHER(uint, pt->sphere_flip, s)) != 0;
        p = v3_select(p, ps, sph_lanes);
        nn = v3_select(nn, v3_select(dn, v3_neg(dn), flip), sph_lanes);
    }
    *n = nn;
    return p;
}

/* Self-intersection guard (Mitsuba 3's spawn_ray): move a ray origin off the
 * surface along the geometric normal, to the side of the outgoing direction,
 * by an amount that grows with the coordinates' magnitude, since float
 * rounding error of a position does. */
#define RAY_EPSILON 8.940697e-05f /* 1500 * 2^-24, Mitsuba 3's math::RayEpsilon */
#define SHADOW_EPSILON 8.940697e-04f

RT_INLINE vec3v offset_origin(vec3v p, vec3v n, vec3v w) {
    floatv eps = (1.0f + v3_maxabs(p)) * RAY_EPSILON;
    return v3_madd(p, rt_copysign(eps, v3_dot(n, w)), n);
}

#endif
