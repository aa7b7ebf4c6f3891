/* lights.cl — sampling the emitters for next-event estimation, and the pdf
 * with which that sampling would have produced a given emitter hit (for the
 * MIS weight of the same path found by BSDF sampling; Veach & Guibas 1995).
 *
 * Emitter choice.  The constant environment (if any) is chosen with
 * probability env_pmf (1/2 when there are area lights too,
 * mcocl/render/emitter_choice.py); otherwise an emitting primitive, by
 * -DLIGHT_SAMPLER (LightSampler codes of layouts.cl):
 *   POWER, UNIFORM  from light_cdf (proportional to power, luminance * area
 *                   * pi, or uniform), the largest k with light_cdf[k] <= u;
 *                   the uniforms live on a grid of 2^23 cell centres
 *                   (rng/uniform.cl), so the host computes the *exact*
 *                   probability of every choice on that grid (prim_pmf,
 *                   env_pmf): the pdf the estimator divides by is the
 *                   probability the sampler really has;
 *   BVH             through the light BVH from the shading point and its
 *                   normal (render/light_bvh.cl), also exact on the grid.
 *
 * Position on the chosen primitive (Veach's thesis §9.2 / pbrt-v4 §6.x):
 *   triangle   uniform area sampling, pdf_omega = d^2 / (A cos theta_l);
 *   sphere     uniform in the cone of directions it subtends when the point
 *              is outside it (pdf_omega = 1 / (2 pi (1 - cos theta_max)),
 *              pbrt-v4 §6.2.4), uniform area sampling otherwise (a point
 *              inside, or a sphere whose normals point inward).
 * Area emitters are one-sided: a sample on the back of the emitter carries
 * no radiance.  The constant environment is sampled uniformly over the
 * sphere, an environment map by its tabulated density (render/envmap.cl).
 * Point, spot and directional lights (render/delta_lights.cl) share the
 * choice table with the area lights; their sample has pdf = the choice
 * probability (a discrete density, flagged `delta`), so its MIS weight is 1.
 *
 * Textured area emitters (-DTEXTURES; emitter_radiance's w = texture id + 1,
 * mcocl/render/texture_table.py): the radiance at a point is the texture at
 * its (u, v) (render/texture.cl) wherever it is evaluated — an emitter hit
 * (emitter_radiance_at), a light sample here, an emitted ray
 * (render/lights_emit.cl), bdpt's s = 0 (emitter_radiance_uv) — so that every
 * integrator estimates the same image.  Positions stay sampled by area; the
 * light choice's power takes the texture's mean texel (compiled.py).
 */
#ifndef MCOCL_RENDER_LIGHTS_CL
#define MCOCL_RENDER_LIGHTS_CL

#include "render/prims.cl"
#include "render/light_bvh.cl"
#include "render/delta_lights.cl"
#include "render/envmap.cl"
#include "sampling/gather.cl"
/* unconditional: runtime.compose inlines an include once, whatever #ifdef surrounds it */
#include "render/texture.cl"

#ifndef LIGHT_SAMPLER
#define LIGHT_SAMPLER LIGHT_SAMPLER_POWER
#endif

/* Lights are flattened by the host (mcocl/render/device_scene.py, light_records)
 * into one light_record (layouts.cl, from mcocl/layouts.py) per light
 * primitive k, LIGHT_RECORD_QUADS float4: triangle v0 and edges v1 - v0,
 * v2 - v0, or sphere centre and (radius, 0, 0); area; shape (a LightShape
 * code); choice probability (exact, on the uniforms' grid); radiance; the
 * primitive id (uint bit pattern). */
