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

#endif
