/* shading_normal.cl — shading normals interpolated from a mesh's vertex
 * normals, with the light-leak guard and the adjoint correction of light
 * tracing (Veach's thesis §5.3).  Built only with -DSHADING_NORMALS (the host
 * sets it when a triangle has vertex normals: mcocl/render/shading_normals.py),
 * so scenes without them compile and render exactly as before.
 *
 * vertex_normals (mcocl/render/shading_normals.py): row t < T is triangle t's
 * record, the rows of its corners' world-space unit normals (in the order of
 * tri_vertices) as uint bits in x, y, z, and in w +1, -1 (the host turned the
 * triangle's normals to the face's front side by negating them) or 0 (no
 * normals: it shades with its face normal); the vertex normals follow, one
 * float4 per vertex.  The hit's barycentrics b1, b2 weigh corners 1 and 2
 * (render/intersect.cl).  A negated triangle's blend is negated after the
 * blend: negation is exact, so that is the blend of the negated normals.
 *
 * With a shading normal ns and the geometric normal ng, the BSDF is
 * evaluated in the frame of ns and a cosine |w . ns| replaces |w . ng| for
 * the direction w towards the light; on the geometric measure this is the
 * BSDF f'(w_light -> w_view) = f_s |w_light . ns| / |w_light . ng|, which is
 * not symmetric.  Path tracing samples w_light and needs nothing more.
 * Light tracing transports importance with the adjoint of f', so each of
 * its scattering events (and its connection to the camera) takes the factor
 *     |w_light . ns| |w_view . ng| / (|w_light . ng| |w_view . ns|)
 * on top of the f_s |w_view . ns| that the BSDF gives (thesis eq. 5.17-5.19).
 * Light leaks: a direction on one side of the shading surface and the other
 * side of the geometric one carries nothing, in both estimators alike. */
#ifndef MCOCL_RENDER_SHADING_NORMAL_CL
#define MCOCL_RENDER_SHADING_NORMAL_CL

#include "render/vec3.cl"
#include "render/lane_io.cl"
#include "render/prims.cl"

/* The shading normal at a hit: the normalised barycentric blend of the
 * triangle's vertex normals, or ng (spheres, triangles without normals,
 * inactive lanes, a blend that vanishes). */
MC_INLINE vec3v shading_normal(global const float4 *vn, const prim_tables *pt, uintv prim, floatv b1, floatv b2,
                               vec3v ng, intv active) {
    intv tri = active & !prim_is_sphere(pt, prim);
    /* (a row t < T always holds rows of the table: those of its normals, or 0) */
    rec4v corner = gather_rec4(vn, lane_select((uintv)(0u), prim, tri));
    rec4v a = gather_rec4(vn, lane_as_uint(corner.x)), b = gather_rec4(vn, lane_as_uint(corner.y)),
          c = gather_rec4(vn, lane_as_uint(corner.z));
    floatv b0 = 1.0f - b1 - b2;
    vec3v ns = v3(b0 * a.x + b1 * b.x + b2 * c.x, b0 * a.y + b1 * b.y + b2 * c.y, b0 * a.z + b1 * b.z + b2 * c.z);
    ns = v3_select(ns, v3(-ns.x, -ns.y, -ns.z), corner.w < 0.0f);
    floatv len2 = v3_len2(ns);
    intv use = tri & (corner.w != 0.0f) & (len2 > 1e-12f);
    ns = v3_scale(ns, lane_rsqrt(lane_select((floatv)(1.0f), len2, use)));
    return v3_select(ng, ns, use);
}

/* Whether w lies on the same side of the shading and the geometric surface. */
MC_INLINE intv shading_side_agrees(vec3v ng, vec3v ns, vec3v w) {
    return (v3_dot(ng, w) > 0.0f) == (v3_dot(ns, w) > 0.0f);
}

/* The adjoint correction of an importance-transport event (light tracing):
 * |w_light . ns| |w_view . ng| / (|w_light . ng| |w_view . ns|), 0 where a cosine vanishes. */
MC_INLINE floatv shading_adjoint(vec3v ng, vec3v ns, vec3v w_light, vec3v w_view) {
    floatv num = lane_abs(v3_dot(w_light, ns)) * lane_abs(v3_dot(w_view, ng));
    floatv den = lane_abs(v3_dot(w_light, ng)) * lane_abs(v3_dot(w_view, ns));
    intv ok = (den > 0.0f) & shading_side_agrees(ng, ns, w_light) & shading_side_agrees(ng, ns, w_view);
    return lane_select((floatv)(0.0f), num / lane_select((floatv)(1.0f), den, ok), ok);
}

#endif
