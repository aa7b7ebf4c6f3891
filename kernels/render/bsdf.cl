/* bsdf.cl — the materials of a scene and one entry point per BSDF query.
 *
 * Materials come from CompiledScene.materials, one material_record each
 * (layouts.cl, from mcocl/layouts.py): kind (a MaterialKind code: MAT_DIFFUSE,
 * MAT_CONDUCTOR (mirror), MAT_ROUGHCONDUCTOR (GGX), MAT_DIELECTRIC), rgb,
 * alpha, int_ior, ext_ior.
 *
 * In a lane build the eight paths of a packet may sit on different
 * materials: every kind present in the packet is evaluated and the lanes
 * take their own kind's result (a kind absent from the packet costs one
 * test).  In the scalar build the same code is an ordinary branch.
 *
 * Conventions (Mitsuba 3): directions in the local frame of the surface's
 * front normal, both pointing away from the surface; eval returns f cos(theta_o)
 * and the solid-angle pdf of sampling wo; sample returns f cos / pdf.
 *
 * Transport modes (Veach's thesis §5.2; pbrt-v4's TransportMode, Mitsuba 3's
 * TransportMode): camera paths carry radiance (TRANSPORT_RADIANCE), light
 * paths importance (TRANSPORT_IMPORTANCE: wi points to the previous vertex of
 * the light path, wo towards the camera side).  Every BSDF here is symmetric
 * except the dielectric's refraction, whose (eta_i / eta_t)^2 radiance scaling
 * the adjoint leaves out; eval is therefore the same in both modes, and only
 * bsdf_sample takes the mode.
 */
#ifndef MCOCL_BSDF_CL
#define MCOCL_BSDF_CL

#include "layouts.cl"
#include "render/vec3.cl"
#include "sampling/gather.cl"
#include "render/lane_io.cl"
#include "render/bsdf_diffuse.cl"
#include "render/bsdf_conductor.cl"
#include "render/bsdf_roughconductor.cl"
#include "render/bsdf_dielectric.cl"


#define TRANSPORT_RADIANCE 0
#define TRANSPORT_IMPORTANCE 1

typedef struct {
    intv kind;
    vec3v color;  /* albedo (diffuse), specular reflectance (conductors), tint (dielectric) */
    floatv alpha; /* GGX roughness */
    floatv eta;   /* int_ior / ext_ior */
} material_v;

/* The material record `index` of every lane (MATERIAL_RECORD_QUADS float4 per material). */
MC_INLINE material_v material_load(global const float4 *mats, uintv index) {
    MATERIAL_RECORD_GATHER(q, mats, index);
    material_v m;
    m.kind = to_intv(REC_FIELD(q, MATERIAL_RECORD_KIND));
    m.color = REC_VEC3(q, MATERIAL_RECORD_RGB);
    m.alpha = REC_FIELD(q, MATERIAL_RECORD_ALPHA);
    m.eta = REC_FIELD(q, MATERIAL_RECORD_INT_IOR) / REC_FIELD(q, MATERIAL_RECORD_EXT_IOR);
    return m;
}

/* Lanes whose material has a non-delta lobe: light sampling applies there. */
MC_INLINE intv bsdf_is_smooth(const material_v *m) {
    return (m->kind == MAT_DIFFUSE) | (m->kind == MAT_ROUGHCONDUCTOR);
}

/* f cos(theta_o) for the pair (wi, wo), and the pdf of sampling wo from wi.
 * Zero for the delta materials (a mirror never reflects a sampled light). */
MC_INLINE vec3v bsdf_eval(const material_v *m, vec3v wi, vec3v wo, floatv *pdf) {
    vec3v f = v3s(0.0f);
    floatv p = (floatv)(0.0f);
    intv is_d = m->kind == MAT_DIFFUSE;
    if (lane_any(is_d)) {
        floatv pd;
        vec3v fd = diffuse_eval(m->color, wi, wo, &pd);
        f = v3_select(f, fd, is_d);
        p = lane_select(p, pd, is_d);
    }
    intv is_r = m->kind == MAT_ROUGHCONDUCTOR;
    if (lane_any(is_r)) {
        floatv pr;
        vec3v fr = roughconductor_eval(m->color, m->alpha, wi, wo, &pr);
        f = v3_select(f, fr, is_r);
        p = lane_select(p, pr, is_r);
    }
    *pdf = p;
    return f;
}

typedef struct {
    vec3v wo;      /* sampled direction (local frame) */
    vec3v weight;  /* f cos / pdf; zero when the sample failed */
    floatv pdf;    /* solid-angle pdf, or the lobe's probability for a delta lobe */
    floatv eta;    /* eta_t / eta_i of the move (refraction), else 1 */
    intv delta;    /* the sampled lobe is a Dirac delta */
} bsdf_sample_v;

/* Sample wo given wi; u_lobe picks a lobe (dielectric), (u1, u2) the direction;
 * mode: TRANSPORT_RADIANCE or TRANSPORT_IMPORTANCE. */
MC_INLINE bsdf_sample_v bsdf_sample(const material_v *m, vec3v wi, floatv u_lobe, floatv u1, floatv u2, int mode) {
    bsdf_sample_v s;
    s.wo = v3(0.0f, 0.0f, 1.0f);
    s.weight = v3s(0.0f);
    s.pdf = (floatv)(0.0f);
    s.eta = (floatv)(1.0f);
    s.delta = (m->kind == MAT_CONDUCTOR) | (m->kind == MAT_DIELECTRIC);
    intv is_d = m->kind == MAT_DIFFUSE;
    if (lane_any(is_d)) {
        vec3v wo;
        floatv p;
        vec3v w = diffuse_sample(m->color, wi, u1, u2, &wo, &p);
        s.wo = v3_select(s.wo, wo, is_d);
        s.weight = v3_select(s.weight, w, is_d);
        s.pdf = lane_select(s.pdf, p, is_d);
    }
    intv is_c = m->kind == MAT_CONDUCTOR;
    if (lane_any(is_c)) {
        vec3v wo;
        floatv p;
        vec3v w = conductor_sample(m->color, wi, &wo, &p);
        s.wo = v3_select(s.wo, wo, is_c);
        s.weight = v3_select(s.weight, w, is_c);
        s.pdf = lane_select(s.pdf, p, is_c);
    }
    intv is_r = m->kind == MAT_ROUGHCONDUCTOR;
    if (lane_any(is_r)) {
        vec3v wo;
        floatv p;
        vec3v w = roughconductor_sample(m->color, m->alpha, wi, u1, u2, &wo, &p);
        s.wo = v3_select(s.wo, wo, is_r);
        s.weight = v3_select(s.weight, w, is_r);
        s.pdf = lane_select(s.pdf, p, is_r);
    }
    intv is_g = m->kind == MAT_DIELECTRIC;
    if (lane_any(is_g)) {
        vec3v wo;
        floatv p, e;
        vec3v w = dielectric_sample(m->color, m->eta, wi, u_lobe, mode == TRANSPORT_IMPORTANCE, &wo, &p, &e);
        s.wo = v3_select(s.wo, wo, is_g);
        s.weight = v3_select(s.weight, w, is_g);
        s.pdf = lane_select(s.pdf, p, is_g);
        s.eta = lane_select(s.eta, e, is_g);
    }
    return s;
}

#endif
