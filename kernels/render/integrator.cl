/* integrator.cl — the path-tracing megakernel: one work-item traces every
 * path of its pixel tile for one block of samples per pixel, LANES paths at
 * a time, and adds their radiance into per-pixel sums.
 *
 * The estimator is the random walk of the lecture ("Path Tracing – náhodná
 * procházka"): L = sum over vertices of the path throughput times the
 * emitted radiance, with the variants chosen at build time by -DINTEGRATOR:
 *   INTEGRATOR_PATH  BSDF sampling only; an emitter hit adds its radiance
 *                    (point, spot and directional lights, which no ray can
 *                    hit, are invisible to it: render/delta_lights.cl);
 *   INTEGRATOR_NEE   next-event estimation ("NEE pro Path Tracing"): a light
 *                    sample at every non-delta vertex, BSDF sampling only to
 *                    continue; an emitter hit counts only after a delta
 *                    vertex or the camera (no double counting);
 *   INTEGRATOR_MIS   both, weighted by the power heuristic, beta = 2 (Veach &
 *                    Guibas 1995; Veach's thesis eq. 9.13).
 * Depths follow Mitsuba 3's path integrator: the camera ray's hit has depth 0;
 * emission is collected at every hit, a vertex scatters (light sample and
 * BSDF sample) only while depth + 1 < max_depth (max_depth < 0: unbounded),
 * and Russian roulette (survival min(max(throughput) eta^2, 0.95)) starts once
 * depth >= rr_depth (lecture: "Ruská ruleta pro integrální rovnice").  The
 * depths are kernel arguments, so changing them does not rebuild the kernel.
 *
 * The area light of a light sample is chosen by -DLIGHT_SAMPLER
 * (render/lights.cl): from a table (power, uniform) or through the light BVH
 * from the vertex (render/light_bvh.cl).  The BVH's choice depends on the
 * vertex, so an emitter hit's MIS weight recomputes it from the previous
 * vertex's point and normal (prev_p, prev_n; the normal is kept only in
 * that build).
 *
 * Random numbers.  Sample (pixel, s) has the 64-bit index s * W * H + pixel
 * and draws, through the sampler (samplers/sampler.cl) in stream
 * RNG_STREAM_RENDER, dimensions 0-1 (the film point, drawn from the pixel
 * filter: render/pixel_filter.cl), 2-3 (the point on a
 * thin lens; render/camera.cl) and, at depth d,
 * RENDER_DIM_BSDF(d) = 4 + 8d .. 7 + 8d (lobe choice, direction 2D, roulette)
 * and RENDER_DIM_LIGHT(d) = 8 + 8d .. 11 + 8d (emitter choice: environment or
 * area, which area light, position 2D) (rng/streams.cl): the image depends on
 * the seed alone, not on how samples are split over launches, work-items or
 * lanes.  With -DRENDER_SOBOL (the Sobol' back end) sample s of batch b in
 * pixel p has instead the index ((b * W * H + p) << SOBOL_LOG2_POINTS) + s:
 * point s of the Owen scrambling (b, p), the same dimensions.
 *
 * Blocks and batches.  A block covers ntiles * tile_pixels consecutive pixels
 * (render_params; the whole film unless the host cuts it: mcocl/render/job.py).
 * With T = ceil(W * H / that) pixel ranges per film, block k is range t = k mod T
 * of batch b = k / T: the samples spp_per_block * b .. of the independent
 * sampler, or the scrambling b of the Sobol' one.  Only sobol cuts films (T > 1),
 * so a batch's points are the same whichever block renders them.
 *
 * Path regeneration.  In a lane build a lane whose path ends takes the next
 * sample of the work-item at once, so lanes stay busy whatever the path
 * lengths.  The order in which a work-item adds samples into a pixel's sums
 * depends on nothing but the work-item's own samples.
 *
 * Where the time goes (mis, LANES 16, perf samples of a -g build mapped to
 * these source lines, one PoCL thread; PoCL's work-group function, where
 * the samples fall, has no line table, so its instructions were matched to
 * those of the kernel's own copy in the same .so, which has one;
 * scenes/many_lights.json, where most paths escape after 1-2 bounces, and
 * scenes/veach_mis.json): shadow rays (trace_packet.cl, packet_any) 36-39
 * % and 13 %, closest hits 33-35 % and 21 %, the light sample 9 % (the
 * power CDF's search over 512 emitters 6 %, 3 % since light_find counts
 * its first halvings: render/lights.cl) and 22 % (the flat light tree over
 * its 5 lights 10 %, the light record's gather 5 %), surface records 3 and
 * 5 %, BSDF sampling 1 and 6.5 %, a fresh path's camera sample, ray and
 * sample assignment 4-5 and 8 %, the film adds 2 and 3 %.  The fresh
 * path's sample and pixel numbers (j / npix, px / width) were LANES scalar
 * divides each, 3.8 % and 6.3 % of the kernel; lane_div's multiply-high
 * (lane_ops.cl) leaves 0.6-0.8 %: 2 % more paths per CPU-second on
 * many_lights, 2.5-3.5 % on veach_mis (interleaved runs in one process,
 * +-5 % run to run; with light_find's change 5 % on many_lights).  Tried
 * and not kept: the eight box tests of a wide node first and then its
 * children hit in bit order (2-6 % slower), shadow rays traced lane by
 * lane through bvh.cl (as fast on many_lights, 34 % slower on veach_mis),
 * hardware gathers for gather_rec4 (3 % slower), no early exit per
 * primitive in packet_leaf_any (no change).
 *
 * Output: for every block of the launch and every pixel of its range (the
 * block's stride: min(ntiles * tile_pixels, W * H) pixels), STATS numbers (film_t)
 *   [0..2] sum of R, G, B   [3..5] sum of squares   [6] finite samples
 *   [7] non-finite samples (NaN/Inf in any channel: counted, kept out of the sums).
 */
