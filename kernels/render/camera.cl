/* camera.cl — the perspective camera, pinhole or thin lens, in both
 * directions: primary rays (path tracing) and the importance of a
 * connection from the scene (light tracing, kernels/render/lt.cl).
 *
 * CompiledScene.camera is one camera_record (layouts.cl): origin, right, up,
 * forward, one float4 each, with the aperture radius in origin.w (0: a
 * pinhole) and the focus distance in right.w.  A film point (sx, sy) in
 * pixels (row 0 at the top, column 0 at the left) maps to
 * ndc_x = 2 sx / W - 1, ndc_y = 1 - 2 sy / H and the pinhole direction
 * d = forward + ndc_x right + ndc_y up (forward component 1); `right` and `up`
 * already carry the tangent of the half field of view and the aspect ratio.
 * The film point (sx, sy) is drawn from the pixel filter
 * (render/pixel_filter.cl; the box: pixel corner + a uniform jitter).
 *
 * A film crop (Mitsuba's hdrfilm crop_*): W x H is the crop, `right` and `up`
 * span the crop's part of the image plane, and up.w / forward.w hold the crop
 * centre's position (crop_shift_x, crop_shift_y) in those units, added to
 * ndc_x, ndc_y (0 without a crop: x + 0 = x bit for bit).  The optical axis
 * stays `forward`, so the importance below (its cos theta to the axis, the
 * crop's image-plane area A) holds unchanged.
 *
 * Thin lens (Mitsuba 3's `thinlens`, pbrt-v4 §5.2.3): a point x_l uniform on
 * the aperture disk of radius a (area A_lens = pi a^2) in the plane of right
 * and up through the origin, and the ray from x_l through the point of the
 * focal plane the pinhole ray meets, origin + focus_distance d.  Points at
 * the focus distance are sharp; the pinhole is the limit a -> 0.
 *
 * The adjoint half.  With the image plane at distance 1, of area
 * A = 4 |right| |up|, and uniform film points, a primary ray of angle theta to
 * `forward` has the density pdf_solid_angle = 1 / (A cos^3 theta) from its lens
 * point (dA = dw / cos^3 theta, on the focal plane as on the image plane),
 * and the importance that makes the whole image's measurement the mean
 * radiance over film and lens is W_e = 1 / (A A_lens cos^4 theta) (A_lens = 1
 * for the pinhole), so that W_e cos theta integrates to 1 over the image's
 * directions and the lens (Veach's thesis §10.2, pbrt-v3's
 * PerspectiveCamera::We).  Pixel j, a box of A / (W H), has
 * W_e^(j) = W H W_e on its directions.  A scene point p connects to a lens
 * point sampled uniformly (the pinhole: its one point) with the density
 * d^2 / (cos theta A_lens) in solid angle at p.
 */
#ifndef MCOCL_RENDER_CAMERA_CL
#define MCOCL_RENDER_CAMERA_CL

#include "layouts.cl"
#include "render/vec3.cl"
#include "render/pixel_filter.cl"

MC_INLINE vec3v cam_row(float4 r) { return v3((floatv)(r.x), (floatv)(r.y), (floatv)(r.z)); }

/* The thin lens's aperture radius, 0 for a pinhole. */
MC_INLINE float camera_aperture(global const float4 *cam) {
    return cam[CAMERA_RECORD_APERTURE_RADIUS_QUAD].CAMERA_RECORD_APERTURE_RADIUS_COMP;
}

/* The lens's area: pi a^2, or 1 for the pinhole (whose importance is per unit "area"). */
MC_INLINE float camera_lens_area(global const float4 *cam) {
    float a = camera_aperture(cam);
    return a > 0.0f ? RT_PI * a * a : 1.0f;
}

/* A point uniform on the aperture disk from (u1, u2) (polar map r = a sqrt(u1),
 * phi = 2 pi u2); the origin for a pinhole. */
