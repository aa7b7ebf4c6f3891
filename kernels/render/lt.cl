/* lt.cl — light tracing with next-event estimation to the camera (the
 * lecture's "Light Tracing – šíření světla" and "NEE pro Light Tracing"):
 * paths start at the emitters (render/lights_emit.cl), and every non-delta
 * vertex, the emitter's own included, is connected to the camera
 * (render/camera.cl, camera_connect: the pinhole, or a point uniform on a
 * thin lens); an unoccluded connection adds its contribution to the pixel it
 * lands on.  Light reaching a thin lens is counted by these connections (a
 * light path that happened to cross the lens disk would estimate the same
 * paths again; it is not counted).
 *
 * Estimator (Veach's thesis §10.2, the s >= 1, t = 1 strategies of BDPT).
 * With beta the light path's throughput at vertex y_i (beta_0 = L_e / pdf_area
 * before the direction is sampled; beta_1 = L_e cos / (pdf_area pdf_solid_angle),
 * times f cos / pdf per bounce after that), pixel j of W x H receives
 *     W H  beta  f(y_i; wi -> camera) cos_y  W_e / pdf_solid_angle(camera connection)
 * (for y_0: L_e(y_0 -> camera) cos_y W_e / (pdf_area pdf_solid_angle)), and the
 * image is the sum over light paths divided by their number.  The BSDF works
 * in importance mode (render/bsdf.cl; the dielectric's refraction without
 * the 1/eta^2 of radiance).  The environment is seen directly through a
 * connection of its sampled direction: the camera looks along -d, with the
 * density env_pmf / (4 pi) of that direction.
 *
 * What light tracing cannot see.  A pinhole is a point: no light path hits
 * it, so light reaches the image only through a connection from a non-delta
 * vertex (a thin lens too, since crossings of the lens are not counted).  A mirror or glass surface seen directly (or through other delta
 * vertices only) is therefore black, and so is everything visible only in
 * it: those paths (camera - delta ... - first non-delta vertex) need a
 * camera subpath (path tracing, BDPT).
 *
 * The camera's clip planes (render_params near_clip, far_clip; render/camera.cl): a
 * connection counts only for a point whose depth along the optical axis lies
 * between them (camera_connect), and its shadow ray stops at the near plane
 * (camera_visible), which is what the clipped primary rays of the path
 * tracer see; the environment is seen along a ray from the near plane to the
 * far one.
 *
 * Depths follow Mitsuba 3's meaning of max_depth, the path length in
 * segments: light vertex y_i connects to the camera when i + 1 <= max_depth
 * (max_depth < 0: unbounded; 0: a black image), and the path grows to
 * y_{i+1} only if y_{i+1} may still connect.  Russian roulette starts at
 * light vertex rr_depth with survival min(max(beta) / max(beta_1), 0.95): the
 * throughput relative to the emitted one, since beta itself carries the
 * scale of the emitter's power.
 *
 * Random numbers: light path i draws, in stream RNG_STREAM_LIGHT_TRACE,
 * LT_DIM_EMIT (emitter choice, position, direction, lens point of y_0's
 * connection), LT_DIM_BSDF(i) and LT_DIM_LENS(i) at light vertex i
 * (rng/streams.cl).  Light path i of a render is the same
 * whatever the launch.
 *
 * The splat film (mcocl/render/splat_film.py).  A block of the job is
 * spp_per_block * W * H light paths, split into `ntiles` contiguous groups of
 * paths (a job constant, independent of the device); work-item (block,
 * group) adds its splats into its own image of W * H * SPLAT_COLUMNS numbers
 * (no other work-item writes there, so no atomics and no lost updates), in
 * the order its paths produce them.  lt_fold_groups then sums a block's
 * group images in group order and turns the block into one *batch*: an
 * independent estimate of every pixel, from which mean and variance follow.
 * The image depends on the seed and the job's block size alone (not on the
 * launches, devices, chunking or resumes): bit-identical for a given LANES.
 */
