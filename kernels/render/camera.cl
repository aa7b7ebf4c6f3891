/* camera.cl — primary rays of the perspective pinhole camera.
 *
 * CompiledScene.camera is one camera_record (layouts.cl): origin, right, up,
 * forward, one float4 each.  A
 * film point (sx, sy) in pixels (row 0 at the top, column 0 at the left)
 * maps to ndc_x = 2 sx / W - 1, ndc_y = 1 - 2 sy / H and the direction
 * normalize(forward + ndc_x right + ndc_y up); `right` and `up` already
 * carry the tangent of the half field of view and the aspect ratio.
 * The pixel filter is a box: (sx, sy) = pixel corner + a uniform jitter, so a
 * pixel's value is the plain mean of its samples.
 *
 * The adjoint half (light tracing, kernels/render/lt.cl).  With the image
 * plane at distance 1, of area A = 4 |right| |up|, and uniform film points,
 * a primary ray of angle theta to `forward` has the density
 * pdf_solid_angle = 1 / (A cos^3 theta) (dA = dw / cos^3 theta), and the
 * importance that makes the whole image's measurement the mean radiance over
 * the film is W_e = 1 / (A cos^4 theta), so that the integral of
 * W_e cos theta over the image's directions is 1 (Veach's thesis §10.2,
 * pbrt-v4 §5.2.x PerspectiveCamera::We).  Pixel j, a box of A / (W H), has
 * W_e^(j) = W H W_e on its directions.  The pinhole is a point: a scene
 * point connects to it deterministically, with the density d^2 / cos theta
 * (the unit "lens area" of pbrt's pinhole, in solid angle at the point).
 */
#ifndef MCOCL_RENDER_CAMERA_CL
#define MCOCL_RENDER_CAMERA_CL

#include "layouts.cl"
#include "render/vec3.cl"

MC_INLINE vec3v cam_row(float4 r) { return v3((floatv)(r.x), (floatv)(r.y), (floatv)(r.z)); }

/* The ray through film point (sx, sy); the origin is the same for all lanes. */
MC_INLINE vec3v camera_ray(global const float4 *cam, floatv sx, floatv sy, float inv_w, float inv_h, vec3v *origin) {
    *origin = cam_row(cam[CAMERA_RECORD_ORIGIN_QUAD]);
    floatv ndc_x = 2.0f * sx * inv_w - 1.0f;
    floatv ndc_y = 1.0f - 2.0f * sy * inv_h;
    vec3v d = v3_madd(v3_madd(cam_row(cam[CAMERA_RECORD_FORWARD_QUAD]), ndc_x, cam_row(cam[CAMERA_RECORD_RIGHT_QUAD])),
                      ndc_y, cam_row(cam[CAMERA_RECORD_UP_QUAD]));
    return v3_normalize(d);
}

/* Where the direction d (unit, from the camera) meets the film: raster
 * position (sx, sy) in pixels and the pixel index (row-major); cos theta to
 * `forward`.  Valid when d points forwards and lands inside the image. */
typedef struct {
    floatv raster_x, raster_y;
    uintv pixel;
    floatv cos_theta;
    floatv importance;       /* W_e of the whole image, 1 / (A cos^4 theta) */
    floatv pdf_solid_angle;  /* density of d among primary rays, 1 / (A cos^3 theta) */
    intv valid;
} camera_direction_v;

MC_INLINE camera_direction_v camera_importance(global const float4 *cam, vec3v d, uint width, uint height) {
    vec3v fwd = cam_row(cam[CAMERA_RECORD_FORWARD_QUAD]);
    vec3v right = cam_row(cam[CAMERA_RECORD_RIGHT_QUAD]);
    vec3v up = cam_row(cam[CAMERA_RECORD_UP_QUAD]);
    float r2 = cam[CAMERA_RECORD_RIGHT_QUAD].x * cam[CAMERA_RECORD_RIGHT_QUAD].x +
               cam[CAMERA_RECORD_RIGHT_QUAD].y * cam[CAMERA_RECORD_RIGHT_QUAD].y +
               cam[CAMERA_RECORD_RIGHT_QUAD].z * cam[CAMERA_RECORD_RIGHT_QUAD].z;
    float u2 = cam[CAMERA_RECORD_UP_QUAD].x * cam[CAMERA_RECORD_UP_QUAD].x +
               cam[CAMERA_RECORD_UP_QUAD].y * cam[CAMERA_RECORD_UP_QUAD].y +
               cam[CAMERA_RECORD_UP_QUAD].z * cam[CAMERA_RECORD_UP_QUAD].z;
    float inv_area = 0.25f * rsqrt(r2 * u2);
    camera_direction_v c;
    c.cos_theta = v3_dot(d, fwd);
    intv front = c.cos_theta > 0.0f;
    floatv z = lane_select((floatv)(1.0f), c.cos_theta, front);
    floatv ndc_x = v3_dot(d, right) / (z * r2);
    floatv ndc_y = v3_dot(d, up) / (z * u2);
    c.raster_x = 0.5f * (ndc_x + 1.0f) * (float)width;
    c.raster_y = 0.5f * (1.0f - ndc_y) * (float)height;
    intv inside = front & (c.raster_x >= 0.0f) & (c.raster_x < (float)width) & (c.raster_y >= 0.0f) &
                  (c.raster_y < (float)height);
    floatv rx = lane_select((floatv)(0.0f), c.raster_x, inside);
    floatv ry = lane_select((floatv)(0.0f), c.raster_y, inside);
    uintv px = lane_min_u(to_uintv_rtz(rx), (uintv)(width - 1u));
    uintv py = lane_min_u(to_uintv_rtz(ry), (uintv)(height - 1u));
    c.pixel = py * width + px;
    floatv c2 = z * z;
    c.pdf_solid_angle = lane_select((floatv)(0.0f), inv_area / (c2 * z), inside);
    c.importance = lane_select((floatv)(0.0f), inv_area / (c2 * c2), inside);
    c.valid = inside;
    return c;
}

/* A scene point p connected to the pinhole: the unit direction wo from p to
 * the camera, the distance, where it lands on the film and with what
 * importance, and the pdf_solid_angle (at p) d^2 / cos theta of the
 * connection.  Visibility is the caller's shadow ray from p along wo. */
typedef struct {
    vec3v wo;
    floatv dist;
    camera_direction_v film;
    floatv pdf_solid_angle;
    intv valid;
} camera_connection_v;

MC_INLINE camera_connection_v camera_connect(global const float4 *cam, vec3v p, uint width, uint height) {
    camera_connection_v k;
    vec3v v = v3_sub(cam_row(cam[CAMERA_RECORD_ORIGIN_QUAD]), p);
    floatv d2 = v3_len2(v);
    k.dist = lane_sqrt(d2);
    k.wo = v3_scale(v, 1.0f / k.dist);
    k.film = camera_importance(cam, v3_neg(k.wo), width, height);
    k.valid = k.film.valid & (d2 > 0.0f);
    k.pdf_solid_angle = lane_select((floatv)(0.0f), d2 / k.film.cos_theta, k.valid);
    return k;
}

#endif