MC_INLINE vec3v camera_lens_point(global const float4 *cam, floatv u1, floatv u2) {
    vec3v o = cam_row(cam[CAMERA_RECORD_ORIGIN_QUAD]);
    float a = camera_aperture(cam);
    if (a <= 0.0f) return o;
    float4 r4 = cam[CAMERA_RECORD_RIGHT_QUAD], u4 = cam[CAMERA_RECORD_UP_QUAD];
    float inv_r = rsqrt(r4.x * r4.x + r4.y * r4.y + r4.z * r4.z);
    float inv_u = rsqrt(u4.x * u4.x + u4.y * u4.y + u4.z * u4.z);
    floatv c;
    floatv s = lane_sincos_2pi(u2, &c);
    floatv rr = a * lane_sqrt(u1);
    return v3_madd(v3_madd(o, rr * c * inv_r, cam_row(r4)), rr * s * inv_u, cam_row(u4));
}

/* The crop centre's shift of ndc_x and ndc_y (0, 0 without a crop). */
MC_INLINE float camera_crop_shift_x(global const float4 *cam) {
    return cam[CAMERA_RECORD_CROP_SHIFT_X_QUAD].CAMERA_RECORD_CROP_SHIFT_X_COMP;
}
MC_INLINE float camera_crop_shift_y(global const float4 *cam) {
    return cam[CAMERA_RECORD_CROP_SHIFT_Y_QUAD].CAMERA_RECORD_CROP_SHIFT_Y_COMP;
}

/* The pinhole direction through film point (sx, sy), forward component 1. */
MC_INLINE vec3v camera_film_direction(global const float4 *cam, floatv sx, floatv sy, float inv_w, float inv_h) {
    floatv ndc_x = 2.0f * sx * inv_w - 1.0f + camera_crop_shift_x(cam);
    floatv ndc_y = 1.0f - 2.0f * sy * inv_h + camera_crop_shift_y(cam);
    return v3_madd(v3_madd(cam_row(cam[CAMERA_RECORD_FORWARD_QUAD]), ndc_x, cam_row(cam[CAMERA_RECORD_RIGHT_QUAD])),
                   ndc_y, cam_row(cam[CAMERA_RECORD_UP_QUAD]));
}

/* The pinhole's ray through film point (sx, sy); the origin is the same for all lanes. */
MC_INLINE vec3v camera_ray(global const float4 *cam, floatv sx, floatv sy, float inv_w, float inv_h, vec3v *origin) {
    *origin = cam_row(cam[CAMERA_RECORD_ORIGIN_QUAD]);
    return v3_normalize(camera_film_direction(cam, sx, sy, inv_w, inv_h));
}

/* The thin lens's ray through film point (sx, sy) from the lens point of (ul1, ul2). */
MC_INLINE vec3v camera_ray_lens(global const float4 *cam, floatv sx, floatv sy, float inv_w, float inv_h, floatv ul1,
                                floatv ul2, vec3v *origin) {
    vec3v d = camera_film_direction(cam, sx, sy, inv_w, inv_h);
    float focus = cam[CAMERA_RECORD_FOCUS_DISTANCE_QUAD].CAMERA_RECORD_FOCUS_DISTANCE_COMP;
    vec3v focal = v3_madd(cam_row(cam[CAMERA_RECORD_ORIGIN_QUAD]), (floatv)(focus), d);
    *origin = camera_lens_point(cam, ul1, ul2);
    return v3_normalize(v3_sub(focal, *origin));
}

/* The launch's camera settings (render_params; host: mcocl/render/job.py):
 * Mitsuba's clip planes, in scene units along the optical axis (near 0 and
 * far +INFINITY clip nothing), and the reconstruction filter
 * (render/pixel_filter.cl).  Launch values rather than build options, so one
 * build serves every clip and filter; each use below branches on a scalar
 * (the same in every lane), so an unclipped render runs the very arithmetic
 * it ran before clips existed and stays bit-identical. */
typedef struct {
    float near_clip, far_clip;
    pixel_filter filter;
} camera_settings;

MC_INLINE camera_settings camera_settings_of(const render_params *p) {
    camera_settings c;
    c.near_clip = p->near_clip;
    c.far_clip = p->far_clip;
    c.filter = pixel_filter_of(p);
    return c;
}

MC_INLINE bool camera_has_near_clip(camera_settings settings) { return settings.near_clip > 0.0f; }
MC_INLINE bool camera_has_far_clip(camera_settings settings) { return settings.far_clip < INFINITY; }