#include "layouts.cl"
#include "samplers/sampler.cl"
#include "render/vec3.cl"
#include "render/lane_io.cl"
#include "render/camera.cl"
#include "render/bsdf.cl"
#include "render/prims.cl"
#include "render/lights.cl"
#include "render/lights_emit.cl"
#include "render/trace.cl"
#include "render/shading_normal.cl"
#include "render/texture.cl"

/* See integrator.cl: the random-number dimension of a vertex must fit 32 bits. */
#define DEPTH_GUARD 65536

#define STATS FILM_STATS
/* A group image's columns: the sums of R, G, B and the count of non-finite splats. */
#define SPLAT_COLUMNS 4

#ifdef FILM_DOUBLE
typedef double film_t;
#else
typedef float film_t;
#endif

MC_INLINE void splat_one(global film_t *img, uint pixel, float r, float g, float b) {
    global film_t *o = img + (size_t)pixel * SPLAT_COLUMNS;
    if ((r - r) == 0.0f && (g - g) == 0.0f && (b - b) == 0.0f) {
        o[0] += (film_t)r;
        o[1] += (film_t)g;
        o[2] += (film_t)b;
    } else {
        o[3] += 1;
    }
}

/* Add the contributions c of the lanes in `ok` to their pixels, in lane order. */
MC_INLINE void splat(global film_t *img, uintv pixel, vec3v c, intv ok) {
#if LANES == 1
    if (ok) splat_one(img, pixel, c.x, c.y, c.z);
#else
    float_lanes lx, ly, lz;
    uint_lanes px;
    int_lanes k_ok;
    lx.v = c.x; ly.v = c.y; lz.v = c.z;
    px.v = pixel;
    k_ok.v = ok;
    /* without a branch per lane (one the CPU mispredicts where few lanes splat): a lane out of
     * `ok` adds +0.0 to pixel 0, which changes no bit of its finite sums */
    for (int k = 0; k < LANES; ++k) {
        const bool on = k_ok.a[k] != 0;
        splat_one(img, on ? px.a[k] : 0u, on ? lx.a[k] : 0.0f, on ? ly.a[k] : 0.0f, on ? lz.a[k] : 0.0f);
    }
#endif
}

/* Add the contributions c of the lanes in `ok`, which landed at film point `film`, to the pixels
 * the reconstruction filter reaches, lane after lane (the box: splat to the pixel it landed in).
 * A filter weighs a contribution by its normalised value at each pixel centre, pbrt-v4's splat
 * (render/pixel_filter.cl); a non-finite contribution is counted once, in the nearest pixel. */
MC_INLINE void splat_filtered(global film_t *img, const pixel_filter *f, const camera_direction_v *film, vec3v c,
                              intv ok, uint width, uint height) {
#ifndef PIXEL_FILTER_SHAPED
    splat(img, film->pixel, c, ok);
#else
    if (f->kind == PIXEL_FILTER_BOX) {
        splat(img, film->pixel, c, ok);
        return;
    }
    float_lanes lx, ly, lz, fx, fy;
    uint_lanes px;
    int_lanes k_ok;
    lx.v = c.x; ly.v = c.y; lz.v = c.z;
    fx.v = film->raster_x; fy.v = film->raster_y;
    px.v = film->pixel;
    k_ok.v = ok;
    for (int k = 0; k < LANES; ++k) {
        if (!k_ok.a[k]) continue;
        const float r = lx.a[k], g = ly.a[k], b = lz.a[k];
        if (!((r - r) == 0.0f && (g - g) == 0.0f && (b - b) == 0.0f)) {
            splat_one(img, px.a[k], r, g, b);
            continue;
        }
        /* the film point in units where pixel i's centre is at i */
        const float x = fx.a[k] - 0.5f, y = fy.a[k] - 0.5f;
        const float rad = f->radius;
        const int x0 = max((int)ceil(x - rad), 0), x1 = min((int)floor(x + rad), (int)width - 1);
        const int y0 = max((int)ceil(y - rad), 0), y1 = min((int)floor(y + rad), (int)height - 1);
        for (int iy = y0; iy <= y1; ++iy) {
            const float wy = filter_weight(f, y - (float)iy);
            if (wy <= 0.0f) continue;
            for (int ix = x0; ix <= x1; ++ix) {
                const float w = wy * filter_weight(f, x - (float)ix);
                if (w > 0.0f) splat_one(img, (uint)iy * width + (uint)ix, r * w, g * w, b * w);
            }
        }
    }
#endif
}