typedef struct {
    global const float4 *light_rec;        /* LIGHT_RECORD_QUADS per light primitive */
    global const float *light_cdf;         /* L + 1 */
    global const float4 *emitter_radiance; /* E */
    global const float4 *light_bvh;        /* LIGHT_BVH_NODE_QUADS per node (LIGHT_SAMPLER_BVH only) */
    global const uint *light_trail;        /* per primitive: root-to-leaf path of its light (BVH only) */
    uint nlights, light_top;               /* light_top: largest power of two <= nlights (0 if none) */
    float env_threshold;                   /* the environment is chosen when u < env_threshold */
    float env_pmf;                         /* ... which happens with this exact probability */
    float4 env_radiance;                   /* w > 0: an environment map, env_map (render/envmap.cl) */
    envmap_t env_map;                      /* bound by light_tables_bind_envmap; unbound otherwise */
    light_choice_memo *memo;               /* 0, or the flat light tree's choice at the last light sample */
    int has_env_map;
#ifdef TEXTURES
    global const float4 *textures;         /* bound by light_tables_bind_textures; 0: constant radiance */
    prim_tables pt;
#endif
} light_tables;

/* The light tables of a render launch: its buffers, and the light count and
 * environment choice of its render_params.  light_bvh and light_trail may be 0
 * where no light BVH is bound (the power and uniform choices never read them). */
MC_INLINE light_tables light_tables_of(const render_params *p, global const float4 *light_rec,
                                       global const float *light_cdf, global const float4 *emitter_radiance,
                                       global const float4 *light_bvh, global const uint *light_trail) {
    light_tables lt;
    lt.light_rec = light_rec;
    lt.light_cdf = light_cdf;
    lt.emitter_radiance = emitter_radiance;
    lt.light_bvh = light_bvh;
    lt.light_trail = light_trail;
    lt.nlights = p->nlights;
    lt.light_top = p->light_top;
    lt.env_threshold = p->env_threshold;
    lt.env_pmf = p->env_pmf;
    lt.env_radiance = p->env_radiance;
    lt.env_map = envmap_of(0, 0);
    lt.has_env_map = 0;
    lt.memo = 0;
#ifdef TEXTURES
    lt.textures = 0;
#endif
    return lt;
}

#ifdef TEXTURES
/* Bind the texture table of a textured launch (render/texture.cl), so that
 * textured area emitters shine with their texture. */
MC_INLINE void light_tables_bind_textures(light_tables *lt, global const float4 *textures, const prim_tables *pt) {
    lt->textures = textures;
    lt->pt = *pt;
}
#endif

/* Bind the environment map tables of a launch (mcocl/render/envmap.py); a
 * scene without one (env_radiance.w == 0) leaves the constant environment. */
MC_INLINE void light_tables_bind_envmap(light_tables *lt, const render_params *p, global const float4 *env_map,
                                        global const uint *env_cdf) {
    if (p->env_radiance.w > 0.0f) {
        lt->env_map = envmap_of(env_map, env_cdf);
        lt->has_env_map = 1;
    }
}

/* Radiance of emitter e (lanes with e < 0 get black). */
MC_INLINE vec3v emitter_radiance_of(const light_tables *lt, intv e) {
    intv has = e >= 0;
    rec4v r = gather_rec4(lt->emitter_radiance, lane_as_uint(lane_select((intv)(0), e, has)));
    return v3_select(v3s(0.0f), v3(r.x, r.y, r.z), has);
}

/* The radiance of emitter e at texture coordinates (u, v): le (its constant) unless the emitter is
 * textured, then the texture there (lanes with e < 0 or inactive keep le). */
MC_INLINE vec3v emitter_radiance_uv(const light_tables *lt, intv e, floatv u, floatv v, vec3v le, intv active) {
#ifdef TEXTURES
    if (lt->textures == 0) return le;
    intv has = active & (e >= 0);
    rec4v r = gather_rec4(lt->emitter_radiance, lane_as_uint(lane_select((intv)(0), e, has)));
    intv id = to_intv(r.w) - 1;
    intv use = has & (id >= 0);
    if (!lane_any(use)) return le;
    return v3_select(le, texture_eval(lt->textures, id, u, v, use), use);
#else
    return le;
#endif
}

/* The radiance of emitter e at the point p of primitive prim (barycentrics b1, b2 of a triangle's corners
 * 1 and 2): le unless the emitter is textured (see emitter_radiance_uv). */
