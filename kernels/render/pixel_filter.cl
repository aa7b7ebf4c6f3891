/* pixel_filter.cl — the reconstruction filter by filter importance sampling
 * (pbrt-v4 §8.8: the film gathers, and each camera sample's offset from the
 * pixel centre is drawn from the filter itself, so a positive filter gives
 * every sample the weight 1 and a pixel stays the plain mean of its samples;
 * its expectation is the filter-weighted mean of the radiance over the
 * filter's support, the same as Mitsuba 3's weighted splatting).
 *
 * The filters are separable, f(x, y) = f1(x) f1(y) (Mitsuba 3 weighs a
 * sample by the product of the 1-D filter on both axes), so each film
 * coordinate is drawn alone from one uniform of the camera's dimensions 0-1
 * (rng/streams.cl).  A build without -DPIXEL_FILTER_SHAPED has only the box;
 * a build with it serves every tent and Gaussian, whose kind (the codes of
 * mcocl/render/pixel_filter.py), radius and stddev are launch values
 * (render_params filter_kind, filter_radius, filter_stddev; one branch on the
 * kind, the same in every lane), so no filter setting costs a build of its own:
 *   PIXEL_FILTER_BOX       offset uniform on the pixel; the film point is
 *                          the pixel corner + u, exactly as before filters
 *                          existed, so box renders stay bit-identical;
 *   PIXEL_FILTER_TENT      f1(x) = max(0, 1 - |x| / r) (Mitsuba's `tent`,
 *                          r = 1 by default): the inverse CDF in closed form,
 *                          x = -r + r sqrt(2u) for u < 1/2, r - r sqrt(2 - 2u) above;
 *   PIXEL_FILTER_GAUSSIAN  f1(x) = max(0, exp(-x^2 / (2 s^2)) - exp(-r^2 / (2 s^2)))
 *                          (Mitsuba's `gaussian`: s = 0.5, r = 4 s by default):
 *                          |x| solves H(t) = v H(r) with
 *                          H(t) = s sqrt(pi/2) erf(t / (s sqrt 2)) - b t, the
 *                          integral of f1 over [0, t], v = |2u - 1| and the
 *                          sign of x that of u - 1/2.  The start is the
 *                          untruncated Gaussian's quantile, t0 = s sqrt 2
 *                          erfinv(v) by Winitzki's closed-form approximation
 *                          of erfinv (relative error ~2e-3, "A handy
 *                          approximation for the error function and its
 *                          inverse", 2008); H is increasing and concave on
 *                          [0, r], so Newton's iteration converges from either
 *                          side (quadratically: a fixed FILTER_NEWTON_STEPS
 *                          = 3 reach float precision, the same in every lane),
 *                          and a bracket [lo, hi] turns a step that would
 *                          leave it into bisection.
 *
 * Splatting (lt.cl, bdpt.cl; pbrt-v4 §8.8 splats light-traced contributions
 * with the filter's value): a contribution that lands at film point x adds
 * f(x - c_p) times itself to every pixel p whose centre c_p lies within the
 * filter's support, f normalised to unit integral (filter_weight), so that
 * pixel p estimates the same filter-weighted mean as its camera samples
 * (filter importance sampling draws x with density f(x - c_p): weight 1).
 * Camera samples of the pixels at the image's edge reach film points up to
 * filter_margin pixels outside it, so camera connections are accepted there
 * too (camera.cl, camera_importance): a path that a camera subpath can
 * sample can then be sampled by a light subpath as well, and bdpt's MIS
 * weights, which do not depend on the pixel, still sum to 1 for it.
 */
#ifndef MCOCL_RENDER_PIXEL_FILTER_CL
#define MCOCL_RENDER_PIXEL_FILTER_CL

#include "layouts.cl"
#include "lanes.cl"
#include "lane_ops.cl"

#define PIXEL_FILTER_BOX 0
#define PIXEL_FILTER_TENT 1
#define PIXEL_FILTER_GAUSSIAN 2

/* The launch's filter (render_params filter_kind, filter_radius, filter_stddev); read only by a
 * -DPIXEL_FILTER_SHAPED build, the box build ignores it. */
typedef struct {
    int kind;
    float radius, stddev;
} pixel_filter;

MC_INLINE pixel_filter pixel_filter_of(const render_params *p) {
    pixel_filter f;
    f.kind = p->filter_kind;
    f.radius = p->filter_radius;
    f.stddev = p->filter_stddev;
    return f;
}

#ifdef PIXEL_FILTER_SHAPED
#define FILTER_NEWTON_STEPS 3
#define WINITZKI_A 0.147f
/* H(t), the integral of the Gaussian filter over [0, t]; t in [0, radius]. */
MC_INLINE floatv filter_gauss_integral(floatv t, float scale, float k, float bias) {
    return scale * erf(t * k) - bias * t;
}