/* Mitsuba's near_clip: the primary ray starts where it crosses the plane at
 * that distance in front of its origin, o + d near / (d . forward), so
 * geometry nearer than the plane is not seen.  The camera rays of bdpt start
 * there too (render/bdpt.cl). */
MC_INLINE vec3v camera_clip_origin(global const float4 *cam, camera_settings settings, vec3v o, vec3v d) {
    if (!camera_has_near_clip(settings)) return o;
    return v3_madd(o, settings.near_clip / v3_dot(d, cam_row(cam[CAMERA_RECORD_FORWARD_QUAD])), d);
}

/* Mitsuba's far_clip: a primary ray ends where it crosses the plane at that
 * distance, maxt = (far - near) / (d . forward) from its near-clipped origin
 * (Mitsuba 3's perspective and thinlens sample_ray), so geometry beyond the
 * plane is not seen and the ray escapes to the environment.  That maxt (with
 * a far clip). */
MC_INLINE floatv camera_far_extent(global const float4 *cam, camera_settings settings, vec3v d) {
    const float span = camera_has_near_clip(settings) ? settings.far_clip - settings.near_clip : settings.far_clip;
    return span / v3_dot(d, cam_row(cam[CAMERA_RECORD_FORWARD_QUAD]));
}

/* Whether the hit at distance t of the (near-clipped) primary ray in
 * direction d lies beyond the far clip plane (never without a far clip). */
MC_INLINE intv camera_beyond_far_clip(global const float4 *cam, camera_settings settings, vec3v d, floatv t) {
    if (!camera_has_far_clip(settings)) return (intv)(0);
    return t > camera_far_extent(cam, settings, d);
}

/* How far a ray from the (near-clipped) origin of a primary ray in direction
 * d may look: to the far clip plane, or without end. */
MC_INLINE floatv camera_ray_extent(global const float4 *cam, camera_settings settings, vec3v d) {
    if (!camera_has_far_clip(settings)) return (floatv)(INFINITY);
    return camera_far_extent(cam, settings, d);
}

/* Whether a scene point at depth z = (p - lens) . forward along the optical
 * axis lies between the clip planes: what the clipped primary rays can see. */
MC_INLINE intv camera_depth_seen(camera_settings settings, floatv z) {
    intv seen = z == z;
    if (camera_has_near_clip(settings)) seen = seen & (z >= settings.near_clip);
    if (camera_has_far_clip(settings)) seen = seen & (z <= settings.far_clip);
    return seen;
}

/* The part of a segment of length dist from a scene point toward the lens,
 * at cos_theta to the optical axis, that the camera sees through: up to the
 * near clip plane (geometry nearer than it is invisible and does not block;
 * the whole segment without a near clip). */
MC_INLINE floatv camera_unclipped_length(camera_settings settings, floatv dist, floatv cos_theta) {
    if (!camera_has_near_clip(settings)) return dist;
    return dist - settings.near_clip / cos_theta;
}

/* Where the ray from lens point xl in the unit direction d meets the film:
 * raster position (sx, sy) in pixels and the pixel index (row-major; the
 * nearest pixel for a point past the edge); cos theta to `forward`.  Valid
 * when d points forwards and lands inside the image, or within the
 * filter_margin that a reconstruction filter's camera samples reach past its
 * edge (render/pixel_filter.cl; 0 for the box). */
typedef struct {
    floatv raster_x, raster_y;
    uintv pixel;
    floatv cos_theta;
    floatv importance;       /* W_e of the whole image, 1 / (A A_lens cos^4 theta) */
    floatv pdf_solid_angle;  /* density of d among primary rays from xl, 1 / (A cos^3 theta) */
    intv valid;
} camera_direction_v;