MC_INLINE vec3v emitter_radiance_at(const light_tables *lt, intv e, uintv prim, floatv b1, floatv b2, vec3v p,
                                    vec3v le, intv active) {
#ifdef TEXTURES
    if (lt->textures == 0) return le;
    intv has = active & (e >= 0);
    rec4v r = gather_rec4(lt->emitter_radiance, lane_as_uint(lane_select((intv)(0), e, has)));
    intv use = has & (r.w > 0.0f);
    if (!lane_any(use)) return le;
    floatv u, v;
    texture_uv(lt->textures, &lt->pt, prim, b1, b2, p, use, &u, &v);
    return emitter_radiance_uv(lt, e, u, v, le, use);
#else
    return le;
#endif
}

/* The radiance of the emitting primitive prim at its point p (a sampled light position; b1, b2 as above). */
MC_INLINE vec3v emitter_radiance_of_prim(const light_tables *lt, uintv prim, floatv b1, floatv b2, vec3v p, vec3v le,
                                         intv active) {
#ifdef TEXTURES
    if (lt->textures == 0 || !lane_any(active)) return le;
    uintv pr = lane_select((uintv)(0u), prim, active);
    PRIM_RECORD_GATHER(q, lt->pt.prim_rec, pr);
    intv e = lane_select((intv)(-1), lane_as_int(REC_FIELD(q, PRIM_RECORD_EMITTER)), active);
    return emitter_radiance_at(lt, e, pr, b1, b2, p, le, active);
#else
    return le;
#endif
}

/* Largest k in [0, nlights - 1] with light_cdf[k] <= u (light_cdf[0] = 0; the table is a CDF, so
 * non-decreasing, and the k with light_cdf[k] <= u are a prefix 0..K).
 *
 * A binary search over the lanes is a chain of dependent gathers, one per halving (10 for the 512
 * emitter triangles of scenes/many_lights.json, where it took about 5 % of the mis kernel).  Its
 * first LIGHT_FIND_COUNTED halvings land on the largest multiple of S = light_top >> (LIGHT_FIND_COUNTED - 1)
 * at most K, that is S times the number of i >= 1 with i S < nlights and light_cdf[i S] <= u: those
 * 2^LIGHT_FIND_COUNTED - 1 entries are the same for every lane, so they are counted by scalar loads
 * and independent comparisons, and only the remaining halvings gather.  On many_lights, 6 counted
 * halvings (63 comparisons, 4 gathers left) took the search from 5.8 % of the kernel's perf samples to
 * 3.0 % (5: 3.7 %, 7: 3.6 %) and gave 2-4 % more paths per CPU-second (interleaved runs, same images);
 * tests/test_render_light_find.py checks the choice against a plain search. */
#define LIGHT_FIND_COUNTED 6u
MC_INLINE uintv light_find(const light_tables *lt, floatv u) {
    const uint n = lt->nlights, top = lt->light_top;
    if (top == 0u) return (uintv)(0u);
    const uint levels = min(LIGHT_FIND_COUNTED, 32u - clz(top)); /* top = 2^T: at most T + 1 halvings */
    const uint stride = top >> (levels - 1u);
    uintv count = (uintv)(0u);
    for (uint i = 1u; i < (1u << levels) && i * stride < n; ++i)
        count += lane_as_uint(mask_bit((floatv)(lt->light_cdf[i * stride]) <= u));
    uintv k = count * stride;
    for (uint step = stride >> 1; step > 0u; step >>= 1) {
        uintv cand = k + step;
        uintv safe = min(cand, (uintv)(n - 1u));
        intv take = (cand < (uintv)(n)) & (gather_float(lt->light_cdf, safe) <= u);
        k = lane_select(k, cand, take);
    }
    return k;
}

/* Geometry of the cone a sphere subtends from p: 1 - cos(theta_max) without
 * cancellation (sin^2 / (1 + cos)), and whether cone sampling applies. */
