/* bdpt_weight_test.cl — a check that bdpt.cl's MIS weights of one path sum
 * to 1 (Veach's thesis eq. 10.9: sum over s + t = k + 1 of w_{s,t}(x) = 1),
 * for tests/test_bdpt_weights.py.
 *
 * Per sample, a camera and a light subpath are grown by bdpt_walk (the
 * render's own walk, pinhole or thin lens) and joined by every deterministic
 * strategy (s, t) of bdpt.cl (s = 0 or s >= 2 with t >= 2; t = 1 with s >= 2
 * for a pinhole: no random numbers inside the connection).  For each joined
 * path x_0 (lens) .. x_k (emitter) the kernel recomputes, from the vertices
 * alone, the area density of every vertex from the camera side (pc) and from
 * the light side (pl) (at a specular vertex next to a connectable one the
 * projected solid-angle density, bdpt.cl's density_toward), lays them out as the subpaths of every strategy
 * (s', t') that could have produced x (s' + t' = k + 1 within the depth caps,
 * the connection's two vertices not delta-scattering), and asks bdpt_mis_weight
 * for each weight.  A path is bad when its weights do not sum to 1
 * (|sum - 1| > WEIGHT_TOL) or when the weight the render's own connection gave
 * it (bdpt_connect or bdpt_connect_camera: the walk's densities) differs from
 * the one recomputed from the vertices (relative WEIGHT_TOL).  Counts per
 * sample, splatted to its own pixel: R paths checked, G bad paths, B checked
 * paths with a delta-scattering vertex.  The splat film divides by the
 * pixel's samples, so the image holds per-sample means.
 *
 * Lanes as bdpt.cl: LANES samples per work-item, grown and joined by the
 * render's lane code; a strategy (s, t) joins every lane's path of the same
 * length k = s + t - 1, so the check runs on all lanes at once, masked where
 * a lane's path was not joined.
 */
#include "render/bdpt.cl"

#define WEIGHT_TOL 1e-3f
#define PATH_MAX (2 * BDPT_MAX_VERTICES)

/* Unit direction from a to b. */
MC_INLINE vec3v unit_to(vec3v a, vec3v b) { return v3_normalize(v3_sub(b, a)); }

/* The density with which surface vertex v samples world direction w_out, light arriving along w_in
 * (both pointing away from v): vertex_eval of the render, given v's material and frame, in the
 * transport mode of the subpath that would sample it. */
MC_INLINE floatv pdf_at(const bdpt_scene *sc, const bdpt_vertex *v, vec3v w_in, vec3v w_out, int mode) {
    vertex_bsdf b = vertex_bsdf_of(sc, v);
    b.wi_local = frame_to_local(b.fr, w_in);
    floatv pdf;
    vertex_eval(&b, w_out, &pdf, 0, mode);
    return pdf;
}

/* The weights of every strategy of path x[0..k] (x[0] the lens, x[k] on an emitter, delta: how the path
 * scatters at each vertex); *w_st: that of (s, t).  Returns their sum. */