#include "layouts.cl"
#include "samplers/sampler.cl"
#include "sampling/mis.cl"
#include "render/vec3.cl"
#include "render/lane_io.cl"
#include "render/camera.cl"
#include "render/pixel_filter.cl"
#include "render/bsdf.cl"
#include "render/prims.cl"
#include "render/lights.cl"
#include "render/trace.cl"
#include "render/shading_normal.cl"
#include "render/texture.cl"
#ifdef CASTER_GUIDING
#include "render/caster_guiding.cl"
#endif

/* INTEGRATOR_PATH, _NEE, _MIS: the Integrator codes of layouts.cl. */
#ifndef INTEGRATOR
#define INTEGRATOR INTEGRATOR_MIS
#endif
/* A guard against endless paths (max_depth -1 with roulette switched off in a
 * closed white scene): the random-number dimension of a vertex must fit 32 bits. */
#define DEPTH_GUARD 65536

#define STATS FILM_STATS /* the FilmStat columns of layouts.cl */

#if INTEGRATOR == INTEGRATOR_MIS && LIGHT_SAMPLER == LIGHT_SAMPLER_BVH
#define LIGHT_CHOICE_AT_VERTEX 1 /* the emitter hit's light pdf needs the previous vertex's point and normal */
#else
#define LIGHT_CHOICE_AT_VERTEX 0
#endif

/* Weight of radiance found by hitting an emitter (or escaping to the
 * environment) after a BSDF sample of pdf prev_pdf; light_pdf is the pdf with
 * which light sampling at the previous vertex would have chosen the same point. */
MC_INLINE floatv emission_weight(intv unsampled, floatv prev_pdf, floatv light_pdf) {
#if INTEGRATOR == INTEGRATOR_PATH
    return (floatv)(1.0f);
#elif INTEGRATOR == INTEGRATOR_NEE
    return lane_select((floatv)(0.0f), (floatv)(1.0f), unsampled);
#else
    return lane_select(power_heuristic(prev_pdf, light_pdf), (floatv)(1.0f), unsampled);
#endif
}

/* The film's number type: double where the device has it, so that the sum of
 * squares of a very bright (finite) sample cannot overflow; float otherwise. */
#ifdef FILM_DOUBLE
typedef double film_t;
#else
typedef float film_t;
#endif