MC_INLINE intv sphere_cone(vec3v p, vec3v c, floatv r, intv flip, floatv *one_minus_cos, floatv *sin2max, vec3v *wc,
                           floatv *dc) {
    vec3v v = v3_sub(c, p);
    floatv dc2 = v3_len2(v);
    floatv s2 = lane_min(r * r / dc2, (floatv)(1.0f));
    *sin2max = s2;
    *one_minus_cos = s2 / (1.0f + safe_sqrt(1.0f - s2));
    *dc = lane_sqrt(dc2);
    *wc = v3_scale(v, 1.0f / *dc);
    return (!flip) & (dc2 > r * r);
}

typedef struct {
    vec3v wo;        /* unit direction from the shading point */
    vec3v pos;       /* the point on the emitter (area lights) */
    vec3v n;         /* its front normal */
    floatv dist;     /* |pos - p| (area and delta lights; 0 otherwise): wo = (pos - p) / dist */
    floatv pdf;      /* solid-angle pdf at the shading point, emitter choice included */
    vec3v radiance;  /* emitted radiance towards the shading point (0 from behind) */
    intv env;        /* the environment or a directional light was sampled (the shadow ray is unbounded) */
    intv delta;      /* a point, spot or directional light: pdf is a probability, no BSDF sample finds it */
    uintv prim;      /* the emitting primitive chosen (area lights) */
    intv valid;
} light_sample_v;

/* Uniform direction on the unit sphere, pdf 1 / (4 pi). */
MC_INLINE vec3v square_to_uniform_sphere(floatv u1, floatv u2) {
    floatv z = 1.0f - 2.0f * u1;
    floatv r = safe_sqrt(1.0f - z * z);
    floatv c;
    floatv s = lane_sincos_2pi(u2, &c);
    return v3(r * c, r * s, z);
}

/* Light sampling at p with normal n (used by the BVH light sampler's
 * importance; n = 0 ignores the receiver's orientation). */