MC_INLINE floatv path_weight_sum(const bdpt_scene *sc, const bdpt_vertex *x, int k, int s, int t, int nl_cap,
                                 int nc_cap, floatv *w_st) {
    floatv pc[PATH_MAX], pl[PATH_MAX];
    intv spec[PATH_MAX]; /* specular vertices take projected solid-angle densities (bdpt.cl, density_toward) */
    spec[0] = spec[k] = (intv)(0);
    for (int i = 1; i < k; ++i) {
        const material_v m = material_load(sc->materials, x[i].mat);
        spec[i] = specular_vertex(&m, &x[i]);
    }
    pc[0] = (floatv)(1.0f);
    pl[k] = x[k].light_pdf_area;
    for (int i = 1; i <= k; ++i) {  /* x_i from x_{i-1} (given x_{i-2}) */
        floatv pdf;
        if (i == 1) {
            pdf = camera_importance(sc->camera, &sc->cam_set, x[0].p, unit_to(x[0].p, x[1].p), sc->width, sc->height)
                      .pdf_solid_angle;
        } else {
            pdf = pdf_at(sc, &x[i - 1], unit_to(x[i - 1].p, x[i - 2].p), unit_to(x[i - 1].p, x[i].p), TRANSPORT_RADIANCE);
            pdf = lane_select(pdf, (floatv)(0.0f), x[i - 1].delta);
        }
        pc[i] = density_toward(pdf, x[i - 1].p, x[i - 1].n, x[i].p, x[i].n, spec[i]);
    }
    for (int i = k - 1; i >= 1; --i) {  /* x_i from x_{i+1} (given x_{i+2}) */
        floatv pdf;
        if (i == k - 1) {
            pdf = emitter_pdf_solid_angle(x[k].n, unit_to(x[k].p, x[i].p));
        } else {
            pdf = pdf_at(sc, &x[i + 1], unit_to(x[i + 1].p, x[i + 2].p), unit_to(x[i + 1].p, x[i].p), TRANSPORT_IMPORTANCE);
            pdf = lane_select(pdf, (floatv)(0.0f), x[i + 1].delta);
        }
        pl[i] = density_toward(pdf, x[i + 1].p, x[i + 1].n, x[i].p, x[i].n, spec[i]);
    }
    pl[0] = (floatv)(0.0f);
    floatv sum = (floatv)(0.0f);
    *w_st = (floatv)(-1.0f);
    bdpt_vertex cam[BDPT_MAX_VERTICES], light[BDPT_MAX_VERTICES];
    for (int tt = 1; tt <= k + 1; ++tt) {
        int ss = k + 1 - tt;
        if (tt > nc_cap || ss > nl_cap) continue;
        /* no connection at a delta scattering */
        const intv joinable = ss > 0 ? !(x[tt - 1].delta | x[tt].delta) : !(intv)(0);
        for (int j = 0; j < tt; ++j) {
            cam[j] = x[j];
            cam[j].pdf_fwd = pc[j];
            cam[j].pdf_rev = pl[j];
        }
        for (int j = 0; j < ss; ++j) {
            light[j] = x[k - j];
            light[j].pdf_fwd = pl[k - j];
            light[j].pdf_rev = pc[k - j];
        }
        floatv w = bdpt_mis_weight(sc, light, cam, ss, tt, nl_cap, nc_cap);
        sum += lane_select((floatv)(0.0f), w, joinable);
        if (ss == s && tt == t) *w_st = w;
    }
    return sum;
}

/* x[0..k]: cam[0..t-1] then light[s-1..0]; the joined endpoints scatter by their smooth lobes. */
MC_INLINE int join_path(const bdpt_vertex *cam, const bdpt_vertex *light, int s, int t, bdpt_vertex *x) {
    for (int j = 0; j < t; ++j) x[j] = cam[j];
    for (int j = 0; j < s; ++j) x[t + j] = light[s - 1 - j];
    int k = s + t - 1;
    x[t - 1].delta = (intv)(0);
    if (s > 0) x[t].delta = (intv)(0);
    if (s > 0) x[k].light_pdf_area = light[0].light_pdf_area;
    return k;
}