/* The arguments of every splatting trace kernel (lt_trace, bdpt_trace), in the
 * order the host binds them (mcocl/render/job.py LT_BUFFERS, splat_film.py):
 * the launch's render_params, the scene's buffers, the bounding sphere light
 * paths from the environment start outside, and the group images. */
#define SPLAT_TRACE_PARAMS                                                                                  \
    const render_params params, global const float4 *camera, SCENE_GEOM_BUFFERS,                            \
    global const float4 *prim_rec, global const float4 *materials, global const float4 *emitter_radiance, \
    global const float4 *light_rec, global const float *light_cdf, global const float4 *vertex_normals,      \
    global const float4 *env_map, global const uint *env_cdf, global const float4 *textures,                \
    const float4 bsphere, global film_t *scratch

/* Textured area emitters shine with their texture (render/lights.cl). */
#ifdef TEXTURES
#define LT_BIND_TEXTURES light_tables_bind_textures(&lt, textures, &pt)
#else
#define LT_BIND_TEXTURES (void)textures
#endif

/* The start of every splatting trace kernel: the launch's settings, this
 * work-item's path group (or return), the geometry, primitive and light
 * tables.  Light paths start at emitters chosen by power: no light BVH is bound. */
#define SPLAT_TRACE_PRELUDE                                                                                 \
    const ulong seed = params.seed;                                                                         \
    const uint width = params.width, height = params.height, rr_depth = params.rr_depth;                    \
    const int max_depth = params.max_depth;                                                                 \
    const uint scene_ntris = params.ntris, scene_nspheres = params.nspheres;                                \
    path_group pg;                                                                                          \
    if (!path_group_at(&params, scratch, (uint)get_global_id(0), &pg)) return;                              \
    const uint npix = pg.npix;                                                                              \
    global film_t *img = pg.img;                                                                            \
    const ulong path0 = pg.path0, total = pg.total;                                                         \
    if (total == 0ul || max_depth == 0) return;                                                             \
    SCENE_GEOM_MAKE(geom);                                                                                  \
    const prim_tables pt = prim_tables_of(&params, scene_spheres, prim_rec);                                \
    light_tables lt = light_tables_of(&params, light_rec, light_cdf, emitter_radiance, 0, 0);              \
    light_tables_bind_envmap(&lt, &params, env_map, env_cdf);                                                \
    LT_BIND_TEXTURES

/* The light paths of one path group.  Work-item gid of a launch is group
 * gid % ntiles of block first_block + gid / ntiles; the block's paths are
 * split evenly over its groups, and each group splats into its own image of
 * scratch (cleared here), so no two work-items write the same memory.
 * Returns 0 for a work-item past the launch. */
typedef struct {
    ulong path0, total;  /* the group's first path index and its number of paths */
    uint npix;
    global film_t *img;  /* SPLAT_COLUMNS per pixel */
} path_group;

MC_INLINE int path_group_at(const render_params *p, global film_t *scratch, uint gid, path_group *g) {
    const uint groups = p->ntiles;
    if (gid >= p->nblocks * groups) return 0;
    const uint bi = gid / groups, group = gid - bi * groups;
    g->npix = p->width * p->height;
    g->img = scratch + ((size_t)bi * groups + group) * g->npix * SPLAT_COLUMNS;
    for (uint k = 0; k < g->npix * SPLAT_COLUMNS; ++k) g->img[k] = 0;
    const ulong spp0 = (p->first_block + bi) * (ulong)p->spp_per_block;
    const uint nspp = spp0 >= (ulong)p->spp_limit ? 0u : (uint)min((ulong)p->spp_per_block, (ulong)p->spp_limit - spp0);
    const ulong block_paths = (ulong)nspp * g->npix;
    g->path0 = spp0 * g->npix + block_paths * group / groups;  /* this group's first light path */
    g->total = block_paths * (group + 1u) / groups - block_paths * group / groups;
    return 1;
}

