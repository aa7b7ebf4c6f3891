/* intersect.cl — scene geometry seen from a kernel: ray–triangle, ray–sphere,
 * normals, areas and uniform area sampling of primitives.
 *
 * Scalar code (one ray per call); valid in any LANES build.  The data are the
 * tables of mcocl/render/device_scene.py:
 *   triangles: the BVH's leaf records (v0 | p, e1 = v1 - v0, e2 = v2 - v0), triangle p's at
 *            leaves + tri_rows[p] (mcocl/render/bvh_leaves.py); the front side is
 *            counter-clockwise, n = normalize(cross(e1, e2));
 *   spheres: float4 (S): centre xyz, radius; sphere_flip[s] = 1: normal points inwards.
 * Primitive ids: p < ntris is triangle p, p >= ntris is sphere p - ntris.
 *
 * Ray–triangle: Möller–Trumbore (1997) with the barycentric edge tests widened
 * by TRI_EDGE_EPS (relative to the triangle, since barycentrics are), so that
 * a ray through an edge shared by two triangles hits at least one of them:
 * float rounding of u, v is ~1e-7 relative for rays that do not start
 * thousands of triangle sizes away, far below the 2^-20 slack.  This is
 * "watertight enough" for closed scenes (the furnace test), not the exact
 * watertight test of Woop et al. 2013 (pbrt-v4 §6.5.3), which costs a shear
 * per ray and is not needed at these scales.  det == 0 (parallel ray or
 * degenerate triangle) never hits; every comparison is written so that a NaN
 * fails it, so degenerate input cannot produce a hit or a NaN t.
 *
 * Ray–sphere: the quadratic with the discriminant computed as
 * r² − |f − (f·d/d·d) d|² (Haines et al., Ray Tracing Gems ch. 7, eq. 10),
 * which stays accurate for small spheres far away, and the root pair formed
 * from q = −(b + sign(b)·sqrt(Δ)) (no cancellation).
 *
 * Rays have an implicit tmin of 0: a ray leaving a surface must start off it;
 * spawn_origin() below offsets a point along its normal for that.
 */
#ifndef MCOCL_RENDER_INTERSECT_CL
#define MCOCL_RENDER_INTERSECT_CL

#include "lanes.cl"

#ifndef M_PI_F
#define M_PI_F 3.14159265358979323846f
#endif

#define TRI_EDGE_EPS 9.5367431640625e-7f /* 2^-20 */

/* Hand-written float3 helpers for the hot paths: the PoCL wheel does not
 * inline OpenCL built-ins (dot, cross, fmin, fmax are out-of-line calls per
 * component there, docs/pocl-notes.md), which made traversal ~20x slower. */