kernel void bdpt_weight_check(
    SPLAT_TRACE_PARAMS)
{
    SPLAT_TRACE_PRELUDE;
    const bdpt_scene sc = bdpt_scene_of(&params, &geom, &pt, &lt, camera, materials, textures, bsphere, npix);
    const bool thin_lens = camera_aperture(camera) > 0.0f;
    const int nc_cap = max_depth >= 0 ? min(max_depth + 1, BDPT_MAX_VERTICES) : BDPT_MAX_VERTICES;
    const int nl_cap = max_depth >= 0 ? min(max_depth, BDPT_MAX_VERTICES) : BDPT_MAX_VERTICES;
    const vec3v forward = cam_row(camera[CAMERA_RECORD_FORWARD_QUAD]);
    bdpt_vertex cam[BDPT_MAX_VERTICES], light[BDPT_MAX_VERTICES], x[PATH_MAX];
    vertex_bsdf cam_b[BDPT_MAX_VERTICES], light_b[BDPT_MAX_VERTICES];

    for (ulong j = 0; j < pg.total; j += LANES) {
        const intv active = LANE_IOTA < (uintv)((uint)min(pg.total - j, (ulong)LANES));
        const ulongv index = (ulongv)(pg.path0 + j) + to_ulongv(LANE_IOTA);
        const uintv pixel = to_uintv(index % (ulongv)(pg.npix));
        mc_sampler_t cs = sampler_start(params.seed, index, RNG_STREAM_RENDER);
        floatv uc[4];
        sampler_seek(&cs, (uintv)(RENDER_DIM_CAMERA));
        sampler_next_nd(&cs, 4, uc);
        uintv py = pixel / width;
        vec3v co, cd;
        floatv sx = to_floatv(pixel - py * width) + uc[0], sy = to_floatv(py) + uc[1];
        cd = thin_lens ? camera_ray_lens(camera, sx, sy, 1.0f / width, 1.0f / height, uc[2], uc[3], &co)
                       : camera_ray(camera, sx, sy, 1.0f / width, 1.0f / height, &co);
        cam[0] = lens_vertex(co, forward);
        floatv pdf_cam = camera_importance(camera, &sc.cam_set, co, cd, width, height).pdf_solid_angle;
        intv nc = lane_select((intv)(0), (intv)(1), active);
        bdpt_walk(&sc, &cs, cam, cam_b, &nc, active, nc_cap, camera_clip_origin(camera, sc.cam_set, co, cd), cd, v3s(1.0f),
                  pdf_cam, TRANSPORT_RADIANCE, params.rr_depth, (floatv)(1.0f), 0);
        mc_sampler_t ls = sampler_start(params.seed, index, RNG_STREAM_LIGHT_TRACE);
        floatv ue[8];
        sampler_seek(&ls, (uintv)(LT_DIM_EMIT));
        sampler_next_nd(&ls, 8, ue);
        intv nl = (intv)(0);
        if (nl_cap > 0) {
            emitter_ray_v er = sample_emitter_ray(&lt, bsphere, ue, active);
            const intv area = er.valid & !er.env;
            bdpt_vertex y0 = {er.pos, er.n, er.n, v3s(1.0f), er.pdf_area, (floatv)(0.0f), er.pdf_area,
                              (intv)(-1), (uintv)(0u), (intv)(0)};
            light[0] = y0;
            vec3v b1 = v3_scale(er.radiance, er.cos_theta / (er.pdf_area * er.pdf_solid_angle));
            nl = lane_select(nl, (intv)(1), area);
            bdpt_walk(&sc, &ls, light, light_b, &nl, area & (v3_maxc(b1) > 0.0f), nl_cap, offset_origin(er.pos, er.n, er.d),
                      er.d, b1, er.pdf_solid_angle, TRANSPORT_IMPORTANCE, params.rr_depth, v3_maxc(b1), 0);
        }
        floatv checked = (floatv)(0.0f), bad = (floatv)(0.0f), with_delta = (floatv)(0.0f);
        for (int t = 1; lane_any(nc >= t); ++t) {
            const intv has_t = nc >= t;
            for (int s = 0; lane_any(has_t & (nl >= s)); ++s) {
                if (s == 1 || s + t < 2 || (max_depth >= 0 && s + t - 1 > max_depth)) continue;
                if (t == 1 && (s < 2 || thin_lens)) continue;
                const intv run = has_t & (nl >= s);
                floatv w;
                if (t == 1) {
                    camera_direction_v film;
                    bdpt_connect_camera(&sc, light, light_b, cam, s, (floatv)(0.0f), (floatv)(0.0f), run, nl_cap, nc_cap,
                                        &film, &w);
                } else {
                    floatv ul[4] = {(floatv)(0.0f), (floatv)(0.0f), (floatv)(0.0f), (floatv)(0.0f)};
                    /* threshold 0: no connection roulette (every weight is the exact one) */
                    bdpt_connect(&sc, light, light_b, cam, s, t, ul, cam_b, run, nl_cap, nc_cap, &ls, (floatv)(0.0f), &w);
                }
                const intv joined = w > 0.0f;  /* not joined: occluded, no contribution */
                if (!lane_any(joined)) continue;
                int k = join_path(cam, light, s, t, x);
                floatv w_st;
                floatv sum = path_weight_sum(&sc, x, k, s, t, nl_cap, nc_cap, &w_st);
                const intv wrong = !(lane_abs(sum - 1.0f) <= WEIGHT_TOL) |
                                   !(lane_abs(w_st - w) <= WEIGHT_TOL * lane_max(w, w_st));
                intv any_delta = (intv)(0);
                for (int i = 1; i < k; ++i) any_delta |= x[i].delta;
                checked += lane_select((floatv)(0.0f), (floatv)(1.0f), joined);
                bad += lane_select((floatv)(0.0f), (floatv)(1.0f), joined & wrong);
                with_delta += lane_select((floatv)(0.0f), (floatv)(1.0f), joined & any_delta);
            }
        }
        const intv got = active & (checked > 0.0f);
        if (lane_any(got)) splat(pg.img, pixel, v3_scale(v3(checked, bad, with_delta), sc.pixels), got);
    }
}