/* Add finished paths into the pixel sums of this work-item's block. */
MC_INLINE void add_sample(global film_t *o, float r, float g, float b) {
    if ((r - r) == 0.0f && (g - g) == 0.0f && (b - b) == 0.0f) { /* all finite */
        film_t fr = r, fg = g, fb = b;
        o[FILM_SUM_R] += fr; o[FILM_SUM_G] += fg; o[FILM_SUM_B] += fb;
        o[FILM_SUMSQ_R] += fr * fr; o[FILM_SUMSQ_G] += fg * fg; o[FILM_SUMSQ_B] += fb * fb;
        o[FILM_SAMPLES] += 1;
    } else {
        o[FILM_NONFINITE] += 1;
    }
}

MC_INLINE void flush_samples(global film_t *out, uintv pixel, vec3v L, intv done) {
#if LANES == 1
    if (done) add_sample(out + (size_t)pixel * STATS, L.x, L.y, L.z);
#else
    float_lanes lx, ly, lz;
    uint_lanes px;
    lx.v = L.x; ly.v = L.y; lz.v = L.z;
    px.v = pixel;
    /* the done lanes in lane order (lowest bit first), as a loop over all lanes would add them:
     * no branch per lane for the CPU to mispredict */
    for (uint bits = lane_bits(done); bits != 0u; bits &= bits - 1u) {
        const uint k = 31u - clz(bits & (0u - bits));
        add_sample(out + (size_t)px.a[k] * STATS, lx.a[k], ly.a[k], lz.a[k]);
    }
#endif
}

/* Give lanes that need work the next samples of the work-item, in lane order: lane k gets
 * *next + (the needing lanes below k) while that is below total.  Vectorised as a prefix count
 * of the mask's bits (the loop over lanes it replaces spent ~7 % of the kernel mispredicting). */
MC_INLINE intv assign_samples(intv need, uint *next, uint total, uintv *j) {
#if LANES == 1
    if (need && *next < total) {
        *j = (*next)++;
        return 1;
    }
    return 0;
#else
    const uint bits = lane_bits(need);
    const uintv below = popcount((uintv)(bits) & (((uintv)(1u) << LANE_IOTA) - 1u));
    const uintv idx = (uintv)(*next) + below;
    const intv fresh = need & (idx < (uintv)(total));
    *j = lane_select(*j, idx, fresh);
    *next = min(*next + popcount(bits), total);
    return fresh;
#endif
}

/* The scalars come in one render_params (layouts.cl; host: mcocl/render/job.py),
 * the tables as buffers of the scene-to-device contract (mcocl/render/device_scene.py). */