MC_INLINE light_sample_v sample_light_at(const light_tables *lt, const prim_tables *pt, vec3v p, vec3v n,
                                         floatv u_env, floatv u_sel, floatv u1, floatv u2, intv active) {
    light_sample_v s;
    s.valid = active & (intv)(0);
    const intv env_chosen = u_env < lt->env_threshold;
    s.env = env_chosen;
    s.delta = (intv)(0);
    s.pdf = (floatv)(0.0f);
    s.radiance = v3s(0.0f);
    s.wo = v3(0.0f, 0.0f, 1.0f);
    s.pos = p;
    s.n = s.wo;
    s.dist = (floatv)(0.0f);
    s.prim = (uintv)(0u);
    intv area = active & !env_chosen;
    if (lt->nlights > 0u && lane_any(area)) {
#if LIGHT_SAMPLER == LIGHT_SAMPLER_BVH
        floatv choice;
        uintv k = light_bvh_sample_memo(lt->light_bvh, p, n, u_sel, area, &choice, lt->memo);
#else
        uintv k = light_find(lt, u_sel);
#endif
        LIGHT_RECORD_GATHER(q, lt->light_rec, k);
        vec3v base = REC_VEC3(q, LIGHT_RECORD_BASE);
        floatv area_l = REC_FIELD(q, LIGHT_RECORD_AREA);
        floatv shape = REC_FIELD(q, LIGHT_RECORD_SHAPE);
#if LIGHT_SAMPLER != LIGHT_SAMPLER_BVH
        floatv choice = REC_FIELD(q, LIGHT_RECORD_PMF);
#endif
        floatv pmf = choice * (1.0f - lt->env_pmf);
        vec3v y = p, ny = s.wo;
        floatv pdf = (floatv)(0.0f);
        intv tri_l = area & (shape == (float)LIGHT_TRIANGLE);
        if (lane_any(tri_l)) {
            /* uniform point of the triangle: barycentrics (1 - sqrt(u1), u2 sqrt(u1)) of (v1, v2) (pbrt-v3 §13.6.5) */
            vec3v e1 = REC_VEC3(q, LIGHT_RECORD_EDGE1), e2 = REC_VEC3(q, LIGHT_RECORD_EDGE2);
            floatv su = lane_sqrt(u1);
            vec3v yt = v3_madd(v3_madd(base, 1.0f - su, e1), u2 * su, e2);
            vec3v nt = v3_normalize(v3_cross(e1, e2));
            vec3v dv = v3_sub(yt, p);
            floatv d2 = v3_len2(dv);
            floatv cosl = -v3_dot(nt, dv) * lane_rsqrt(d2);
            y = v3_select(y, yt, tri_l);
            ny = v3_select(ny, nt, tri_l);
            pdf = lane_select(pdf, pmf * d2 / (area_l * cosl), tri_l);
        }
        intv sph_l = area & ((shape == (float)LIGHT_SPHERE) | (shape == (float)LIGHT_SPHERE_INWARD));
        if (lane_any(sph_l)) {
            vec3v c = base;
            floatv r = REC_FIELD(q, LIGHT_RECORD_EDGE1); /* the radius */
            intv flip = shape == (float)LIGHT_SPHERE_INWARD;
            floatv omc, s2max, dc;
            vec3v wc;
            intv cone = sphere_cone(p, c, r, flip, &omc, &s2max, &wc, &dc);
            floatv cph;
            floatv sph_ = lane_sincos_2pi(u2, &cph);
            /* cone: cos(theta) uniform in [cos theta_max, 1]; the point follows from the angle alpha at
             * the centre, cos alpha = sin^2 theta / sin theta_max + cos theta sqrt(1 - sin^2 theta / sin^2 theta_max)
             * (pbrt-v4 §6.2.4) */
            floatv ct = 1.0f - u1 * omc;
            floatv s2t = u1 * omc * (2.0f - u1 * omc);
            floatv smax = lane_sqrt(s2max);
            floatv ca = s2t / smax + ct * safe_sqrt(1.0f - s2t / s2max);
            floatv sa = safe_sqrt(1.0f - ca * ca);
            frame3v fr = frame_from_normal(wc);
            vec3v nout = v3_neg(frame_to_world(fr, v3(sa * cph, sa * sph_, ca)));
            /* area: uniform over the whole sphere; only lanes inside a sphere or on an inward one take it,
             * so the cone case (a point outside: nearly every lane) skips its sample and pdf */
            const intv by_area = sph_l & !cone;
            const int any_area = lane_any(by_area);
            if (any_area) nout = v3_select(square_to_uniform_sphere(u1, u2), nout, cone);
            vec3v ys = v3_madd(c, r, nout);
            vec3v nf = v3_select(nout, v3_neg(nout), flip);
            floatv pdf_s = RT_INV_2PI / omc;
            if (any_area) {
                vec3v dv = v3_sub(ys, p);
                floatv d2 = v3_len2(dv);
                floatv cosl = -v3_dot(nf, dv) * lane_rsqrt(d2);
                floatv pdf_area = d2 / (area_l * cosl);
                pdf_s = lane_select(pdf_area, pdf_s, cone);
            }
            y = v3_select(y, ys, sph_l);
            ny = v3_select(ny, nf, sph_l);
            pdf = lane_select(pdf, pmf * pdf_s, sph_l);
        }
        intv delta_l = area & light_shape_is_delta(shape);
        floatv delta_scale = (floatv)(0.0f);
        if (lane_any(delta_l)) {
            vec3v wd, yd;
            intv unbounded;
            delta_scale = delta_light_toward(base, shape, REC_VEC3(q, LIGHT_RECORD_EDGE1),
                                             REC_VEC3(q, LIGHT_RECORD_EDGE2), area_l, p, &wd, &yd, &unbounded);
            y = v3_select(y, yd, delta_l);
            ny = v3_select(ny, v3_neg(wd), delta_l); /* faces p: a delta light has no back */
            pdf = lane_select(pdf, pmf, delta_l);
            s.env = s.env | (delta_l & unbounded);
            s.delta = s.delta | delta_l;
        }
        vec3v dv = v3_sub(y, p);
        floatv dist = lane_sqrt(v3_len2(dv));
        vec3v wo = v3_scale(dv, 1.0f / dist);
        intv front = v3_dot(ny, wo) < 0.0f;
        intv ok = area & front & (pdf > 0.0f) & lane_finite(pdf);
        s.wo = v3_select(s.wo, wo, area);
        s.dist = lane_select(s.dist, dist, area);
        s.prim = lane_select(s.prim, lane_as_uint(REC_FIELD(q, LIGHT_RECORD_PRIM)), area);
        s.pos = v3_select(s.pos, y, area);
        s.n = v3_select(s.n, ny, area);
        s.pdf = lane_select(s.pdf, pdf, ok);
        vec3v rad = REC_VEC3(q, LIGHT_RECORD_RADIANCE);
        /* a textured emitter: its texture at the sampled point (triangle barycentrics as sampled above) */
        floatv su_t = lane_sqrt(u1);
        rad = emitter_radiance_of_prim(lt, s.prim, 1.0f - su_t, u2 * su_t, y, rad, ok & !delta_l);
        s.radiance = v3_select(s.radiance, v3_select(rad, v3_scale(rad, delta_scale), delta_l), ok);
        s.valid = s.valid | ok;
    }
    intv envl = active & env_chosen;
    if (lt->env_pmf > 0.0f && lt->has_env_map && lane_any(envl)) {
        floatv pe;
        vec3v de = envmap_sample(&lt->env_map, u1, u2, &pe);
        intv ok = envl & (pe > 0.0f) & lane_finite(pe);
        s.wo = v3_select(s.wo, de, envl);
        s.pdf = lane_select(s.pdf, lt->env_pmf * pe, ok);
        s.radiance = v3_select(s.radiance, envmap_radiance(&lt->env_map, de, ok), envl);
        s.valid = s.valid | ok;
    } else if (lt->env_pmf > 0.0f && lane_any(envl)) {
        s.wo = v3_select(s.wo, square_to_uniform_sphere(u1, u2), envl);
        s.pdf = lane_select(s.pdf, (floatv)(lt->env_pmf * RT_INV_4PI), envl);
        s.radiance = v3_select(s.radiance, v3((floatv)(lt->env_radiance.x), (floatv)(lt->env_radiance.y),
                                              (floatv)(lt->env_radiance.z)), envl);
        s.valid = s.valid | envl;
    }
    return s;
}