/* Give lanes that need work the next light paths of the work-item, in lane order. */
MC_INLINE intv assign_paths(intv need, ulong *next, ulong total, ulongv *j) {
#if LANES == 1
    if (need && *next < total) {
        *j = (*next)++;
        return 1;
    }
    return 0;
#else
    int_lanes nd, fr;
    ulong jj[LANES];
    MC_CAT(vstore, LANE_SUFFIX)(*j, 0, jj);
    nd.v = need;
    for (int k = 0; k < LANES; ++k) {
        fr.a[k] = 0;
        if (nd.a[k] && *next < total) {
            jj[k] = (*next)++;
            fr.a[k] = -1;
        }
    }
    *j = MC_CAT(vload, LANE_SUFFIX)(0, jj);
    return fr.v;
#endif
}

/* A shadow ray from p (normal n) to the connection's lens point: is it clear?  With a near
 * clip, only up to the near clip plane: the camera does not see what lies nearer, so it does
 * not block (render/camera.cl, camera_unclipped_length). */
MC_INLINE intv camera_visible(const scene_geom *geom, vec3v p, vec3v n, const camera_connection_v *k, intv active) {
    vec3v so = offset_origin(p, n, k->wo);
    floatv dist = camera_unclipped_length(k->settings, lane_sqrt(v3_len2(v3_sub(k->lens, so))), k->film.cos_theta);
    return active & !trace_any_v(geom, so, k->wo, dist * (1.0f - SHADOW_EPSILON), active);
}

#ifndef LT_NO_TRACE_KERNEL /* bdpt.cl takes the splat film's helpers and fold, not this kernel */
/* Light paths of blocks first_block .. first_block + nblocks - 1; params.ntiles
 * groups of paths per block, one work-item each; bsphere: centre and radius
 * of the scene's bounding sphere.  scratch: one group image per work-item. */
