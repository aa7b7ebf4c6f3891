/* lights_emit.cl — emitters as the start of light paths: sample a ray
 * leaving an emitter, with its densities in both measures (the adjoint half
 * of lights.cl, which samples a point on an emitter *toward* a shading point).
 *
 * Which emitter: the same choice as lights.cl (the environment when
 * u_env < env_threshold, with exact probability env_pmf; otherwise the light
 * primitive light_find picks, with the exact probability of its record),
 * i.e. in proportion to emitted power (mcocl/render/emitter_choice.py).
 *
 * Area emitters (Veach's thesis §10.2 / pbrt-v4 §12.x SampleLe): a point
 * uniform by area on the chosen primitive, pdf_area = choice / area, then a
 * cosine-weighted direction about the front normal, pdf_solid_angle =
 * cos(theta) / pi.  Emission is one-sided: no ray leaves the back.
 *
 * The constant environment: a uniform direction d of travel
 * (pdf_solid_angle = 1 / (4 pi)), then a point uniform on the disk of radius
 * R (the scene's bounding sphere) perpendicular to d, placed just outside the
 * bounding sphere on the side the light comes from (pdf_area = choice /
 * (pi R^2), the disk's normal being d).  Every ray of direction d that meets
 * the scene crosses that disk, so the pair samples all light the environment
 * sends into the scene (pbrt-v4's UniformInfiniteLight::SampleLe).  An
 * environment map (render/envmap.cl) draws d from its own density instead
 * (d = minus the direction the light comes from; pdf_solid_angle that density).
 *
 * Delta lights (render/delta_lights.cl; `delta` set): a point or spot light
 * starts at its position (pdf_area = choice, a probability) with a uniform
 * direction on the sphere (point, 1 / (4 pi)) or in the cutoff cone (spot,
 * 1 / (2 pi (1 - cos cutoff))), radiance = intensity times the falloff, cos 1.
 * A directional light starts on the environment's disk (pdf_area = choice /
 * (pi R^2)) with its fixed direction (pdf_solid_angle 1, a probability),
 * radiance = irradiance.  So beta_1 = L cos / (pdf_area pdf_solid_angle) is the
 * usual flux weight; no delta light can be seen by a camera connection.
 */
#ifndef MCOCL_RENDER_LIGHTS_EMIT_CL
#define MCOCL_RENDER_LIGHTS_EMIT_CL

#include "render/lights.cl"
#include "render/bsdf_diffuse.cl"
#include "render/delta_lights.cl"

/* The disk of an environment ray sits this fraction of R beyond the bounding sphere. */
#define EMIT_DISK_MARGIN 1e-3f

typedef struct {
    vec3v pos;               /* ray origin: the point on the emitter (area) or on the disk (environment) */
    vec3v n;                 /* front normal at pos (area); the direction d (environment) */
    vec3v d;                 /* unit direction of travel */
    vec3v radiance;          /* emitted radiance along d (zero when invalid) */
    floatv pdf_area;         /* emitter choice times the area density of pos */
    floatv pdf_solid_angle;  /* density of d */
    floatv cos_theta;        /* cosine between n and d */
    intv env;                /* the environment was chosen */
    intv delta;              /* a point, spot or directional light was chosen (never seen directly) */
    intv infinite;           /* the environment or a directional light: the ray comes from infinitely far */
    intv valid;
} emitter_ray_v;

/* The light rays of lanes dl, which chose a delta light (see the header):
 * base, shape, axis (edge1), cone (edge2), inv_width (area) and le (radiance)
 * of its record, pmf its choice probability. */
