/* texture.cl — textured material colours: the (u, v) of a hit and the
 * checkerboard and bitmap lookups (Mitsuba 3's conventions: mcocl/render/textures.py
 * and mcocl/render/shape_uvs.py).  Built only with -DTEXTURES (the host sets
 * it when a material has a texture), so other scenes compile and render
 * exactly as before.
 *
 * textures: the one float4 table of mcocl/render/texture_table.py: a header
 * (int rows of the material map, triangle UVs, sphere frames, descriptors),
 * then those, then every texture's texels.
 */
#ifndef MCOCL_RENDER_TEXTURE_CL
#define MCOCL_RENDER_TEXTURE_CL

#include "render/vec3.cl"
#include "render/prims.cl"
#include "render/material.cl"
#include "sampling/gather.cl"

/* Codes of the descriptor (mcocl/render/textures.py: KINDS, FILTERS, WRAPS). */
#define TEX_CHECKERBOARD 0
#define TEX_BITMAP 1
#define TEX_FILTER_NEAREST 0
#define TEX_WRAP_MIRROR 1
#define TEX_WRAP_CLAMP 2
/* |to_uv (u, v)| is clamped below this before texel indices are taken (int32 range). */
#define TEX_UV_LIMIT 1.0e6f

/* The (u, v) at a hit: the triangle's corner UVs blended by the barycentrics (b1, b2 weigh
 * corners 1 and 2), or a sphere's (phi / 2 pi, theta / pi) of the hit point p in its local frame. */
MC_INLINE void texture_uv(global const float4 *tex, const prim_tables *pt, uintv prim, floatv b1, floatv b2, vec3v p,
                          intv active, floatv *u, floatv *v) {
    const uint tri_row = as_uint(tex[0].y), sph_row = as_uint(tex[0].z);
    intv sph = active & prim_is_sphere(pt, prim);
    intv tri = active & !sph;
    uintv k = tri_row + lane_select((uintv)(0u), prim, tri) * 2u;
    rec4v a = gather_rec4(tex, k), c = gather_rec4(tex, k + 1u);
    floatv b0 = 1.0f - b1 - b2;
    floatv uu = b0 * a.x + b1 * a.z + b2 * c.x;
    floatv vv = b0 * a.y + b1 * a.w + b2 * c.y;
    if (pt->nspheres > 0u && lane_any(sph)) {
        uintv j = lane_select((uintv)(0u), prim - pt->ntris, sph);
        rec4v s = gather_rec4(pt->spheres, j);
        uintv f = sph_row + j * 3u;
        rec4v r0 = gather_rec4(tex, f), r1 = gather_rec4(tex, f + 1u), r2 = gather_rec4(tex, f + 2u);
        vec3v d = v3_sub(p, v3(s.x, s.y, s.z));
        vec3v l = v3_normalize(v3(r0.x * d.x + r0.y * d.y + r0.z * d.z, r1.x * d.x + r1.y * d.y + r1.z * d.z,
                                  r2.x * d.x + r2.y * d.y + r2.z * d.z));
        floatv phi = atan2(l.y, l.x) * RT_INV_2PI;
        phi = lane_select(phi, phi + 1.0f, phi < 0.0f);
        floatv theta = acos(lane_clamp(l.z, -1.0f, 1.0f)) * RT_INV_PI;
        uu = lane_select(uu, phi, sph);
        vv = lane_select(vv, theta, sph);
    }
    *u = lane_select((floatv)(0.0f), uu, active);
    *v = lane_select((floatv)(0.0f), vv, active);
}

/* i mod n in [0, n) for |i| < 2^24, n >= 1: the quotient by a float division (off by at most one,
 * then corrected), as vector integer division has no instruction on CPUs. */
MC_INLINE intv texture_mod(intv i, intv n) {
    intv r = i - to_intv(floor(to_floatv(i) / to_floatv(n))) * n;
    r = lane_select(r, r + n, r < 0);
    return lane_select(r, r - n, r >= n);
}

