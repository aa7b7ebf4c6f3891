/* delta_lights.cl — point, spot and directional lights: emitters with no
 * surface, which no ray can hit (host: mcocl/render/delta_lights.py).
 *
 * They take part only where a vertex is *connected* to a light: next-event
 * estimation (render/lights.cl, with MIS weight 1 since BSDF sampling can
 * never find them, Veach's thesis §9.2.2) and the start of light paths
 * (render/lights_emit.cl; bdpt.cl).  A path tracer without light sampling never sees
 * them.  The light records (LIGHT_RECORD of layouts.cl, shape POINT, SPOT or
 * DIRECTIONAL) hold:
 *   POINT        base = position, radiance = intensity I (W/sr);
 *   SPOT         as POINT, edge1 = unit axis, edge2 = (cos cutoff, cos beam,
 *                cutoff in radians), area = 1 / (cutoff - beam) (0 when the
 *                two angles are equal);
 *   DIRECTIONAL  base = unit direction of travel, radiance = irradiance E
 *                (W/m^2 on a surface facing the light).
 *
 * Mitsuba 3's spot falloff (its spot emitter's documentation): full intensity
 * within beam_width of the axis, falling linearly in the angle to 0 at
 * cutoff_angle, 0 beyond.
 */
#ifndef MCOCL_RENDER_DELTA_LIGHTS_CL
#define MCOCL_RENDER_DELTA_LIGHTS_CL

#include "render/vec3.cl"

/* The shape codes >= LIGHT_POINT are the delta lights (mcocl/layouts.py LightShape). */
MC_INLINE intv light_shape_is_delta(floatv shape) { return shape >= (float)LIGHT_POINT; }

/* The spot's intensity factor at cos_t, the cosine between its axis and the
 * direction of emission (cone = edge2: cos cutoff, cos beam, cutoff). */
MC_INLINE floatv spot_falloff(floatv cos_t, vec3v cone, floatv inv_width) {
    floatv ramp = (cone.z - acos(lane_clamp(cos_t, -1.0f, 1.0f))) * inv_width;
    floatv f = lane_select(lane_clamp(ramp, 0.0f, 1.0f), (floatv)(1.0f), cos_t >= cone.y);
    return lane_select((floatv)(0.0f), f, cos_t > cone.x);
}

/* A delta light as seen from p: the unit direction wo toward it, the point
 * the shadow ray ends at (the light's position; p + wo for a directional
 * light, whose shadow ray is unbounded: *unbounded set), and the factor of
 * the record's radiance that arrives at p per unit solid-angle density: the
 * falloff / distance^2 of point and spot lights, 1 for a directional light
 * (its irradiance). */
MC_INLINE floatv delta_light_toward(vec3v base, floatv shape, vec3v axis, vec3v cone, floatv inv_width, vec3v p,
                                    vec3v *wo, vec3v *pos, intv *unbounded) {
    intv directional = shape == (float)LIGHT_DIRECTIONAL;
    vec3v dv = v3_sub(base, p);
    floatv d2 = v3_len2(dv);
    vec3v w_pt = v3_scale(dv, lane_rsqrt(d2));
    vec3v w_dir = v3_neg(base);
    *wo = v3_select(w_pt, w_dir, directional);
    *pos = v3_select(base, v3_add(p, w_dir), directional);
    *unbounded = directional;
    floatv fall = lane_select((floatv)(1.0f), spot_falloff(-v3_dot(axis, w_pt), cone, inv_width),
                              shape == (float)LIGHT_SPOT);
    return lane_select(fall / d2, (floatv)(1.0f), directional);
}

/* Uniform direction in the cone of half-angle acos(cos_max) about +z, pdf 1 / (2 pi (1 - cos_max)). */
MC_INLINE vec3v square_to_uniform_cone(floatv u1, floatv u2, floatv cos_max) {
    floatv z = 1.0f - u1 * (1.0f - cos_max);
    floatv r = safe_sqrt(1.0f - z * z);
    floatv c;
    floatv s = lane_sincos_2pi(u2, &c);
    return v3(r * c, r * s, z);
}

#endif