/* The tent's offset from the pixel centre, in pixels, drawn with the uniform u in [0, 1). */
MC_INLINE floatv filter_tent_offset(float r, floatv u) {
    intv low = u < 0.5f;
    floatv lo = -r + r * lane_sqrt(2.0f * u);
    floatv hi = r - r * lane_sqrt(lane_max(2.0f - 2.0f * u, (floatv)(0.0f)));
    return lane_select(hi, lo, low);
}

/* The Gaussian's offset from the pixel centre, in pixels, drawn with the uniform u in [0, 1). */
MC_INLINE floatv filter_gauss_offset(float r, float s, floatv u) {
    const float k = M_SQRT1_2_F / s;                 /* 1 / (s sqrt 2) */
    const float scale = s * 1.2533141373155003f;     /* s sqrt(pi / 2) */
    const float bias = exp(-0.5f * (r / s) * (r / s));
    const float total = scale * erf(r * k) - bias * r;
    intv neg = u < 0.5f;
    floatv v = lane_abs(2.0f * u - 1.0f);
    floatv target = v * total;
    /* erfinv(v) ~ sqrt(sqrt(c^2 - l / a) - c), c = 2 / (pi a) + l / 2, l = ln(1 - v^2) */
    floatv l = log(lane_max(1.0f - v * v, (floatv)(1e-30f)));
    floatv c = 0.63661977f / WINITZKI_A + 0.5f * l;
    floatv t0 = lane_sqrt(lane_max(lane_sqrt(c * c - l / WINITZKI_A) - c, (floatv)(0.0f))) / k;
    floatv t = lane_min(t0, (floatv)(r)), lo = (floatv)(0.0f), hi = (floatv)(r);
    for (int i = 0; i < FILTER_NEWTON_STEPS; ++i) {
        floatv g = filter_gauss_integral(t, scale, k, bias) - target;
        intv below = g < 0.0f;
        lo = lane_select(lo, t, below);
        hi = lane_select(t, hi, below);
        floatv dens = exp(-(t * k) * (t * k)) - bias;
        floatv step = t - g / dens;
        /* outside the bracket (or a vanishing density, a NaN step): bisect instead */
        intv bad = !(step >= lo) | !(step <= hi);
        t = lane_select(step, 0.5f * (lo + hi), bad);
    }
    return lane_select(t, -t, neg);
}
#endif

/* The offset from the pixel centre, in pixels, drawn from the filter with the uniform u in [0, 1). */
MC_INLINE floatv filter_offset(const pixel_filter *f, floatv u) {
#ifdef PIXEL_FILTER_SHAPED
    if (f->kind == PIXEL_FILTER_TENT) return filter_tent_offset(f->radius, u);
    if (f->kind == PIXEL_FILTER_GAUSSIAN) return filter_gauss_offset(f->radius, f->stddev, u);
#endif
    return u - 0.5f;
}

/* How far past the image's edge, in pixels, a camera sample's film point may lie. */
MC_INLINE float filter_margin(const pixel_filter *f) {
#ifdef PIXEL_FILTER_SHAPED
    if (f->kind != PIXEL_FILTER_BOX) return f->radius - 0.5f;
#endif
    return 0.0f;
}

#ifdef PIXEL_FILTER_SHAPED
/* The 1-D filter f1 at offset x (pixels) over its integral: the density of filter_offset's offsets
 * (a tent or a Gaussian). */
MC_INLINE float filter_weight(const pixel_filter *f, float x) {
    const float r = f->radius;
    const float a = fabs(x);
    if (f->kind == PIXEL_FILTER_TENT) return a < r ? (1.0f - a / r) / r : 0.0f;
    const float s = f->stddev;
    const float k = M_SQRT1_2_F / s;
    const float bias = exp(-0.5f * (r / s) * (r / s));
    const float total = 2.0f * (s * 1.2533141373155003f * erf(r * k) - bias * r); /* the integral over [-r, r] */
    return a < r ? fmax(exp(-(a * k) * (a * k)) - bias, 0.0f) / total : 0.0f;
}
#endif

/* The film coordinate of a camera sample in pixel column/row `base` (as a
 * float) from the uniform u: the box keeps base + u bit for bit. */
MC_INLINE floatv film_coordinate(const pixel_filter *f, floatv base, floatv u) {
#ifdef PIXEL_FILTER_SHAPED
    if (f->kind != PIXEL_FILTER_BOX) return base + 0.5f + filter_offset(f, u);
#endif
    return base + u;
}

#endif