/* Integer texel coordinate i wrapped into [0, size) by the lanes' wrap modes. */
MC_INLINE intv texture_wrap(intv i, intv size, intv mode) {
    intv r = texture_mod(i, size);
    intv two = size + size;
    intv m = texture_mod(i, two);
    m = lane_select(m, two - 1 - m, m >= size);
    intv c = lane_select(lane_select(i, size - 1, i >= size), (intv)(0), i < 0);
    return lane_select(lane_select(r, m, mode == TEX_WRAP_MIRROR), c, mode == TEX_WRAP_CLAMP);
}

/* floor(x) as an integer, x clamped to +-TEX_UV_LIMIT first (far outside any image: wrap decides). */
MC_INLINE intv texture_floor(floatv x) {
    return to_intv(floor(lane_clamp(x, -TEX_UV_LIMIT, TEX_UV_LIMIT)));
}

/* The RGB of texture `id` at (u, v), per lane (0 in inactive lanes). */
MC_INLINE vec3v texture_eval(global const float4 *tex, intv id, floatv u, floatv v, intv active) {
    const uint desc_row = as_uint(tex[0].w);
    uintv d = desc_row + to_uintv(lane_select((intv)(0), id, active)) * 3u;
    rec4v d0 = gather_rec4(tex, d), d1 = gather_rec4(tex, d + 1u), d2 = gather_rec4(tex, d + 2u);
    intv code = lane_as_int(d0.x);
    intv w = lane_select((intv)(1), lane_as_int(d0.y), active), h = lane_select((intv)(1), lane_as_int(d0.z), active);
    intv first = lane_as_int(d0.w);
    intv kind = code & 15, filter = (code >> 4) & 15, wrap = (code >> 8) & 15;
    floatv su = d1.x * u + d1.y * v + d2.x;
    floatv sv = d1.z * u + d1.w * v + d2.y;

    /* checkerboard: color0 (texel 0) where frac(su) > 1/2 and frac(sv) > 1/2 agree, else color1 (texel 1);
     * it and nearest lanes read texel i00 with weight 1 (fx = fy = 0); inactive lanes row 0 */
    intv odd = ((su - floor(su)) > 0.5f) != ((sv - floor(sv)) > 0.5f);
    intv i00 = lane_select((intv)(0), first + lane_select((intv)(0), (intv)(1), odd), active);
    intv i10 = i00, i01 = i00, i11 = i00;
    floatv fx = (floatv)(0.0f), fy = (floatv)(0.0f);
    intv bitmap = active & (kind == TEX_BITMAP);
    intv bilinear = bitmap & (filter != TEX_FILTER_NEAREST);
    if (lane_any(bitmap)) {
        /* bilinear: the four texels around (su W - 1/2, sv H - 1/2); nearest: the texel under (su W, sv H) */
        floatv px = su * to_floatv(w) - 0.5f, py = sv * to_floatv(h) - 0.5f;
        intv x0 = texture_floor(px), y0 = texture_floor(py);
        fx = lane_select((floatv)(0.0f), lane_clamp(px - to_floatv(x0), 0.0f, 1.0f), bilinear);
        fy = lane_select((floatv)(0.0f), lane_clamp(py - to_floatv(y0), 0.0f, 1.0f), bilinear);
        x0 = lane_select(texture_floor(su * to_floatv(w)), x0, bilinear);
        y0 = lane_select(texture_floor(sv * to_floatv(h)), y0, bilinear);
        intv xa = texture_wrap(x0, w, wrap), xb = texture_wrap(x0 + 1, w, wrap);
        intv ya = texture_wrap(y0, h, wrap), yb = texture_wrap(y0 + 1, h, wrap);
        i00 = lane_select(i00, first + ya * w + xa, bitmap);
        i10 = lane_select(i00, first + ya * w + xb, bilinear);
        i01 = lane_select(i00, first + yb * w + xa, bilinear);
        i11 = lane_select(i00, first + yb * w + xb, bilinear);
    }
    rec4v a = gather_rec4(tex, to_uintv(i00)), b = a, c = a, e = a;
    if (lane_any(bilinear)) { /* the other three texels only where a lane filters bilinearly */
        b = gather_rec4(tex, to_uintv(i10));
        c = gather_rec4(tex, to_uintv(i01));
        e = gather_rec4(tex, to_uintv(i11));
    }
    floatv gx = 1.0f - fx, gy = 1.0f - fy;
    vec3v out = v3(gy * (gx * a.x + fx * b.x) + fy * (gx * c.x + fx * e.x),
                   gy * (gx * a.y + fx * b.y) + fy * (gx * c.y + fx * e.y),
                   gy * (gx * a.z + fx * b.z) + fy * (gx * c.z + fx * e.z));
    return v3_select(v3s(0.0f), out, active);
}