/* The environment's radiance arriving from direction d (constant or map). */
MC_INLINE vec3v environment_radiance(const light_tables *lt, vec3v d, intv active) {
    if (lt->has_env_map) return envmap_radiance(&lt->env_map, d, active);
    return v3_select(v3s(0.0f), v3((floatv)(lt->env_radiance.x), (floatv)(lt->env_radiance.y),
                                   (floatv)(lt->env_radiance.z)), active);
}

/* The solid-angle density with which light sampling picks direction d when it chooses the
 * environment (the choice env_pmf not included). */
MC_INLINE floatv environment_pdf(const light_tables *lt, vec3v d, intv active) {
    if (lt->has_env_map) return envmap_pdf(&lt->env_map, d, active);
    return lane_select((floatv)(0.0f), (floatv)(RT_INV_4PI), active);
}

/* Light sampling at p, whatever its orientation (sample_light_at with n = 0). */
MC_INLINE light_sample_v sample_light(const light_tables *lt, const prim_tables *pt, vec3v p, floatv u_env,
                                      floatv u_sel, floatv u1, floatv u2, intv active) {
    return sample_light_at(lt, pt, p, v3s(0.0f), u_env, u_sel, u1, u2, active);
}

/* The probability that the light choice at p (normal n) picks primitive prim
 * (an emitter hit; prim_pmf is the CDF's exact share, sf->pmf). */
