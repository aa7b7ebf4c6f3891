/* prims.cl — what a shading point needs to know about the primitive a ray hit.
 *
 * The geometry is the CompiledScene contract's (primitive p < T is triangle
 * p, p >= T is sphere p - T; spheres float (S, 4) centre and radius); the
 * BVH and the traversal are bvh.cl's.  For shading, the host
 * (mcocl/render/device_scene.py, prim_records) flattens every primitive into
 * one prim_record (layouts.cl, from mcocl/layouts.py: front unit normal of a
 * triangle (0 for spheres), area, material, emitter (-1 if none), the
 * probability that light sampling chooses it, and whether a sphere's normals
 * point inwards), stored as PRIM_RECORD_QUADS float4, so that a packet of hits
 * costs two record loads per lane instead of a dozen scalar gathers.
 */
#ifndef MCOCL_RENDER_PRIMS_CL
#define MCOCL_RENDER_PRIMS_CL

#include "layouts.cl"
#include "render/vec3.cl"
#include "render/lane_io.cl"

typedef struct {
    global const float4 *spheres;  /* S: centre, radius */
    global const float4 *prim_rec; /* PRIM_RECORD_QUADS float4 per primitive */
    uint ntris, nspheres;
} prim_tables;

/* The primitive tables of a render launch: its buffers and the counts of its render_params. */
MC_INLINE prim_tables prim_tables_of(const render_params *p, global const float4 *spheres,
                                     global const float4 *prim_rec) {
    prim_tables pt;
    pt.spheres = spheres;
    pt.prim_rec = prim_rec;
    pt.ntris = p->ntris;
    pt.nspheres = p->nspheres;
    return pt;
}

MC_INLINE intv prim_is_sphere(const prim_tables *pt, uintv prim) { return prim >= (uintv)(pt->ntris); }

/* A surface point hit by a ray, with its primitive's record. */
typedef struct {
    vec3v p;       /* position */
    vec3v n;       /* unit front normal */
    floatv area;   /* primitive area */
    uintv mat;     /* material index */
    intv emitter;  /* emitter index, -1 if the primitive does not emit */
    floatv pmf;    /* light-choice probability of the primitive */
} surface_v;

/* The surfaces hit by the active lanes.  Positions are o + t d: their float
 * error (~1e-7 t) is far below the spawn offset (prims.cl, offset_origin);
 * sphere hits are projected back onto the sphere (pbrt-v4 §6.8.5). */
MC_INLINE surface_v surface_at(const prim_tables *pt, uintv prim, floatv t, vec3v o, vec3v d, intv active) {
    uintv pr = lane_select((uintv)(0u), prim, active);
    PRIM_RECORD_GATHER(q, pt->prim_rec, pr);
    surface_v s;
    s.p = v3_madd(o, lane_select((floatv)(0.0f), t, active), d);
    s.n = REC_VEC3(q, PRIM_RECORD_NORMAL);
    s.area = REC_FIELD(q, PRIM_RECORD_AREA);
    s.mat = lane_as_uint(REC_FIELD(q, PRIM_RECORD_MATERIAL));
    s.emitter = lane_select((intv)(-1), lane_as_int(REC_FIELD(q, PRIM_RECORD_EMITTER)), active);
    s.pmf = REC_FIELD(q, PRIM_RECORD_PMF);
    intv sph = active & prim_is_sphere(pt, pr);
    if (pt->nspheres > 0u && lane_any(sph)) {
        rec4v c = gather_rec4(pt->spheres, lane_select((uintv)(0u), pr - pt->ntris, sph));
        vec3v cc = v3(c.x, c.y, c.z);
        vec3v dn = v3_normalize(v3_sub(s.p, cc));
        s.p = v3_select(s.p, v3_madd(cc, c.w, dn), sph);
        s.n = v3_select(s.n, v3_select(dn, v3_neg(dn), REC_FIELD(q, PRIM_RECORD_INWARD) != 0.0f), sph);
    }
    s.n = v3_select(v3(0.0f, 0.0f, 1.0f), s.n, active);
    return s;
}

/* Self-intersection guard (Mitsuba 3's spawn_ray): move a ray origin off the
 * surface along the geometric normal, to the side of the outgoing direction,
 * by an amount that grows with the coordinates' magnitude, since float
 * rounding error of a position does. */
#define RAY_EPSILON 8.940697e-05f /* 1500 * 2^-24, Mitsuba 3's math::RayEpsilon */
#define SHADOW_EPSILON 8.940697e-04f

MC_INLINE vec3v offset_origin(vec3v p, vec3v n, vec3v w) {
    floatv eps = (1.0f + v3_maxabs(p)) * RAY_EPSILON;
    return v3_madd(p, lane_copysign(eps, v3_dot(n, w)), n);
}

#endif
