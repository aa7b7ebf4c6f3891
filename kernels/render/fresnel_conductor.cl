/* fresnel_conductor.cl — the unpolarised Fresnel reflectance of a conductor,
 * complex index of refraction eta + i k relative to the outside medium, per
 * RGB channel: the exact formula of the s and p amplitudes written with
 * a^2 + b^2 = |(eta + i k)^2 - sin^2 theta| (pbrt-v3 §8.2.1, "Fresnel
 * reflectance" for conductors; also Mitsuba 3's fresnel_conductor).
 * eta 0, k 1 gives 1 at every angle (Mitsuba's perfect mirror, material="none").
 */
#ifndef MCOCL_FRESNEL_CONDUCTOR_CL
#define MCOCL_FRESNEL_CONDUCTOR_CL

#include "render/vec3.cl"

/* One channel: reflectance at incidence cosine c (clamped to [0, 1]). */
MC_INLINE floatv fresnel_conductor_1(floatv c, floatv eta, floatv k) {
    c = lane_min(lane_max(c, 0.0f), 1.0f);
    floatv c2 = c * c, s2 = 1.0f - c2;
    floatv e2 = eta * eta, k2 = k * k;
    floatv t0 = e2 - k2 - s2;
    floatv a2pb2 = lane_sqrt(t0 * t0 + 4.0f * e2 * k2);
    floatv a = lane_sqrt(lane_max(0.5f * (a2pb2 + t0), 0.0f));
    floatv t1 = a2pb2 + c2, t2 = 2.0f * c * a;
    floatv rs = (t1 - t2) / (t1 + t2);
    floatv t3 = c2 * a2pb2 + s2 * s2, t4 = t2 * s2;
    floatv rp = rs * (t3 - t4) / (t3 + t4);
    return 0.5f * (rs + rp);
}

MC_INLINE vec3v fresnel_conductor(floatv c, vec3v eta, vec3v k) {
    return v3(fresnel_conductor_1(c, eta.x, k.x), fresnel_conductor_1(c, eta.y, k.y), fresnel_conductor_1(c, eta.z, k.z));
}

#endif