kernel void render_blocks(
    const render_params params,
    global const float4 *camera,
    SCENE_GEOM_BUFFERS,
    global const float4 *prim_rec, global const float4 *materials, global const float4 *emitter_radiance,
    global const float4 *light_rec, global const float *light_cdf,
    global const float4 *light_bvh, global const uint *light_trail,
    global const float4 *vertex_normals,
    global const float4 *env_map, global const uint *env_cdf,
    global const float4 *textures,
    global film_t *out)
{
    const ulong first_block = params.first_block, seed = params.seed;
    const uint nblocks = params.nblocks, spp_per_block = params.spp_per_block, spp_limit = params.spp_limit;
    const uint width = params.width, height = params.height, tile_pixels = params.tile_pixels;
    const uint ntiles = params.ntiles, rr_depth = params.rr_depth;
    const int max_depth = params.max_depth;
    const uint scene_ntris = params.ntris, scene_nspheres = params.nspheres;
    const float env_pmf = params.env_pmf;
    const float4 env_radiance = params.env_radiance;
    const uint gid = (uint)get_global_id(0);
    if (gid >= nblocks * ntiles) return;
    const uint bi = gid / ntiles;
    const uint tile = gid - bi * ntiles;
    const ulong block = first_block + bi;
    const uint npix_total = width * height;
    /* the block's pixel range (see "Blocks and batches" above): range t of batch b */
    const uint span = ntiles * tile_pixels;
    const uint ranges = (npix_total + span - 1u) / span;
    const ulong batch = block / ranges;
    const uint first_pix = (uint)(block - batch * ranges) * span;
    const uint pix0 = first_pix + tile * tile_pixels;
    if (pix0 >= npix_total) return; /* past the film's end in its last range: the host reads nothing here */
    const uint npix = min(tile_pixels, npix_total - pix0);
    const ulong spp0 = batch * (ulong)spp_per_block;
    const uint nspp = spp0 >= (ulong)spp_limit ? 0u : (uint)min((ulong)spp_per_block, (ulong)spp_limit - spp0);
    const uint total = npix * nspp;
    /* the block's sums, pixel first_pix first; `pixel` below counts from first_pix */
    global film_t *acc = out + (size_t)bi * min(span, npix_total) * STATS;
    for (uint k = 0; k < npix * STATS; ++k) acc[(size_t)(pix0 - first_pix) * STATS + k] = 0;
    if (total == 0u) return;

    SCENE_GEOM_MAKE(geom);
    const prim_tables pt = prim_tables_of(&params, scene_spheres, prim_rec);
    light_tables lt = light_tables_of(&params, light_rec, light_cdf, emitter_radiance, light_bvh, light_trail);
#if LIGHT_CHOICE_AT_VERTEX
    /* the flat light tree's choice at a vertex's light sample, read back by the MIS weight of the emitter
     * its BSDF sample hits (render/light_bvh.cl, light_choice_memo) */
    light_choice_memo choice_memo;
    choice_memo.valid = 0;
    lt.memo = &choice_memo;
#endif
    light_tables_bind_envmap(&lt, &params, env_map, env_cdf);
#ifdef TEXTURES
    light_tables_bind_textures(&lt, textures, &pt);
#endif
    const bool has_env = env_radiance.x > 0.0f || env_radiance.y > 0.0f || env_radiance.z > 0.0f;
    const vec3v env_le = v3((floatv)(env_radiance.x), (floatv)(env_radiance.y), (floatv)(env_radiance.z));
    const float inv_w = 1.0f / (float)width, inv_h = 1.0f / (float)height;
    const bool thin_lens = camera_aperture(camera) > 0.0f;
    const camera_settings cam_set = camera_settings_of(&params);
    /* the sample and pixel of a fresh path by multiply-high, not by LANES scalar divides (lane_ops.cl) */
    const lane_divisor npix_div = lane_divisor_of(npix), width_div = lane_divisor_of(width);

    /* per-lane path state */
    intv alive = (intv)(0);
    uintv j = (uintv)(0u), pixel = (uintv)(0u);
    uintv depth = (uintv)(0u);
    mc_sampler_t smp = sampler_start(seed, (ulongv)(0ul), RNG_STREAM_RENDER);
    vec3v o = v3s(0.0f), d = v3(0.0f, 0.0f, 1.0f), prev_p = v3s(0.0f);
    vec3v thr = v3s(1.0f), L = v3s(0.0f);
    floatv eta = (floatv)(1.0f), prev_pdf = (floatv)(0.0f);
    intv unsampled = (intv)(0); /* the previous vertex was the camera or a delta lobe */
#ifdef CASTER_GUIDING
    intv all_delta = (intv)(0); /* every vertex before was the camera or a delta lobe: caster guiding applies */
#endif
#if LIGHT_CHOICE_AT_VERTEX
    vec3v prev_n = v3s(0.0f);
#endif
    uint next = 0u;

    while (true) {
        /* ---- regeneration: new camera paths for idle lanes ---- */
        intv need = !alive;
        if (next < total && lane_any(need)) {
            intv fresh = assign_samples(need, &next, total, &j);
            uintv s = lane_div(j, npix_div);
            uintv px = (uintv)(pix0) + (j - s * npix);
#ifdef RENDER_SOBOL
            /* Per pixel RQMC: the sample's number within the batch is the
             * Sobol' point, (batch, pixel) the scrambling, so every pixel of
             * every batch is an independent Owen scrambling with its own seed per
             * dimension (samplers/sobol_sampler.cl; host: mcocl/render/job.py). */
            ulongv index = ((ulongv)(batch * (ulong)npix_total) + to_ulongv(px)) << SOBOL_LOG2_POINTS | to_ulongv(s);
#else
            ulongv index = (to_ulongv(s) + (ulongv)(spp0)) * (ulong)npix_total + to_ulongv(px);
#endif
            mc_sampler_t fs = sampler_start(seed, index, RNG_STREAM_RENDER);
            floatv uc[2];
            sampler_seek(&fs, (uintv)(RENDER_DIM_CAMERA));
            sampler_next_2d(&fs, uc);
            smp = sampler_select(smp, fs, fresh);
            uintv py = lane_div(px, width_div);
            /* the film point: the pixel filter's sample (render/pixel_filter.cl) */
            floatv sx = film_coordinate(&cam_set.filter, to_floatv(px - py * width), uc[0]);
            floatv sy = film_coordinate(&cam_set.filter, to_floatv(py), uc[1]);
            vec3v co, cd;
            if (thin_lens) {
                floatv ul[2]; /* the lens point: dimensions 2-3 of the camera's block */
                sampler_next_2d(&fs, ul);
                cd = camera_ray_lens(camera, sx, sy, inv_w, inv_h, ul[0], ul[1], &co);
            } else {
                cd = camera_ray(camera, sx, sy, inv_w, inv_h, &co);
            }
            co = camera_clip_origin(camera, cam_set, co, cd);
            pixel = lane_select(pixel, px - (uintv)(first_pix), fresh);
            o = v3_select(o, co, fresh);
            d = v3_select(d, cd, fresh);
            thr = v3_select(thr, v3s(1.0f), fresh);
            L = v3_select(L, v3s(0.0f), fresh);
            eta = lane_select(eta, (floatv)(1.0f), fresh);
            prev_pdf = lane_select(prev_pdf, (floatv)(0.0f), fresh);
            depth = lane_select(depth, (uintv)(0u), fresh);
            unsampled = unsampled | fresh;
#ifdef CASTER_GUIDING
            all_delta = all_delta | fresh;
#endif
            alive = alive | fresh;
        }
        if (!lane_any(alive)) break;

        /* ---- intersect ---- */
        hitv h = trace_closest_v(&geom, o, d, alive);
        /* a primary ray ends at the far clip plane (render/camera.cl): what lies beyond is a miss */
        if (camera_has_far_clip(cam_set))
            h.hit = h.hit & !(camera_beyond_far_clip(camera, cam_set, d, h.t) & (depth == (uintv)(0u)));
        intv hit = alive & h.hit;
        intv miss = alive & !h.hit;

        /* ---- the environment, seen by a ray that escaped ---- */
        if (has_env && max_depth != 0 && lane_any(miss)) {
            if (lt.has_env_map) {
                /* an environment map (render/envmap.cl): its radiance and light-sampling density along d */
                floatv lp = env_pmf * envmap_pdf(&lt.env_map, d, miss);
                floatv w = emission_weight(unsampled, prev_pdf, lp);
                vec3v le = envmap_radiance(&lt.env_map, d, miss);
                L = v3_select(L, v3_add(L, v3_scale(v3_mul(thr, le), w)), miss);
            } else {
                floatv w = emission_weight(unsampled, prev_pdf, (floatv)(env_pmf * RT_INV_4PI));
                L = v3_select(L, v3_add(L, v3_scale(v3_mul(thr, env_le), w)), miss);
            }
        }

        surface_v sf = surface_at(&pt, h.prim, h.t, o, d, hit);
        vec3v p = sf.p, n = sf.n;
#ifdef SHADING_NORMALS
        /* the BSDF's frame (render/shading_normal.cl); n stays the geometric normal */
        vec3v ns = shading_normal(vertex_normals, &pt, h.prim, h.b1, h.b2, n, hit);
#else
        vec3v ns = n;
#endif

        /* ---- emission of the surface hit (one-sided: front = normal) ---- */
        /* (max_depth 0 renders black, as in Mitsuba 3) */
        intv emitting = hit & (sf.emitter >= 0) & (v3_dot(n, d) < 0.0f) & (intv)(max_depth != 0 ? -1 : 0);
        if (lane_any(emitting)) {
            vec3v le = emitter_radiance_at(&lt, sf.emitter, h.prim, h.b1, h.b2, p, emitter_radiance_of(&lt, sf.emitter),
                                           emitting);
#if INTEGRATOR == INTEGRATOR_MIS
#if LIGHT_CHOICE_AT_VERTEX
            floatv lp = light_pdf_hit_at(&lt, &pt, prev_p, prev_p, prev_n, d, h.prim, &sf, emitting & !unsampled);
#else
            floatv lp = light_pdf_hit(&lt, &pt, prev_p, d, h.prim, &sf, emitting & !unsampled);
#endif
#else
            floatv lp = (floatv)(0.0f);
#endif
            floatv w = emission_weight(unsampled, prev_pdf, lp);
            L = v3_select(L, v3_add(L, v3_scale(v3_mul(thr, le), w)), emitting);
        }

        /* ---- scatter, while the path may grow ---- */
        const uint depth_limit = max_depth >= 0 ? min((uint)max_depth, (uint)DEPTH_GUARD) : (uint)DEPTH_GUARD;
        intv cont = hit & (depth + 1u < (uintv)(depth_limit));
        intv next_alive = (intv)(0);
#if LIGHT_CHOICE_AT_VERTEX
        choice_memo.valid = 0; /* read above for the vertex before; this vertex's light sample refills it */
#endif
        if (lane_any(cont)) {
            material_v m = material_load(materials, lane_select((uintv)(0u), sf.mat, cont));
#ifdef TEXTURES
            /* the material's textures at the hit's (u, v) (render/texture.cl) */
            material_texture_at_hit(&m, textures, &pt, h.prim, h.b1, h.b2, p, cont);
#endif
            frame3v fr = frame_from_normal(ns);
            vec3v wi = frame_to_local(fr, v3_neg(d));
#if defined(RENDER_SOBOL) && INTEGRATOR != INTEGRATOR_PATH
#if RENDER_DIM_LIGHT(0) != RENDER_DIM_BSDF(0) + 4
#error "the light sample's dimensions must follow the BSDF's"
#endif
            /* the BSDF's dimensions and the light sample's after them in one draw, the same
             * numbers as two: the Sobol' back end then groups the lanes by dimension once for
             * both (samplers/sobol_sampler.cl, sobol_reversed_rows_lanes) */
            floatv uv[8];
            sampler_seek(&smp, RENDER_DIM_BSDF(depth));
            sampler_next_nd(&smp, 8, uv);
            const floatv *ub = uv; /* lobe, direction 2D, roulette */
#else
            floatv ub[4]; /* lobe, direction 2D, roulette */
            sampler_seek(&smp, RENDER_DIM_BSDF(depth));
            sampler_next_nd(&smp, 4, ub);
#endif
#ifdef CASTER_GUIDING
            /* The probability that this vertex aims its continuation at a caustic caster
             * (render/caster_guiding.cl; the estimator: mcocl/render/caster_guiding.py):
             * params.caster_share at the path's first non-delta vertex (the surface whose
             * caustic the camera sees, directly or through mirrors and glass) where its BSDF
             * does not refract and the point lies outside some caster's bounding sphere, on the
             * side its caustic falls on and within its reach, else 0.  One vertex per path: the
             * mixture may raise a vertex's weight by up to 1 / (1 - share), and at every vertex
             * of a closed scene those factors compound (share 0.75 at every vertex: a Cornell
             * box with a glass ball 100x noisier). */
            caster_view casters;
            casters.n = (uintv)(0u);
            if (lane_any(cont & all_delta)) /* deeper vertices never aim: no cones to compute */
                casters = caster_view_at(&params, p);
            const floatv aim_share = lane_select((floatv)(0.0f), (floatv)(params.caster_share),
                                                 cont & all_delta & bsdf_is_smooth(&m)
                                                 & (m.kind != MAT_ROUGHDIELECTRIC) & (casters.n > (uintv)(0u)));
            const intv guided = aim_share > 0.0f;
#endif

#if INTEGRATOR != INTEGRATOR_PATH
            /* The point lifted off the surface on its front side (the back side where a
             * twosided material is seen from behind), where shadow rays start.  Light
             * samples are measured at p itself, as are the light pdfs of a reflected
             * ray's emitter hit (light_pdf_hit_at, along the ray's direction from p), so
             * both MIS weights of a path are one function of the direction at p and sum
             * to one.  Measured at the lifted point, next-event estimation estimated the
             * irradiance eps above the surface, a bias of order eps / distance that grows
             * with the scene's coordinates as offset_origin's eps does: 0.28 % at 50
             * units, 1e-4 in the Cornell box, where it made mis brighter than bdpt's
             * connections, which start at p (tests/test_render_direct_lambert.py, against
             * Lambert's polygon formula).  Reflected rays still leave the lifted point,
             * as Mitsuba 3's do: the BSDF strategy's share keeps that bias. */
            vec3v p_up = offset_origin(p, n, v3_select(n, v3_neg(n), bsdf_mirrored(&m, wi)));

            /* -- next-event estimation -- */
            intv nee = cont & bsdf_is_smooth(&m);
            if (lane_any(nee)) {
#if defined(RENDER_SOBOL)
                const floatv *ul = uv + 4; /* drawn with the BSDF's */
#else
                floatv ul[4];
                sampler_seek(&smp, RENDER_DIM_LIGHT(depth));
                sampler_next_nd(&smp, 4, ul);
#endif
                light_sample_v ls = sample_light_at(&lt, &pt, p, n, ul[0], ul[1], ul[2], ul[3], nee);
                floatv bpdf;
                vec3v f = bsdf_eval(&m, wi, frame_to_local(fr, ls.wo), &bpdf);
#ifdef CASTER_GUIDING
                /* the continuation's strategy is the mixture: its density is the BSDF strategy's pdf */
                if (lane_any(guided))
                    bpdf = aim_share * caster_pdf(&casters, ls.wo) + (1.0f - aim_share) * bpdf;
#endif
#if INTEGRATOR == INTEGRATOR_MIS
                /* a delta light (render/delta_lights.cl) has no BSDF-sampling strategy: weight 1 */
                floatv w = lane_select(power_heuristic(ls.pdf, bpdf), (floatv)(1.0f), ls.delta);
#else
                floatv w = (floatv)(1.0f);
#endif
                vec3v c = v3_scale(v3_mul(v3_mul(thr, f), ls.radiance), w / ls.pdf);
                intv ok = nee & ls.valid & (v3_maxc(c) > 0.0f);
#ifdef SHADING_NORMALS
                ok = ok & shading_side_agrees(n, ns, v3_neg(d)) & shading_side_agrees(n, ns, ls.wo);
#endif
                if (lane_any(ok)) {
                    vec3v so = p_up;
#ifdef SMOOTH_TRANSMISSION
                    /* a light behind the surface, reached through a rough refraction
                     * (roughdielectric): the shadow ray leaves from that side.  Built only
                     * for scenes with such a material (mcocl/render/job.py): it costs the
                     * others ~4 % even where no lane takes it. */
                    intv across = ok & (v3_dot(ls.wo, v3_sub(p_up, p)) < 0.0f);
                    if (lane_any(across)) so = v3_select(so, offset_origin(p, n, ls.wo), across);
#endif
                    /* the shadow ray aims from its origin at the light point itself: a ray parallel
                     * to ls.wo (measured from p) would pass eps beside it */
                    vec3v sd = v3_sub(ls.pos, so);
                    floatv sl = lane_sqrt(v3_len2(sd));
                    vec3v sdir = v3_select(v3_scale(sd, 1.0f / lane_select((floatv)(1.0f), sl, sl > 0.0f)), ls.wo, ls.env);
                    floatv tmax = lane_select(sl * (1.0f - SHADOW_EPSILON), (floatv)(INFINITY), ls.env);
                    intv occluded = trace_any_v(&geom, so, sdir, tmax, ok);
                    L = v3_select(L, v3_add(L, c), ok & !occluded);
                }
            }
#endif
            /* -- BSDF sampling continues the path -- */
#ifdef CASTER_GUIDING
            /* ub[0] below aim_share aims at a caster; above it, rescaled to [0, 1), it picks the BSDF's lobe */
            floatv u_lobe = lane_min(lane_max((ub[0] - aim_share) / (1.0f - aim_share), (floatv)(0.0f)),
                                     (floatv)(0x1.fffffep-1f));
#else
            floatv u_lobe = ub[0];
#endif
            bsdf_sample_v bs = bsdf_sample(&m, wi, u_lobe, ub[1], ub[2], TRANSPORT_RADIANCE);
            vec3v wo = frame_to_world(fr, bs.wo);
#ifdef CASTER_GUIDING
            /* One-sample MIS of the two techniques, balance heuristic (Veach's thesis §9.2.4): a
             * direction of either is weighted by f cos over the mixture's density, share * p_cone +
             * (1 - share) * p_bsdf, which is also the pdf the MIS weight of an emitter the path hits
             * next sees (prev_pdf).  A delta lobe has no density: the BSDF drew it with probability
             * (1 - share) times its own, so its weight is divided by (1 - share). */
            if (lane_any(guided)) {
                const intv aim = guided & (ub[0] < aim_share);
                vec3v fcos = v3_scale(bs.weight, bs.pdf); /* f cos of the BSDF's own sample */
                floatv bsdf_pdf = bs.pdf;
                if (lane_any(aim)) {
                    const floatv share = lane_select((floatv)(1.0f), aim_share, aim);
                    const uintv pick = lane_min_u(to_uintv(ub[0] / share * to_floatv(casters.n)),
                                                  max(casters.n, (uintv)(1u)) - (uintv)(1u));
                    const vec3v wa = caster_sample(&casters, pick, ub[1], ub[2]);
                    floatv pa;
                    const vec3v fa = bsdf_eval(&m, wi, frame_to_local(fr, wa), &pa);
                    wo = v3_select(wo, wa, aim);
                    fcos = v3_select(fcos, fa, aim);
                    bsdf_pdf = lane_select(bsdf_pdf, pa, aim);
                    bs.delta = bs.delta & !aim;
                    bs.eta = lane_select(bs.eta, (floatv)(1.0f), aim); /* a reflection: no refracting BSDF is guided */
                }
                const floatv mix = aim_share * caster_pdf(&casters, wo) + (1.0f - aim_share) * bsdf_pdf;
                const intv spread = guided & !bs.delta;
                const vec3v w_mix = v3_scale(fcos, lane_select((floatv)(0.0f), 1.0f / mix, mix > 0.0f));
                bs.weight = v3_select(v3_scale(bs.weight, 1.0f / (1.0f - aim_share)), w_mix, spread);
                bs.pdf = lane_select(bs.pdf, mix, spread);
            }
#endif
#ifdef SHADING_NORMALS
            /* a direction the two normals disagree on carries nothing (no light leaks) */
            intv leak = !(shading_side_agrees(n, ns, v3_neg(d)) & shading_side_agrees(n, ns, wo));
            bs.weight = v3_select(bs.weight, v3s(0.0f), leak);
#endif
            thr = v3_select(thr, v3_mul(thr, bs.weight), cont);
            eta = lane_select(eta, eta * bs.eta, cont);
            vec3v o_next = offset_origin(p, n, wo);
            prev_p = v3_select(prev_p, p, cont);
            prev_pdf = lane_select(prev_pdf, bs.pdf, cont);
#if LIGHT_CHOICE_AT_VERTEX
            prev_n = v3_select(prev_n, n, cont);
#endif
            unsampled = lane_select(unsampled, bs.delta, cont);
#ifdef CASTER_GUIDING
            all_delta = all_delta & (!cont | bs.delta);
#endif
            o = v3_select(o, o_next, cont);
            d = v3_select(d, wo, cont);
            depth = lane_select(depth, depth + 1u, cont);

            /* -- Russian roulette (Mitsuba 3's rule) -- */
            floatv tmax_ = v3_maxc(thr);
            floatv q = lane_min(tmax_ * eta * eta, (floatv)(0.95f));
            intv rr = depth >= (uintv)(rr_depth);
            intv survive = ub[3] < q;
            thr = v3_select(thr, v3_scale(thr, 1.0f / q), cont & rr & survive);
            next_alive = cont & (!rr | survive) & (tmax_ > 0.0f);
        }

        /* ---- paths that ended: into the pixel sums ---- */
        intv done = alive & !next_alive;
        if (lane_any(done)) flush_samples(acc, pixel, L, done);
        alive = next_alive;
    }
}