MC_INLINE void emitter_ray_delta(emitter_ray_v *r, vec3v base, floatv shape, vec3v axis, vec3v cone, floatv inv_width,
                                 vec3v le, floatv pmf, float4 bsphere, const floatv *u, intv dl) {
    intv spot = shape == (float)LIGHT_SPOT, dir = shape == (float)LIGHT_DIRECTIONAL;
    /* point (the whole sphere: cos_max = -1) or spot: a uniform direction in the cone about the axis */
    floatv cmax = lane_select((floatv)(-1.0f), cone.x, spot);
    vec3v wl = square_to_uniform_cone(u[4], u[5], cmax);
    vec3v dp = frame_to_world(frame_from_normal(v3_select(v3(0.0f, 0.0f, 1.0f), axis, spot)), wl);
    floatv pdf_dp = RT_INV_2PI / (1.0f - cmax);
    floatv fall = lane_select((floatv)(1.0f), spot_falloff(wl.z, cone, inv_width), spot);
    /* directional: a point uniform on the disk of radius R across the direction of travel, placed
     * as the environment's (below) */
    frame3v fd = frame_from_normal(base);
    floatv rad = bsphere.w, cd;
    floatv sd = lane_sincos_2pi(u[3], &cd);
    floatv rr = rad * lane_sqrt(u[2]);
    vec3v centre = v3((floatv)(bsphere.x), (floatv)(bsphere.y), (floatv)(bsphere.z));
    vec3v od = v3_madd(v3_madd(v3_madd(centre, -rad * (1.0f + EMIT_DISK_MARGIN), base), rr * cd, fd.s), rr * sd, fd.t);
    vec3v d = v3_select(dp, base, dir);
    floatv pa = lane_select(pmf, pmf / (RT_PI * rad * rad), dir);
    vec3v l = v3_scale(le, fall);
    intv ok = dl & (pmf > 0.0f) & (v3_maxc(l) > 0.0f);
    r->pos = v3_select(r->pos, v3_select(base, od, dir), dl);
    r->n = v3_select(r->n, d, dl);
    r->d = v3_select(r->d, d, dl);
    r->cos_theta = lane_select(r->cos_theta, (floatv)(1.0f), dl);
    r->pdf_area = lane_select(r->pdf_area, pa, dl);
    r->pdf_solid_angle = lane_select(r->pdf_solid_angle, lane_select(pdf_dp, (floatv)(1.0f), dir), dl);
    r->radiance = v3_select(r->radiance, v3_select(v3s(0.0f), l, ok), dl);
    r->valid = (r->valid & !dl) | ok;
    r->delta = r->delta | dl;
    r->infinite = r->infinite | (dl & dir);
}

/* Sample a light ray from the uniforms u[0..5]: environment or area, which
 * light, position 2D, direction 2D.  bsphere: centre xyz and radius of the
 * scene's bounding sphere. */