MC_INLINE floatv light_choice_pmf(const light_tables *lt, vec3v p, vec3v n, uintv prim, const surface_v *sf,
                                  intv active) {
#if LIGHT_SAMPLER == LIGHT_SAMPLER_BVH
    uintv trail = gather_uint(lt->light_trail, lane_select((uintv)(0u), prim, active));
    /* the caller's memo is valid only where p, n are the point and normal of its last light sample */
    if (lt->memo && lt->memo->valid) return light_bvh_memo_pmf(lt->memo, lt->light_bvh, trail, active);
    return light_bvh_pmf(lt->light_bvh, p, n, trail, active);
#else
    return sf->pmf;
#endif
}

/* The solid-angle pdf with which sample_light_at, called at p_choice with
 * normal n, picks the point y of surface sf (an emitter hit) — the same
 * choices as above; the solid angle is measured at p, the surface point the
 * ray left, along the ray's unit direction w.  The ray itself left an offset
 * origin (offset_origin), so the line from p along w meets the emitter's
 * plane at distance s = n_y . (y - p) / n_y . w, not exactly at y: measured
 * along w, the density is the one sample_light_at(p) has in direction w, and
 * the two MIS weights of a path are the same function of the direction at p
 * (measured from p to y, they differed by O(eps / |y - p|), which biased a
 * furnace sphere's reflected light by 3e-4). */
MC_INLINE floatv light_pdf_hit_at(const light_tables *lt, const prim_tables *pt, vec3v p, vec3v p_choice, vec3v n,
                                  vec3v w, uintv prim, const surface_v *sf, intv active) {
    floatv pmf = light_choice_pmf(lt, p_choice, n, prim, sf, active) * (1.0f - lt->env_pmf);
    intv sph_l = active & prim_is_sphere(pt, prim);
    intv by_cone = active & (intv)(0);
    floatv pdf_cone = (floatv)(0.0f);
    /* the line from p along w meets the emitter's plane at distance dist, where cosw = n_y . w */
    floatv cosw = v3_dot(sf->n, w);
    floatv dist = v3_dot(sf->n, v3_sub(sf->p, p)) / cosw;
    if (pt->nspheres > 0u && lane_any(sph_l)) {
        rec4v c = gather_rec4(pt->spheres, lane_select((uintv)(0u), prim - pt->ntris, sph_l));
        vec3v cc = v3(c.x, c.y, c.z);
        /* the record's normal points inwards for a flipped sphere: the centre lies on its side */
        intv flip = v3_dot(sf->n, v3_sub(cc, sf->p)) > 0.0f;
        floatv omc, s2max, dc;
        vec3v wc;
        intv cone = sphere_cone(p, cc, c.w, flip, &omc, &s2max, &wc, &dc);
        pdf_cone = pmf * RT_INV_2PI / omc;
        by_cone = sph_l & cone;
        /* p inside or on the sphere: the line leaves it at the far root of |p + s w - c| = r (a tangent
         * plane would be off by the curvature where the chord is short, as on the sphere itself) */
        intv inside = sph_l & !cone;
        if (lane_any(inside)) {
            vec3v oc = v3_sub(p, cc);
            floatv b = v3_dot(w, oc);
            floatv s_far = safe_sqrt(b * b - (v3_len2(oc) - c.w * c.w)) - b;
            vec3v ny = v3_scale(v3_sub(v3_madd(p, s_far, w), cc), 1.0f / c.w);
            dist = lane_select(dist, s_far, inside);
            cosw = lane_select(cosw, v3_dot(ny, w), inside);
        }
    }
    floatv pdf = pdf_cone;
    if (lane_any(active & !by_cone)) /* the area density, where some lane is not a sphere seen from outside */
        pdf = lane_select(pmf * dist * dist / (sf->area * lane_abs(cosw)), pdf_cone, by_cone);
    return lane_select((floatv)(0.0f), pdf, active);
}

/* light_pdf_hit_at for sample_light (n = 0). */
MC_INLINE floatv light_pdf_hit(const light_tables *lt, const prim_tables *pt, vec3v p, vec3v w, uintv prim,
                               const surface_v *sf, intv active) {
    return light_pdf_hit_at(lt, pt, p, p, v3s(0.0f), w, prim, sf, active);
}

#endif
