/* bsdf.cl — GENERATED from mcocl/bsdf_registry.py by `python -m mcocl.layouts`; do not edit.
 *
 * One entry point per BSDF query, dispatching on material_record.kind to the
 * functions of each registered BSDF's kernel file (render/bsdf_<name>.cl).
 * In a lane build the paths of a packet may sit on different materials: every
 * kind present in the packet is evaluated and the lanes take their own kind's
 * result (a kind absent from the packet costs one test); in the scalar build
 * the same code is an ordinary branch.
 *
 * Conventions (Mitsuba 3): directions in the local frame of the surface's
 * front normal, both pointing away from the surface; eval returns f cos(theta_o)
 * and the solid-angle pdf of sampling wo; sample returns f cos / pdf.
 *
 * Transport modes (Veach's thesis §5.2; pbrt-v4's and Mitsuba 3's TransportMode):
 * camera paths carry radiance (TRANSPORT_RADIANCE), light paths importance
 * (TRANSPORT_IMPORTANCE).  The BSDFs here are symmetric but for refraction's
 * radiance scaling: sample passes the mode to every BSDF's sample function,
 * eval (bsdf_eval_mode) to the smooth refracting ones (roughdielectric).
 */
#ifndef MCOCL_BSDF_CL
#define MCOCL_BSDF_CL

#include "render/material.cl"

#define TRANSPORT_RADIANCE 0
#define TRANSPORT_IMPORTANCE 1

#include "render/bsdf_diffuse.cl"
#include "render/bsdf_conductor.cl"
#include "render/bsdf_roughconductor.cl"
#include "render/bsdf_dielectric.cl"
#include "render/bsdf_plastic.cl"
#include "render/bsdf_roughdielectric.cl"
#include "render/bsdf_thindielectric.cl"
#include "render/bsdf_roughplastic.cl"

/* Lanes that see a twosided material from behind.  There the BSDF is the
 * front one mirrored through the surface (Mitsuba 3's `twosided`): eval and
 * sample flip the z of wi (and of wo) so that every BSDF sees a front-side
 * query, and sample flips the z of the sampled wo back. */
MC_INLINE intv bsdf_mirrored(const material_v *m, vec3v wi) {
    return ((m->flags & MAT_FLAG_TWOSIDED) != 0) & (wi.z < 0.0f);
}

/* Lanes whose material has a non-delta lobe: light sampling applies there. */
MC_INLINE intv bsdf_is_smooth(const material_v *m) {
    return (m->kind == MAT_DIFFUSE) | (m->kind == MAT_ROUGHCONDUCTOR) | (m->kind == MAT_PLASTIC) | (m->kind == MAT_ROUGHDIELECTRIC) | (m->kind == MAT_ROUGHPLASTIC);
}

/* f cos(theta_o) for the pair (wi, wo), and the pdf of sampling wo from wi, in
 * transport mode `mode` (it matters to rough refraction only, see the top).
 * Zero for the delta materials (a mirror never reflects a sampled light). */
MC_INLINE vec3v bsdf_eval_mode(const material_v *m, vec3v wi, vec3v wo, floatv *pdf, int mode) {
    vec3v f = v3s(0.0f);
    floatv p = (floatv)(0.0f);
    intv back = bsdf_mirrored(m, wi);
    wi.z = lane_select(wi.z, -wi.z, back);
    wo.z = lane_select(wo.z, -wo.z, back);
    intv is_diffuse = m->kind == MAT_DIFFUSE;
    if (lane_any(is_diffuse)) {
        floatv pk;
        vec3v fk = diffuse_bsdf_eval(m, wi, wo, &pk);
        f = v3_select(f, fk, is_diffuse);
        p = lane_select(p, pk, is_diffuse);
    }
    intv is_roughconductor = m->kind == MAT_ROUGHCONDUCTOR;
    if (lane_any(is_roughconductor)) {
        floatv pk;
        vec3v fk = roughconductor_bsdf_eval(m, wi, wo, &pk);
        f = v3_select(f, fk, is_roughconductor);
        p = lane_select(p, pk, is_roughconductor);
    }
    intv is_plastic = m->kind == MAT_PLASTIC;
    if (lane_any(is_plastic)) {
        floatv pk;
        vec3v fk = plastic_bsdf_eval(m, wi, wo, &pk);
        f = v3_select(f, fk, is_plastic);
        p = lane_select(p, pk, is_plastic);
    }
    intv is_roughdielectric = m->kind == MAT_ROUGHDIELECTRIC;
    if (lane_any(is_roughdielectric)) {
        floatv pk;
        vec3v fk = roughdielectric_bsdf_eval(m, wi, wo, &pk, mode);
        f = v3_select(f, fk, is_roughdielectric);
        p = lane_select(p, pk, is_roughdielectric);
    }
    intv is_roughplastic = m->kind == MAT_ROUGHPLASTIC;
    if (lane_any(is_roughplastic)) {
        floatv pk;
        vec3v fk = roughplastic_bsdf_eval(m, wi, wo, &pk);
        f = v3_select(f, fk, is_roughplastic);
        p = lane_select(p, pk, is_roughplastic);
    }
    *pdf = p;
    return f;
}