/* The material map's row of the lanes' materials: (x, y, z) = the textures of colour, roughness and a
 * dielectric's transmittance, -1: none. */
MC_INLINE rec4v material_texture_ids(const material_v *m, global const float4 *tex, intv active) {
    const uint mat_row = as_uint(tex[0].x);
    return gather_rec4(tex, mat_row + lane_select((uintv)(0u), m->index, active));
}

/* Replace the colour (the transmittance, the roughness) of the lanes' materials by their textures at (u, v);
 * r: their material_texture_ids.  A textured colour of a dielectric without a transmittance of its own
 * (no MAT_FLAG_TRANSMITTANCE) tints both lobes, as its constant colour does. */
MC_INLINE void material_texture_apply(material_v *m, global const float4 *tex, rec4v r, floatv u, floatv v,
                                      intv active) {
    intv rgb_tex = lane_as_int(r.x), alpha_tex = lane_as_int(r.y), trans_tex = lane_as_int(r.z);
    intv use = active & (rgb_tex >= 0);
    if (lane_any(use)) {
        m->color = v3_select(m->color, texture_eval(tex, rgb_tex, u, v, use), use);
        m->transmit = v3_select(m->transmit, m->color, use & ((m->flags & MAT_FLAG_TRANSMITTANCE) == 0));
    }
    use = active & (trans_tex >= 0);
    if (lane_any(use)) m->transmit = v3_select(m->transmit, texture_eval(tex, trans_tex, u, v, use), use);
    use = active & (alpha_tex >= 0);
    if (lane_any(use)) {
        /* a roughness texture: the luminance of its RGB (Rec. 709 weights), within the alpha key's range */
        vec3v c = texture_eval(tex, alpha_tex, u, v, use);
        floatv a = 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z;
        m->alpha = lane_select(m->alpha, lane_clamp(a, 1.0e-4f, 1.0f), use);
    }
}

/* Replace the colour (the transmittance, the roughness) of the lanes' materials by their textures at (u, v). */
MC_INLINE void material_texture(material_v *m, global const float4 *tex, floatv u, floatv v, intv active) {
    material_texture_apply(m, tex, material_texture_ids(m, tex, active), u, v, active);
}

/* The same at a ray hit (primitive, barycentrics b1, b2, point p): the (u, v) are computed only when
 * a lane's material has a texture, so that untextured surfaces of a textured scene cost one read. */
MC_INLINE void material_texture_at_hit(material_v *m, global const float4 *tex, const prim_tables *pt, uintv prim,
                                       floatv b1, floatv b2, vec3v p, intv active) {
    rec4v r = material_texture_ids(m, tex, active);
    intv need = active & ((lane_as_int(r.x) >= 0) | (lane_as_int(r.y) >= 0) | (lane_as_int(r.z) >= 0));
    if (!lane_any(need)) return;
    floatv u, v;
    texture_uv(tex, pt, prim, b1, b2, p, need, &u, &v);
    material_texture_apply(m, tex, r, u, v, need);
}

#endif