MC_INLINE emitter_ray_v sample_emitter_ray(const light_tables *lt, float4 bsphere, const floatv *u, intv active) {
    emitter_ray_v r;
    r.env = active & (u[0] < lt->env_threshold);
    r.delta = active & (intv)(0);
    r.infinite = r.env;
    r.valid = active & (intv)(0);
    r.pos = v3s(0.0f);
    r.n = v3(0.0f, 0.0f, 1.0f);
    r.d = r.n;
    r.radiance = v3s(0.0f);
    r.pdf_area = (floatv)(0.0f);
    r.pdf_solid_angle = (floatv)(0.0f);
    r.cos_theta = (floatv)(0.0f);
    intv area = active & !r.env;
    if (lt->nlights > 0u && lane_any(area)) {
        uintv k = light_find(lt, u[1]);
        LIGHT_RECORD_GATHER(q, lt->light_rec, k);
        vec3v base = REC_VEC3(q, LIGHT_RECORD_BASE);
        floatv area_l = REC_FIELD(q, LIGHT_RECORD_AREA);
        floatv shape = REC_FIELD(q, LIGHT_RECORD_SHAPE);
        floatv pmf = REC_FIELD(q, LIGHT_RECORD_PMF) * (1.0f - lt->env_pmf);
        /* triangle: barycentrics (1 - sqrt(u1), u2 sqrt(u1)) of (v1, v2), as lights.cl */
        vec3v e1 = REC_VEC3(q, LIGHT_RECORD_EDGE1), e2 = REC_VEC3(q, LIGHT_RECORD_EDGE2);
        floatv su = lane_sqrt(u[2]);
        vec3v y = v3_madd(v3_madd(base, 1.0f - su, e1), u[3] * su, e2);
        vec3v ny = v3_normalize(v3_cross(e1, e2));
        intv sph = area & ((shape == (float)LIGHT_SPHERE) | (shape == (float)LIGHT_SPHERE_INWARD));
        if (lane_any(sph)) {
            /* sphere: uniform by area over the whole sphere; the front normal points
             * inwards for a flipped sphere */
            vec3v no = square_to_uniform_sphere(u[2], u[3]);
            floatv radius = REC_FIELD(q, LIGHT_RECORD_EDGE1);
            y = v3_select(y, v3_madd(base, radius, no), sph);
            ny = v3_select(ny, v3_select(no, v3_neg(no), shape == (float)LIGHT_SPHERE_INWARD), sph);
        }
        floatv pdf_dir;
        vec3v w_local = square_to_cosine_hemisphere(u[4], u[5], &pdf_dir);
        frame3v fr = frame_from_normal(ny);
        floatv pdf_a = pmf / area_l;
        intv ok = area & (pdf_a > 0.0f) & lane_finite(pdf_a);
        r.pos = v3_select(r.pos, y, area);
        r.n = v3_select(r.n, ny, area);
        r.d = v3_select(r.d, frame_to_world(fr, w_local), area);
        r.cos_theta = lane_select(r.cos_theta, w_local.z, area);
        r.pdf_area = lane_select(r.pdf_area, pdf_a, ok);
        r.pdf_solid_angle = lane_select(r.pdf_solid_angle, pdf_dir, ok);
        /* a textured emitter: its texture at the sampled point (render/lights.cl) */
        vec3v rad = emitter_radiance_of_prim(lt, lane_as_uint(REC_FIELD(q, LIGHT_RECORD_PRIM)), 1.0f - su,
                                             u[3] * su, y, REC_VEC3(q, LIGHT_RECORD_RADIANCE),
                                             ok & !light_shape_is_delta(shape));
        r.radiance = v3_select(r.radiance, rad, ok);
        r.valid = r.valid | ok;
        intv dl = area & light_shape_is_delta(shape);
        if (lane_any(dl))
            emitter_ray_delta(&r, base, shape, e1, REC_VEC3(q, LIGHT_RECORD_EDGE2), area_l,
                              REC_VEC3(q, LIGHT_RECORD_RADIANCE), pmf, bsphere, u, dl);
    }
    if (lt->env_pmf > 0.0f && lane_any(r.env)) {
        vec3v d = square_to_uniform_sphere(u[2], u[3]);
        floatv pdf_d = (floatv)(RT_INV_4PI);
        vec3v le = v3((floatv)(lt->env_radiance.x), (floatv)(lt->env_radiance.y), (floatv)(lt->env_radiance.z));
        if (lt->has_env_map) {
            /* the map's density picks where the light comes from; it travels the other way */
            vec3v from = envmap_sample(&lt->env_map, u[2], u[3], &pdf_d);
            d = v3_neg(from);
            le = envmap_radiance(&lt->env_map, from, r.env);
        }
        frame3v fr = frame_from_normal(d);
        floatv rad = bsphere.w;
        /* uniform point of the disk: polar map r = R sqrt(u4), phi = 2 pi u5 */
        floatv c;
        floatv s = lane_sincos_2pi(u[5], &c);
        floatv rr = rad * lane_sqrt(u[4]);
        vec3v centre = v3((floatv)(bsphere.x), (floatv)(bsphere.y), (floatv)(bsphere.z));
        vec3v on_disk = v3_madd(centre, -rad * (1.0f + EMIT_DISK_MARGIN), d);
        on_disk = v3_madd(v3_madd(on_disk, rr * c, fr.s), rr * s, fr.t);
        r.pos = v3_select(r.pos, on_disk, r.env);
        r.n = v3_select(r.n, d, r.env);
        r.d = v3_select(r.d, d, r.env);
        r.cos_theta = lane_select(r.cos_theta, (floatv)(1.0f), r.env);
        r.pdf_area = lane_select(r.pdf_area, (floatv)(lt->env_pmf / (RT_PI * rad * rad)), r.env);
        r.pdf_solid_angle = lane_select(r.pdf_solid_angle, pdf_d, r.env);
        r.radiance = v3_select(r.radiance, le, r.env);
        r.valid = r.valid | (r.env & (pdf_d > 0.0f) & lane_finite(pdf_d));
    }
    return r;
}

/* The density with which sample_emitter_ray picks direction d at a point of
 * an area emitter with front normal n (cos(theta) / pi, zero from behind). */
MC_INLINE floatv emitter_pdf_solid_angle(vec3v n, vec3v d) {
    floatv c = v3_dot(n, d);
    return lane_select((floatv)(0.0f), c * RT_INV_PI, c > 0.0f);
}

#endif
