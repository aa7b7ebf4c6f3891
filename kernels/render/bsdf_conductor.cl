/* bsdf_conductor.cl — a smooth metal, Mitsuba 3's `conductor`: a perfect
 * mirror times the specular reflectance, and for the lanes whose material has
 * MAT_FLAG_COMPLEX_IOR times the conductor Fresnel term of its eta + i k
 * (render/fresnel_conductor.cl).
 * A Dirac delta lobe: `eval` is zero for every direction (no light sampling
 * at a mirror), sampling returns the reflected direction with weight R. */
#ifndef MCOCL_BSDF_CONDUCTOR_CL
#define MCOCL_BSDF_CONDUCTOR_CL

#include "render/material.cl"
#include "render/fresnel_conductor.cl"

MC_INLINE vec3v reflect_local(vec3v w) { return v3(-w.x, -w.y, w.z); }

/* mat->color is the specular reflectance R; the uniforms are unused (a delta lobe), eta 1. */
MC_INLINE vec3v conductor_bsdf_sample(const material_v *mat, vec3v wi, floatv u_lobe, floatv u1, floatv u2,
                                      vec3v *wo, floatv *pdf, floatv *eta, int mode) {
    *wo = reflect_local(wi);
    intv ok = wi.z > 0.0f;  /* one-sided: black from behind */
    *pdf = lane_select((floatv)(0.0f), (floatv)(1.0f), ok);
    *eta = (floatv)(1.0f);
    vec3v r = mat->color;
    intv cplx = (mat->flags & MAT_FLAG_COMPLEX_IOR) != 0;
    if (lane_any(cplx)) {
        vec3v eta, k;
        material_conductor_ior(mat, &eta, &k);
        r = v3_select(r, v3_mul(r, fresnel_conductor(wi.z, eta, k)), cplx);
    }
    return v3_select(v3s(0.0f), r, ok);
}

#endif
