/* texture_test.cl — the texture lookups exposed to the tests (render/texture.cl):
 * texture_eval of texture ids[i] at (u[i], v[i]), and texture_uv of primitive
 * prim[i] at barycentrics (b1, b2) / point p.  Outputs are structure of arrays
 * (component c of item i at c * n + i). */
#include "render/lane_io.cl"
#include "render/texture.cl"

/* in: u, v, id (as float) (3 components); out: rgb (3 components) */
kernel void texture_lookup(global const float4 *tex, uint n, global const float *in, global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    floatv u = load_floatv(in + base), v = load_floatv(in + n + base);
    intv id = to_intv(load_floatv(in + 2 * n + base));
    intv all = (intv)(0) == (intv)(0);
    vec3v c = texture_eval(tex, id, u, v, all);
    store_floatv(c.x, out + base);
    store_floatv(c.y, out + n + base);
    store_floatv(c.z, out + 2 * n + base);
}

/* in: prim (as float), b1, b2, p.xyz (6 components); out: u, v (2 components) */
kernel void texture_coordinates(global const float4 *tex, global const float4 *spheres, uint ntris, uint nspheres,
                                uint n, global const float *in, global float *out) {
    uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    prim_tables pt;
    pt.spheres = spheres;
    pt.prim_rec = 0;
    pt.ntris = ntris;
    pt.nspheres = nspheres;
    uintv prim = to_uintv(load_floatv(in + base));
    vec3v p = v3(load_floatv(in + 3 * n + base), load_floatv(in + 4 * n + base), load_floatv(in + 5 * n + base));
    intv all = (intv)(0) == (intv)(0);
    floatv u, v;
    texture_uv(tex, &pt, prim, load_floatv(in + n + base), load_floatv(in + 2 * n + base), p, all, &u, &v);
    store_floatv(u, out + base);
    store_floatv(v, out + n + base);
}
