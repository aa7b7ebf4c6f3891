/* bsdf_conductor.cl — a perfect mirror (Mitsuba 3's `conductor` with a
 * constant specular reflectance in place of the complex Fresnel term).
 * A Dirac delta lobe: `eval` is zero for every direction (no light sampling
 * at a mirror), sampling returns the reflected direction with weight R. */
#ifndef MCOCL_BSDF_CONDUCTOR_CL
#define MCOCL_BSDF_CONDUCTOR_CL

#include "render/vec3.cl"

MC_INLINE vec3v reflect_local(vec3v w) { return v3(-w.x, -w.y, w.z); }

MC_INLINE vec3v conductor_sample(vec3v spec, vec3v wi, vec3v *wo, floatv *pdf) {
    *wo = reflect_local(wi);
    intv ok = wi.z > 0.0f;  /* one-sided: black from behind */
    *pdf = lane_select((floatv)(0.0f), (floatv)(1.0f), ok);
    return v3_select(v3s(0.0f), spec, ok);
}

#endif