MC_INLINE float g3_dot(float3 a, float3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
MC_INLINE float3 g3_cross(float3 a, float3 b)
{
    return (float3)(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
MC_INLINE float g_min(float a, float b) { return a < b ? a : b; }
MC_INLINE float g_max(float a, float b) { return a > b ? a : b; }

typedef struct {
    global const float4 *nodes;   /* BVH, layout of mcocl/render/bvh.py */
    global const float4 *leaves;  /* leaf_prim records in leaf order (mcocl/render/bvh_leaves.py) */
    global const float4 *wide;    /* 8-wide nodes of the single-ray traversal (mcocl/render/bvh_wide.py) */
    global const uint *tri_rows;  /* row of each triangle's leaf record after `leaves` (bvh_leaves.py device_geometry) */
    global const float4 *spheres; /* centre, radius */
    global const uint *sphere_flip;
    uint ntris;
    uint nspheres;
} scene_geom;

typedef struct {
    float t;     /* ray parameter of the hit: point = o + t d */
    uint prim;   /* primitive id */
    float b1, b2; /* triangle barycentrics of v1, v2 (0 for spheres) */
} hit_info;

/* The geometry's buffers as kernel parameters, in the order of CompiledScene.geom_args(). */
#define SCENE_GEOM_BUFFERS                                                                   \
    global const float4 *bvh_nodes, global const uint *tri_rows,                             \
    global const float4 *scene_spheres, global const uint *scene_sphere_flip
/* ... followed by the counts T and S: all of CompiledScene.geom_args().  A kernel with a
 * parameter struct takes SCENE_GEOM_BUFFERS and defines scene_ntris, scene_nspheres itself. */
#define SCENE_GEOM_PARAMS SCENE_GEOM_BUFFERS, const uint scene_ntris, const uint scene_nspheres
/* Declare `scene_geom name` from SCENE_GEOM_PARAMS inside a kernel. */
#define SCENE_GEOM_MAKE(name)                                                                \
    scene_geom name;                                                                         \
    name.nodes = bvh_nodes; name.tri_rows = tri_rows;                                        \
    name.leaves = bvh_nodes + as_uint(bvh_nodes[0].w);                                       \
    name.wide = name.leaves + 3u * as_uint(bvh_nodes[0].x);                                  \
    name.spheres = scene_spheres; name.sphere_flip = scene_sphere_flip;                      \
    name.ntris = scene_ntris; name.nspheres = scene_nspheres

/* Ray–triangle (Möller–Trumbore) given v0 and the edges e1 = v1 − v0, e2 = v2 − v0
 * (the BVH's leaf records hold them precomputed).  On a hit with t in (0, tmax)
 * writes t and the barycentrics of v1 and v2 and returns true. */
MC_INLINE bool intersect_triangle_edges(float3 v0, float3 e1, float3 e2, float3 o, float3 d, float tmax,
                                        float *t_out, float *b1_out, float *b2_out)
{
    float3 pv = g3_cross(d, e2);
    float det = g3_dot(e1, pv);
    float inv = 1.0f / det;                  /* det == 0: inv = inf, every test below fails */
    float3 tv = o - v0;
    float u = g3_dot(tv, pv) * inv;
    float3 qv = g3_cross(tv, e1);
    float v = g3_dot(d, qv) * inv;
    float t = g3_dot(e2, qv) * inv;
    bool ok = (u >= -TRI_EDGE_EPS) && (v >= -TRI_EDGE_EPS) && (u + v <= 1.0f + TRI_EDGE_EPS) && (t > 0.0f) && (t < tmax)
              && (det != 0.0f);
    if (ok) {
        *t_out = t;
        *b1_out = u;
        *b2_out = v;
    }
    return ok;
}

/* Ray–triangle of the vertices themselves. */
MC_INLINE bool intersect_triangle(float3 v0, float3 v1, float3 v2, float3 o, float3 d, float tmax, float *t_out,
                                  float *b1_out, float *b2_out)
{
    return intersect_triangle_edges(v0, v1 - v0, v2 - v0, o, d, tmax, t_out, b1_out, b2_out);
}

/* Ray–sphere: the nearest root in (0, tmax).  Works for any (non-zero) d. */
MC_INLINE bool intersect_sphere(float4 s, float3 o, float3 d, float tmax, float *t_out)
{
    float3 f = o - s.xyz;
    float a = g3_dot(d, d);
    float b = g3_dot(f, d);                      /* half the linear coefficient */
    float c = g3_dot(f, f) - s.w * s.w;
    float3 l = f - (b / a) * d;                  /* f minus its projection on d */
    float disc = a * (s.w * s.w - g3_dot(l, l)); /* = b² − a c, without cancellation */
    if (!(disc >= 0.0f)) return false;
    float sq = sqrt(disc);
    float q = -(b + (b < 0.0f ? -sq : sq));
    float t0 = q / a, t1 = c / q;
    float tn = g_min(t0, t1), tf = g_max(t0, t1);
    float t = (tn > 0.0f) ? tn : tf;
    if (t > 0.0f && t < tmax) {
        *t_out = t;
        return true;
    }
    return false;
}

/* Triangle prim's leaf record (v0 | prim, e1, e2): its edges are the float32 v1 − v0 and v2 − v0 the
 * functions below computed from the vertices before, bit for bit (mcocl/render/bvh_leaves.py). */
MC_INLINE global const float4 *tri_record(const scene_geom *g, uint prim) { return g->leaves + g->tri_rows[prim]; }

/* The unit geometric normal on the front side at point p of primitive prim. */
MC_INLINE float3 prim_normal(const scene_geom *g, uint prim, float3 p)
{
    if (prim < g->ntris) {
        global const float4 *r = tri_record(g, prim);
        return normalize(cross(r[1].xyz, r[2].xyz));
    }
    float4 s = g->spheres[prim - g->ntris];
    float3 n = normalize(p - s.xyz);
    return g->sphere_flip[prim - g->ntris] ? -n : n;
}

/* Surface area of a primitive. */
MC_INLINE float prim_area(const scene_geom *g, uint prim)
{
    if (prim < g->ntris) {
        global const float4 *r = tri_record(g, prim);
        return 0.5f * length(cross(r[1].xyz, r[2].xyz));
    }
    float r = g->spheres[prim - g->ntris].w;
    return 4.0f * M_PI_F * r * r;
}

/* A point distributed uniformly over the primitive's area (density 1/area) and
 * its front normal in *n.  Triangles: b0 = 1 − √u1, b1 = u2 √u1 (pbrt-v3
 * §13.6.5 "UniformSampleTriangle"); spheres: z = 1 − 2 u1, φ = 2π u2 (Archimedes). */
MC_INLINE float3 prim_sample_area(const scene_geom *g, uint prim, float2 u, float3 *n)
{
    if (prim < g->ntris) {
        global const float4 *r = tri_record(g, prim);
        float3 v0 = r[0].xyz, e1 = r[1].xyz, e2 = r[2].xyz;
        float su = sqrt(u.x);
        float b1 = 1.0f - su, b2 = u.y * su;
        *n = normalize(cross(e1, e2));
        return v0 + b1 * e1 + b2 * e2;
    }
    float4 s = g->spheres[prim - g->ntris];
    float z = 1.0f - 2.0f * u.x;
    float rxy = sqrt(fmax(0.0f, 1.0f - z * z));
    float phi = 2.0f * M_PI_F * u.y;
    float3 dir = (float3)(rxy * cos(phi), rxy * sin(phi), z);
    *n = g->sphere_flip[prim - g->ntris] ? -dir : dir;
    return s.xyz + s.w * dir;
}

/* A ray origin near surface point p (geometric normal n) from which a ray in
 * direction w does not re-hit the surface it leaves: p moved along ±n to the
 * side w points to, by an offset relative to the magnitude of p's
 * coordinates (float32 rounding of p is ~6e-8 |p|; 2^-17 leaves a wide
 * margin and is invisible at scene scale). */
MC_INLINE float3 spawn_origin(float3 p, float3 n, float3 w)
{
    float3 ap = fabs(p);
    float eps = 7.62939453125e-6f * fmax(fmax(fmax(ap.x, ap.y), ap.z), 1e-2f); /* 2^-17 */
    return p + (dot(n, w) >= 0.0f ? eps : -eps) * n;
}

#endif