kernel void lt_trace(
    SPLAT_TRACE_PARAMS)
{
    SPLAT_TRACE_PRELUDE;
    const float pixels = (float)npix;
    const float lens_area = camera_lens_area(camera);
    const camera_settings cam_set = camera_settings_of(&params);
    const uint depth_limit = max_depth >= 0 ? min((uint)max_depth, (uint)DEPTH_GUARD) : (uint)DEPTH_GUARD;

    /* per-lane path state */
    intv alive = (intv)(0);
    ulongv j = (ulongv)(0ul);
    uintv depth = (uintv)(0u); /* index i of the light vertex the ray will hit */
    mc_sampler_t smp = sampler_start(seed, (ulongv)(0ul), RNG_STREAM_LIGHT_TRACE);
    vec3v o = v3s(0.0f), d = v3(0.0f, 0.0f, 1.0f), beta = v3s(0.0f);
    floatv beta_scale = (floatv)(1.0f); /* max(beta_1), the reference of Russian roulette */
    ulong next = 0ul;

    while (true) {
        /* ---- new light paths for idle lanes; y_0 connects to the camera at once ---- */
        intv need = !alive;
        while (next < total && lane_any(need)) {
            intv fresh = assign_paths(need, &next, total, &j);
            mc_sampler_t fs = sampler_start(seed, j + (ulongv)(path0), RNG_STREAM_LIGHT_TRACE);
            floatv ue[8];
            sampler_seek(&fs, (uintv)(LT_DIM_EMIT));
            sampler_next_nd(&fs, 8, ue);
            smp = sampler_select(smp, fs, fresh);
            emitter_ray_v er = sample_emitter_ray(&lt, bsphere, ue, fresh);
            intv area = er.valid & !er.env & !er.delta; /* no camera connection sees a delta light */
            if (lane_any(area)) {
                /* the light vertex itself: L_e(y_0 -> camera) cos_y W_e / (pdf_area pdf_camera) */
                camera_connection_v k = camera_connect(camera, cam_set, er.pos, ue[6], ue[7], width, height);
                floatv cos_y = v3_dot(er.n, k.wo);
                floatv w = pixels * cos_y * k.film.importance / (er.pdf_area * k.pdf_solid_angle);
                intv ok = area & k.valid & (cos_y > 0.0f);
                ok = camera_visible(&geom, er.pos, er.n, &k, ok);
                if (lane_any(ok))
                    splat_filtered(img, &cam_set.filter, &k.film, v3_scale(er.radiance, w), ok, width, height);
            }
            intv env = er.valid & er.env;
            if (lane_any(env)) {
                /* the environment seen directly: the camera looks along -d from a lens point
                 * uniform on the lens (density 1 / A_lens); d had density env_pmf pdf_solid_angle */
                vec3v look = v3_neg(er.d);
                vec3v xl = camera_lens_point(camera, ue[6], ue[7]);
                camera_direction_v c = camera_importance(camera, &cam_set, xl, look, width, height);
                floatv w = pixels * lens_area * c.importance * c.cos_theta / (lt.env_pmf * er.pdf_solid_angle);
                intv ok = env & c.valid;
                /* the primary ray along look: from the near clip plane to the far one (render/camera.cl) */
                ok = ok & !trace_any_v(&geom, camera_clip_origin(camera, cam_set, xl, look), look,
                                       camera_ray_extent(camera, cam_set, look), ok);
                if (lane_any(ok)) splat_filtered(img, &cam_set.filter, &c, v3_scale(er.radiance, w), ok, width, height);
            }
            /* beta_1 = L_e cos / (pdf_area pdf_solid_angle); the ray leaves y_0 */
            vec3v b1 = v3_scale(er.radiance, er.cos_theta / (er.pdf_area * er.pdf_solid_angle));
            intv go = er.valid & (v3_maxc(b1) > 0.0f) & (intv)(1u < depth_limit ? -1 : 0);
            beta = v3_select(beta, b1, fresh);
            beta_scale = lane_select(beta_scale, v3_maxc(b1), fresh);
            o = v3_select(o, v3_select(offset_origin(er.pos, er.n, er.d), er.pos, er.env), fresh);
            d = v3_select(d, er.d, fresh);
            depth = lane_select(depth, (uintv)(1u), fresh);
            alive = alive | go;
            need = !alive;
        }
        if (!lane_any(alive)) break;

        /* ---- intersect: light vertex y_depth ---- */
        hitv h = trace_closest_v(&geom, o, d, alive);
        intv hit = alive & h.hit;
        surface_v sf = surface_at(&pt, h.prim, h.t, o, d, hit);
        vec3v p = sf.p, n = sf.n;
        material_v m = material_load(materials, lane_select((uintv)(0u), sf.mat, hit));
#ifdef TEXTURES
        /* the material's textures at the hit's (u, v) (render/texture.cl) */
        material_texture_at_hit(&m, textures, &pt, h.prim, h.b1, h.b2, p, hit);
#endif
#ifdef SHADING_NORMALS
        /* the BSDF's frame; importance transport takes the adjoint factor (render/shading_normal.cl) */
        vec3v ns = shading_normal(vertex_normals, &pt, h.prim, h.b1, h.b2, n, hit);
        frame3v fr = frame_from_normal(ns);
#else
        frame3v fr = frame_from_normal(n);
#endif
        vec3v wi = frame_to_local(fr, v3_neg(d));

        /* ---- next-event estimation to the camera ---- */
        intv conn = hit & bsdf_is_smooth(&m);
        if (lane_any(conn)) {
            floatv ul[2];
            sampler_seek(&smp, LT_DIM_LENS(depth));
            sampler_next_2d(&smp, ul);
            camera_connection_v k = camera_connect(camera, cam_set, p, ul[0], ul[1], width, height);
            floatv bpdf;
            vec3v f = bsdf_eval_mode(&m, wi, frame_to_local(fr, k.wo), &bpdf, TRANSPORT_IMPORTANCE);
            vec3v c = v3_scale(v3_mul(beta, f), pixels * k.film.importance / k.pdf_solid_angle);
#ifdef SHADING_NORMALS
            c = v3_scale(c, shading_adjoint(n, ns, v3_neg(d), k.wo));
#endif
            intv ok = conn & k.valid & (v3_maxc(c) > 0.0f);
            ok = camera_visible(&geom, p, n, &k, ok);
            if (lane_any(ok)) splat_filtered(img, &cam_set.filter, &k.film, c, ok, width, height);
        }

        /* ---- the path grows while its next vertex may still connect ---- */
        intv cont = hit & (depth + 1u < (uintv)(depth_limit));
        intv next_alive = (intv)(0);
        if (lane_any(cont)) {
            floatv ub[4]; /* lobe, direction 2D, roulette */
            sampler_seek(&smp, LT_DIM_BSDF(depth));
            sampler_next_nd(&smp, 4, ub);
            bsdf_sample_v bs = bsdf_sample(&m, wi, ub[0], ub[1], ub[2], TRANSPORT_IMPORTANCE);
            vec3v wo = frame_to_world(fr, bs.wo);
#ifdef SHADING_NORMALS
            bs.weight = v3_scale(bs.weight, shading_adjoint(n, ns, v3_neg(d), wo));
#endif
            beta = v3_select(beta, v3_mul(beta, bs.weight), cont);
            o = v3_select(o, offset_origin(p, n, wo), cont);
            d = v3_select(d, wo, cont);
            depth = lane_select(depth, depth + 1u, cont);
            floatv rel = v3_maxc(beta) / beta_scale;
            floatv q = lane_min(rel, (floatv)(0.95f));
            intv rr = depth >= (uintv)(rr_depth);
            intv survive = ub[3] < q;
            beta = v3_select(beta, v3_scale(beta, 1.0f / q), cont & rr & survive);
            next_alive = cont & (!rr | survive) & (rel > 0.0f);
        }
        alive = next_alive;
    }
}