/* bsdf_eval_mode for camera paths (radiance). */
MC_INLINE vec3v bsdf_eval(const material_v *m, vec3v wi, vec3v wo, floatv *pdf) {
    return bsdf_eval_mode(m, wi, wo, pdf, TRANSPORT_RADIANCE);
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
MC_INLINE bsdf_sample_v bsdf_sample(const material_v *m, vec3v wi, floatv u_lobe, floatv u1, floatv u2,
                                    int mode) {
    bsdf_sample_v s;
    s.wo = v3(0.0f, 0.0f, 1.0f);
    s.weight = v3s(0.0f);
    s.pdf = (floatv)(0.0f);
    s.eta = (floatv)(1.0f);
    s.delta = (m->kind == MAT_CONDUCTOR) | (m->kind == MAT_DIELECTRIC) | (m->kind == MAT_THINDIELECTRIC);
    intv back = bsdf_mirrored(m, wi);
    wi.z = lane_select(wi.z, -wi.z, back);
    intv is_diffuse = m->kind == MAT_DIFFUSE;
    if (lane_any(is_diffuse)) {
        vec3v wo;
        floatv p, e;
        vec3v w = diffuse_bsdf_sample(m, wi, u_lobe, u1, u2, &wo, &p, &e, mode);
        s.wo = v3_select(s.wo, wo, is_diffuse);
        s.weight = v3_select(s.weight, w, is_diffuse);
        s.pdf = lane_select(s.pdf, p, is_diffuse);
    }
    intv is_conductor = m->kind == MAT_CONDUCTOR;
    if (lane_any(is_conductor)) {
        vec3v wo;
        floatv p, e;
        vec3v w = conductor_bsdf_sample(m, wi, u_lobe, u1, u2, &wo, &p, &e, mode);
        s.wo = v3_select(s.wo, wo, is_conductor);
        s.weight = v3_select(s.weight, w, is_conductor);
        s.pdf = lane_select(s.pdf, p, is_conductor);
    }
    intv is_roughconductor = m->kind == MAT_ROUGHCONDUCTOR;
    if (lane_any(is_roughconductor)) {
        vec3v wo;
        floatv p, e;
        vec3v w = roughconductor_bsdf_sample(m, wi, u_lobe, u1, u2, &wo, &p, &e, mode);
        s.wo = v3_select(s.wo, wo, is_roughconductor);
        s.weight = v3_select(s.weight, w, is_roughconductor);
        s.pdf = lane_select(s.pdf, p, is_roughconductor);
    }
    intv is_dielectric = m->kind == MAT_DIELECTRIC;
    if (lane_any(is_dielectric)) {
        vec3v wo;
        floatv p, e;
        vec3v w = dielectric_bsdf_sample(m, wi, u_lobe, u1, u2, &wo, &p, &e, mode);
        s.wo = v3_select(s.wo, wo, is_dielectric);
        s.weight = v3_select(s.weight, w, is_dielectric);
        s.pdf = lane_select(s.pdf, p, is_dielectric);
        s.eta = lane_select(s.eta, e, is_dielectric);
    }
    intv is_plastic = m->kind == MAT_PLASTIC;
    if (lane_any(is_plastic)) {
        vec3v wo;
        floatv p, e;
        intv dl;
        vec3v w = plastic_bsdf_sample(m, wi, u_lobe, u1, u2, &wo, &p, &e, mode, &dl);
        s.wo = v3_select(s.wo, wo, is_plastic);
        s.weight = v3_select(s.weight, w, is_plastic);
        s.pdf = lane_select(s.pdf, p, is_plastic);
        s.delta = lane_select(s.delta, dl, is_plastic);
    }
    intv is_roughdielectric = m->kind == MAT_ROUGHDIELECTRIC;
    if (lane_any(is_roughdielectric)) {
        vec3v wo;
        floatv p, e;
        vec3v w = roughdielectric_bsdf_sample(m, wi, u_lobe, u1, u2, &wo, &p, &e, mode);
        s.wo = v3_select(s.wo, wo, is_roughdielectric);
        s.weight = v3_select(s.weight, w, is_roughdielectric);
        s.pdf = lane_select(s.pdf, p, is_roughdielectric);
        s.eta = lane_select(s.eta, e, is_roughdielectric);
    }
    intv is_thindielectric = m->kind == MAT_THINDIELECTRIC;
    if (lane_any(is_thindielectric)) {
        vec3v wo;
        floatv p, e;
        vec3v w = thindielectric_bsdf_sample(m, wi, u_lobe, u1, u2, &wo, &p, &e, mode);
        s.wo = v3_select(s.wo, wo, is_thindielectric);
        s.weight = v3_select(s.weight, w, is_thindielectric);
        s.pdf = lane_select(s.pdf, p, is_thindielectric);
        s.eta = lane_select(s.eta, e, is_thindielectric);
    }
    intv is_roughplastic = m->kind == MAT_ROUGHPLASTIC;
    if (lane_any(is_roughplastic)) {
        vec3v wo;
        floatv p, e;
        vec3v w = roughplastic_bsdf_sample(m, wi, u_lobe, u1, u2, &wo, &p, &e, mode);
        s.wo = v3_select(s.wo, wo, is_roughplastic);
        s.weight = v3_select(s.weight, w, is_roughplastic);
        s.pdf = lane_select(s.pdf, p, is_roughplastic);
    }
    s.wo.z = lane_select(s.wo.z, -s.wo.z, back);
    return s;
}

#endif