MC_INLINE camera_direction_v camera_importance(global const float4 *cam, const camera_settings *cs, vec3v xl, vec3v d,
                                               uint width, uint height) {
    vec3v fwd = cam_row(cam[CAMERA_RECORD_FORWARD_QUAD]);
    vec3v right = cam_row(cam[CAMERA_RECORD_RIGHT_QUAD]);
    vec3v up = cam_row(cam[CAMERA_RECORD_UP_QUAD]);
    float4 r4 = cam[CAMERA_RECORD_RIGHT_QUAD], u4 = cam[CAMERA_RECORD_UP_QUAD];
    float r2 = r4.x * r4.x + r4.y * r4.y + r4.z * r4.z;
    float u2 = u4.x * u4.x + u4.y * u4.y + u4.z * u4.z;
    float inv_area = 0.25f * rsqrt(r2 * u2);
    camera_direction_v c;
    c.cos_theta = v3_dot(d, fwd);
    intv front = c.cos_theta > 0.0f;
    floatv z = lane_select((floatv)(1.0f), c.cos_theta, front);
    /* the film point: the pinhole direction of the focal-plane point the ray passes (d itself for a pinhole) */
    vec3v v = d;
    if (camera_aperture(cam) > 0.0f) {
        float focus = cam[CAMERA_RECORD_FOCUS_DISTANCE_QUAD].CAMERA_RECORD_FOCUS_DISTANCE_COMP;
        v = v3_scale(v3_sub(v3_madd(xl, focus / z, d), cam_row(cam[CAMERA_RECORD_ORIGIN_QUAD])), 1.0f / focus);
    }
    floatv vz = lane_select((floatv)(1.0f), v3_dot(v, fwd), front);
    floatv ndc_x = v3_dot(v, right) / (vz * r2) - camera_crop_shift_x(cam);
    floatv ndc_y = v3_dot(v, up) / (vz * u2) - camera_crop_shift_y(cam);
    c.raster_x = 0.5f * (ndc_x + 1.0f) * (float)width;
    c.raster_y = 0.5f * (1.0f - ndc_y) * (float)height;
    const float margin = filter_margin(&cs->filter);
    intv inside = front & (c.raster_x >= -margin) & (c.raster_x < (float)width + margin) &
                  (c.raster_y >= -margin) & (c.raster_y < (float)height + margin);
    floatv rx = lane_max(lane_select((floatv)(0.0f), c.raster_x, inside), (floatv)(0.0f));
    floatv ry = lane_max(lane_select((floatv)(0.0f), c.raster_y, inside), (floatv)(0.0f));
    uintv px = lane_min_u(to_uintv_rtz(rx), (uintv)(width - 1u));
    uintv py = lane_min_u(to_uintv_rtz(ry), (uintv)(height - 1u));
    c.pixel = py * width + px;
    floatv c2 = z * z;
    c.pdf_solid_angle = lane_select((floatv)(0.0f), inv_area / (c2 * z), inside);
    c.importance = lane_select((floatv)(0.0f), inv_area / (camera_lens_area(cam) * c2 * c2), inside);
    c.valid = inside;
    return c;
}

/* A scene point p connected to the lens point of (ul1, ul2) (the pinhole:
 * its one point): the unit direction wo from p to that point, the distance,
 * where it lands on the film and with what importance, and the
 * pdf_solid_angle (at p) d^2 / (cos theta A_lens) of the connection.
 * Visibility is the caller's shadow ray from p to `lens`. */
typedef struct {
    vec3v lens;
    vec3v wo;
    floatv dist;
    camera_direction_v film;
    floatv pdf_solid_angle;
    intv valid;
    camera_settings settings;  /* the clip planes it was checked against (its shadow ray stops at the near one) */
} camera_connection_v;

MC_INLINE camera_connection_v camera_connect(global const float4 *cam, camera_settings settings, vec3v p, floatv ul1,
                                             floatv ul2, uint width, uint height) {
    camera_connection_v k;
    k.lens = camera_lens_point(cam, ul1, ul2);
    vec3v v = v3_sub(k.lens, p);
    floatv d2 = v3_len2(v);
    k.dist = lane_sqrt(d2);
    k.wo = v3_scale(v, 1.0f / k.dist);
    k.film = camera_importance(cam, &settings, k.lens, v3_neg(k.wo), width, height);
    k.valid = k.film.valid & (d2 > 0.0f);
    k.settings = settings;
    /* the point must lie between the clip planes, as for the primary rays that could see it */
    if (camera_has_near_clip(settings) || camera_has_far_clip(settings))
        k.valid = k.valid & camera_depth_seen(settings, k.dist * k.film.cos_theta);
    k.pdf_solid_angle = lane_select((floatv)(0.0f), d2 / (k.film.cos_theta * camera_lens_area(cam)), k.valid);
    return k;
}

#endif