#endif

/* Per (block, pixel): the block's group images summed in group order, as
 * one batch of the film (film_t STATS, layouts.cl FilmStat): the batch mean
 * Y = (sum of splats) / (light paths of the block) in SUM, Y^2 in SUMSQ,
 * 1 in SAMPLES (0 for a block past spp_limit), the non-finite splats.
 * The launch's blocks go to out from block out_first on. */
kernel void lt_fold_groups(const render_params params, global const film_t *scratch, const uint out_first,
                           global film_t *out) {
    const uint npix = params.width * params.height, groups = params.ntiles;
    const uint gid = (uint)get_global_id(0);
    if (gid >= params.nblocks * npix) return;
    const uint bi = gid / npix, pixel = gid - bi * npix;
    const ulong spp0 = (params.first_block + bi) * (ulong)params.spp_per_block;
    const uint nspp = spp0 >= (ulong)params.spp_limit
                          ? 0u : (uint)min((ulong)params.spp_per_block, (ulong)params.spp_limit - spp0);
    film_t s[SPLAT_COLUMNS] = {0, 0, 0, 0};
    for (uint g = 0; g < groups; ++g) {
        global const film_t *src = scratch + (((size_t)bi * groups + g) * npix + pixel) * SPLAT_COLUMNS;
        for (int c = 0; c < SPLAT_COLUMNS; ++c) s[c] += src[c];
    }
    global film_t *o = out + (((size_t)out_first + bi) * npix + pixel) * STATS;
    const film_t inv = nspp > 0u ? (film_t)1 / ((film_t)nspp * (film_t)npix) : (film_t)0;
    for (int c = 0; c < 3; ++c) {
        film_t y = s[c] * inv;
        o[FILM_SUM_R + c] = y;
        o[FILM_SUMSQ_R + c] = y * y;
    }
    o[FILM_SAMPLES] = nspp > 0u ? 1 : 0;
    o[FILM_NONFINITE] = s[3];
}
