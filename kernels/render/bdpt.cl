/* bdpt.cl — bidirectional path tracing (the lecture's "Obousměrný Path
 * Tracing"; Veach's thesis §10.2 and §10.3, Veach & Guibas 1995).
 *
 * Per sample: a camera subpath z_0 .. z_{nc-1} (z_0 the lens point) and a
 * light subpath y_0 .. y_{nl-1} (y_0 on an area emitter), kept in private
 * arrays of at most BDPT_MAX_VERTICES vertices each; every strategy (s, t)
 * (s light vertices, t >= 1 camera vertices, path length s + t - 1 segments)
 * is evaluated:
 *   s = 0       the camera subpath hits an emitter at z_{t-1} ((0, 3) behind a
 *               pinhole's glass z_1: both of its branches, see "Splitting" below);
 *   t = 1       light vertex y_{s-1} connects to the camera (a lens point
 *               uniform on the aperture, as lt.cl): the contribution is splatted
 *               to the pixel it lands in;
 *   s = 1       next-event estimation from z_{t-1}: a fresh point on an emitter,
 *               sampled by the same density as y_0 (lights_emit.cl), so that the
 *               MIS weights see one density for the first light vertex;
 *   otherwise   y_{s-1} and z_{t-1} are joined by a shadow ray.
 * Connections need non-delta endpoints (bsdf_is_smooth): a mirror, glass or a
 * delta-sampled plastic coat is only passed through by sampling.
 *
 * Splitting at the first camera vertex (split_first_vertex; Arvo & Kirk 1990,
 * "Particle transport and image synthesis", splitting; Whitted's tracing of
 * both branches of glass).  Why: on scenes/caustic.json (128 px) 99 % of the
 * per-pixel variance sat in the 20 pixels where the camera sees the small
 * lamp reflected in the glass ball, and 93 % of the image's variance came
 * from paths of at most 2 segments: camera, glass (reflection), lamp.  Only
 * (0, 3) samples them, and the glass reflects with probability F (a few %),
 * so a sample was Bernoulli(F c) times a huge L_e (c: the glint's pixel
 * coverage), variance ~ L_e^2 F c.  With a pinhole camera and z_1 on a
 * delta BSDF of two branches (two_branch_delta: `dielectric`,
 * `thindielectric`; not a mirror's single branch, not plastic's coat), the
 * MIS weight of (0, 3) for z_0 z_1 z_2 is exactly 1: (1, 2) would connect at
 * the delta z_1 and (2, 1) would connect the delta z_1 to the camera
 * (bdpt_mis_weight leaves both out), and a pinhole is no target of light
 * paths (no t = 0).  So the emission right after z_1 is estimated by the sum
 * over both branches b, beta_1 W_b Le_b (W_b: the branch's BSDF weight, what
 * the throughput is multiplied by when b is drawn with probability P_b is
 * W_b / P_b; the refraction's 1/eta^2 included): (0, 3) counts the branch
 * the walk drew as cam[2].beta P_b Le_b, and one closest-hit ray along the
 * other branch (no random numbers) adds beta_1 W_o Le_o to the sample's own
 * pixel, emission_seen evaluating both ends as (0, t) does.  Variance ~
 * L_e^2 F^2 c (1 - c): about 1/F lower.  Longer paths through z_1 still
 * follow the walk's one branch, unchanged.  The camera walk's roulette at
 * z_1 (rr_depth <= 1) applies to the drawn branch's term only, which it
 * divides by the survival probability as every throughput: its expectation
 * stays beta_1 W_b Le_b and the other branch's term is exact, so the split
 * stays unbiased (tests/test_render_bdpt_split.py, rr_depth 1).  Skipped
 * for a thin lens, for max_depth < 2 and for single strategies other than
 * (0, 3).  Measured (bench/bdpt_efficiency.py, 128 px, budget 6 s, 2 runs;
 * shared machine): caustic bdpt / mis efficiency 7.9 before, 12.2 after
 * (from the renders' own variances 3.8 before, 14.3 after: bdpt's own
 * variance efficiency x 3.1); on the Cornell box with a mirror and a glass
 * sphere its own-variance ratio stays 1.05-1.06 (that variance is the
 * mirror's reflection of the light, one branch, and longer paths), paths per
 * CPU-second unchanged within noise (-1.4 % over 3 interleaved renders).
 * Images with no two-branch delta surface seen from a pinhole are
 * bit-identical.
 *
 * Point and spot lights (render/delta_lights.cl): y_0 is the light's
 * position, with pdf_fwd its choice probability (the same for the s = 1
 * point); no camera subpath can hit it and no camera connection can see it,
 * so (0, t) and (1, 1) are no strategies for such a path (pbrt-v3's
 * IsDeltaLight in MISWeight).
 *
 * Lights at infinity (the environment, constant or a map, and directional
 * lights; pbrt-v3's infinite-light vertices): y_0 is a direction, with
 * pdf_fwd its solid-angle density as light sampling draws it (env_pmf times
 * the map's density; a directional light's choice probability), and y_1 gets
 * the area density cos / (pi R^2) of the disk the light ray starts on
 * (lights_emit.cl).  A camera subpath that escapes ends in such a vertex
 * (pdf_fwd: the BSDF's solid-angle density), where (0, t) adds the
 * environment's radiance; its reverse densities are env_pmf times the
 * environment's density and cos / (pi R^2) at the vertex before.  A light at
 * infinity is not connected to the camera as y_0, so (1, 1) is no strategy
 * there (lt.cl's direct view of the environment is left to (0, 2)).
 *
 * MIS weights (Veach's thesis eq. 10.9 with the ratios of §10.2.1; the
 * pdf ratio walk of pbrt-v3's MISWeight): every vertex stores pdf_fwd, the
 * area density with which its own subpath generated it, and pdf_rev, the area
 * density with which the other direction would.  For a strategy (s, t) the
 * four vertices next to the connection get their reverse densities from the
 * connection itself, and the weight is
 *     w_{s,t} = 1 / (1 + sum_{i} r_i^beta),   r_i = prod pdf_rev / pdf_fwd
 * over the strategies (s', t') of the same path that the caps allow
 * (s' <= light vertices, t' >= 1, t' <= camera vertices); a vertex sampled
 * through a delta lobe gets pdf_fwd = pdf_rev = 0 (counted as 1 in the
 * ratios) and the strategies that would connect at it or next to it are left
 * out of the sum.  beta (render_params.bdpt_power_mis): 1 the balance heuristic, 2 the power
 * heuristic.  The camera's lens is not a target of light paths (t = 0 is
 * not a strategy), as in lt.cl.
 *
 * The camera's clip planes (render_params near_clip, far_clip; render/camera.cl): the
 * camera ray leaves from the near clip plane (z_0 stays the lens point) and a
 * hit beyond the far one is a miss, as the megakernel's primary rays; a
 * (s, 1) connection counts only for a point between the planes, its shadow
 * ray stopping at the near one (lt.cl, camera_visible).  The clip removes a
 * path (one whose z_1 lies outside the planes) from every strategy alike and
 * changes no density, so the weights of a path that remains still sum to 1.
 *
 * Specular chains (specular_vertex, density_toward).  Along a chain of
 * specular vertices c_1 .. c_k (mirror, glass: no connection ends there)
 * between non-specular a and b, only the strategies that sample the whole
 * chain from one side remain, and the ratio of their densities is
 *   p_a(a -> chain -> b) / p_b(b -> chain -> a)
 *     = (p_sa(a) G_g / cos_a) / (p_sa(b) G_g / cos_b)
 * (p_sa the solid-angle densities leaving a and b, G_g the chain's
 * generalized geometry term, the same both ways: etendue is conserved
 * through mirrors and, both ends in one medium, through refractions; the
 * Fresnel choices are the same both ways too), so G_g cancels.
 * Converting to area at c_1 (cos_c1 / |a c_1|^2) and at c_k as the other
 * vertices do left a spurious factor (cos_c1 |b c_k|^2) / (cos_ck |a c_1|^2)
 * in the weights: on the Cornell box with a glass sphere the caustic under
 * the ball (camera, floor, glass, glass, light), which light tracing (4, 1)
 * samples far better, gave (4, 1) 2.5 % of its mean and (0, 5) the rest, and
 * those pixels held 45 % of bdpt's variance (as much variance per sample as
 * mis there, at 3.5x the cost).  So a specular vertex's densities from a
 * non-specular neighbour are the projected solid-angle density p_sa / |cos|
 * at the neighbour (density_toward), its densities from specular neighbours
 * stay zero (counted as 1), and the ratios across the chain are the exact
 * ratio above.  "Specular" is a property of the vertex (a material without a
 * smooth lobe, not an emitter, not at infinity), not of the lobe a walk drew,
 * so every strategy of a path computes the same numbers and the weights
 * still sum to 1 (tests/test_bdpt_weights.py recomputes them from the
 * vertices by the same rule).  Chains next to a light at infinity or a point
 * or spot light keep the area densities (any consistent choice is unbiased).
 * Measured (128 px, 256 spp, sobol, the box with two spheres; the renders'
 * own variances): the summed pixel variance 1.36 -> 0.85, the caustic's 0.61
 * -> 0.16, variance x CPU-time 1.78x lower; bench/bdpt_efficiency.py
 * (128 px, budget 6 s, reference 120 s, 2 runs) bdpt / mis 1.77 and 1.54 in
 * two runs on that box (own variances 1.71, 1.48; 1.08-1.22 before), 0.53 on the plain box (images
 * unchanged), 13.1 on scenes/caustic.json (own variances 24.9, 14.3-15.4
 * before).  Images without specular surfaces are bit-identical.  What is
 * left on the box with two spheres (its error, own variance x CPU time):
 * 67 % in the 7.5 % of pixels that see the balls, camera-only paths (the
 * light in the mirror, the room and its caustics through the glass), where
 * bdpt is mis at 3.4x the cost per sample; only a lower cost per sample
 * (fuller packets) or more camera subpaths per light subpath would help there.
 *
 * Russian roulette is a multiplicative survival weight on the subpath
 * throughput (1 / q on survival); the pdfs of the MIS weights leave it out:
 * any weights that sum to 1 over the strategies of a path keep every
 * strategy's sum unbiased (Veach's thesis §9.2).
 *
 * Depths (Mitsuba 3's max_depth: path length in segments).  A strategy (s, t)
 * counts when s + t - 1 <= max_depth; the camera subpath holds at most
 * max_depth + 1 vertices, the light subpath max_depth, both capped at
 * BDPT_MAX_VERTICES (max_depth < 0: the caps only; paths longer than
 * 2 BDPT_MAX_VERTICES - 1 segments are dropped, a bias of order rho^(2 cap)).
 *
 * Random numbers.  Sample (pixel, s) has the index s W H + pixel, as in
 * integrator.cl; its camera subpath draws in RNG_STREAM_RENDER (RENDER_DIM_CAMERA
 * + 2 for a thin lens's point, RENDER_DIM_BSDF(k - 1) at z_k, RENDER_DIM_LIGHT(k - 1)
 * for the s = 1 light point at z_k), its light subpath in RNG_STREAM_LIGHT_TRACE
 * with the same index (LT_DIM_EMIT, LT_DIM_BSDF(i) and LT_DIM_LENS(i) at y_i, as
 * lt.cl).  The film point (RENDER_DIM_CAMERA's two dimensions) comes instead from
 * a stratified set, next paragraph.  That is the independent sampler (the Philox
 * back end); the sobol sampler draws every one of these dimensions as a
 * quasi-Monte Carlo point of the sample's pixel and batch ("Quasi-Monte Carlo" below).
 *
 * Film positions.  Sample s = s_b + b spp_per_block of a pixel p is sample s_b
 * of the pixel in batch (block) b, and its film uniforms are point s_b of an
 * Owen-scrambled (0, 2)-sequence (Sobol' dimensions 0 and 1; Owen 1995,
 * nested scrambling by hashing as the sobol back end: samplers/owen_scramble.cl)
 * whose scrambling (b W H + p) is seeded from Philox in RNG_STREAM_BDPT_FILM
 * (bdpt_film_uniforms).  So a pixel's film points in a batch are stratified
 * (any 2^m of them a (0, m, 2)-net, any prefix close to one: a block cut
 * short by spp_limit stays stratified), every batch and pixel has its own
 * independent scrambling (the batches stay independent, so the variance
 * layer stays honest: mcocl/render/splat_film.py), and every other dimension
 * is drawn as before.  Why: on the Cornell box with a mirror and a glass
 * sphere a third of bdpt's variance sat in the 10 pixels where the mirror
 * ball reflects the ceiling light, the coverage noise of a bright region
 * smaller than a pixel, which only the camera subpath samples ((0, 3): no
 * connection ends at the mirror) and which bdpt sampled as mis does at
 * about 3.7 x mis's cost per sample.  The batch must hold several samples
 * per pixel for it to matter: the host gives bdpt batches of up to 16 spp
 * while a work-item's share of a block stays within BDPT_GROUP_PATHS camera
 * samples, which bounds a block's time (splat_film.py, splat_spp_per_block).
 * Measured (128 px, 256 spp, that box): the summed pixel variance per
 * sample 24 % lower with batches of 16 spp, 27 % with 64, than with
 * independent positions (batches of 1); at 512 px 4 % lower with 16 than
 * with 4; more in the README's bdpt section.  The pixel and batch of a sample
 * come from its index (two divisions per packet lane, no measurable time).
 * The thin lens's point stays independent.  (This paragraph is the
 * independent sampler's; the sobol sampler's film points are its own.)
 *
 * Quasi-Monte Carlo (the sobol sampler: -DSAMPLER_BACKEND=SAMPLER_BACKEND_SOBOL,
 * mcocl/render/splat_film.py, bdpt_sobol_defines).  Sample s = s_b + b
 * spp_per_block of pixel p (s_b its number in batch b) draws every dimension
 * of both subpaths as a coordinate of an Owen-scrambled Sobol' point (the back
 * end samplers/sobol_sampler.cl: Owen 1995, "Randomly permuted (t,m,s)-nets
 * and (t,s)-sequences", nested scrambling, hashed as Burley 2020, "Practical
 * Hash-based Owen Scrambling", JCGT 9(4)):
 *   camera subpath  point s_b of scrambling b W H + p (sampler index
 *                   ((b W H + p) << SOBOL_LOG2_POINTS) + s_b, as RENDER_SOBOL
 *                   in render/integrator.cl): the pixel's samples in a batch
 *                   are one net: film point, lens point, each camera vertex's
 *                   BSDF block and s = 1 light point;
 *   light subpath   point s_b W H + p of scrambling b (index (b <<
 *                   SOBOL_LOG2_POINTS) + s_b W H + p): the batch's W H
 *                   spp_per_block light subpaths, all pixels together, are one
 *                   net: emission (emitter, position, direction, the (1, 1)
 *                   lens point), each light vertex's BSDF block and (s, 1) lens point.
 * Why the light subpaths are one net per batch and not per pixel: they splat
 * (t = 1) into whichever pixel they reach, so per-pixel nets leave the number
 * of splats a pixel receives a Poisson count.  On the plain Cornell box (64
 * px, 256 spp, batches of 64) with per-pixel nets the 1 % of pixels of
 * largest variance held 74 % of it, on and around the ceiling light, whose
 * direct view (1, 1) samples with an MIS weight near 1 against the camera
 * ray hitting it (0, 2); with one net per batch the emitter points and
 * directions of all light subpaths are stratified together, each pixel's
 * share of the splats is nearly exact, and the summed variance per sample fell
 * 3.9x (0.0129 to 0.0034; the top 1 % then held 11 %).  The own pixel's
 * connections (s >= 2, t >= 2) take the light subpaths at indices s_b W H + p
 * of that net, a strided subset, not a net of its own but still spread out;
 * each sample's numbers stay uniform (unbiased).  Batches are blocks
 * (mcocl/render/splat_film.py) and every batch has its own scramblings (the
 * camera's per pixel, the light's per batch): the batches stay independent,
 * so the splat film's variance from batch means stays honest, as for lt and
 * the independent sampler.  SOBOL_LOG2_POINTS is fixed at 24 for bdpt (one
 * build for every image and batch size), so a block holds at most 2^24
 * samples (the host checks it).
 * The two subpaths keep their layouts of rng/streams.cl, but they must not
 * share Sobol' coordinates: two Owen scramblings of one coordinate are
 * strongly dependent within a net (their first bits are the point's first bit
 * XOR two random bits, and so on down the tree), so camera dimension j and light
 * dimension j would be paired on a curve instead of filling the square.  So
 * the coordinates interleave by blocks of four (bdpt_draw, BDPT_SOBOL_DIM):
 * block k of the camera's layout is Sobol' block 2k, block k of the light's is
 * 2k + 1 (the film point keeps dimensions 0 and 1, the best-distributed pair;
 * the light's emitter choice and position take 4 .. 7).  Distinct Sobol'
 * dimensions are jointly stratified (Joe and Kuo's direction numbers make the
 * low-dimensional projections nets) and every dimension has its own
 * scrambling seed (the stream's Philox words, as for mis).  (The alternative,
 * pbrt-v4's padded 2-D pairs, sec. 8.7, needs a random, hash-based
 * permutation of the sample index per pair: a nested scrambling of the index
 * is again a scrambling of the van der Corput coordinate, the same
 * dependence; and padding gives up the joint stratification of distinct
 * Sobol' coordinates.)  A table of RENDER_TABLE_DIMS = 256 dimensions covers
 * camera vertices up to z_15 and light vertices up to y_14; deeper ones are
 * the back end's padded dimensions (sobol_padded_reversed), still unbiased.
 * The connection roulette's uniforms stay Philox in both builds
 * (connection_roulette): one dimension per strategy (s, t), up to about 1200,
 * which no table holds, and the padded dimensions are scramblings of one van
 * der Corput coordinate, so they would be correlated among the strategies of
 * one sample; the roulette only trades time for variance where a connection
 * is small, so its stratification has little to gain.
 * Measured: see the README's bdpt section.
 *
 * Output: the splat film of lt.cl (mcocl/render/splat_film.py).  A block is
 * spp_per_block W H samples in `ntiles` groups; the sample's own pixel gets
 * W H times the t >= 2 strategies' sum, the t = 1 strategies splat W H times
 * their contribution where they land, and lt_fold_groups divides by the
 * block's W H spp_per_block samples.  A reconstruction filter: the camera
 * ray's film point is drawn from the filter around the pixel's centre and
 * the t = 1 splats carry the filter's weight (render/pixel_filter.cl); the
 * MIS weights stay the box's, which do not depend on the pixel.
 *
 * Lanes (Veach's algorithm unchanged, laid out for SIMD as lt.cl and the
 * path integrators): a work-item takes LANES consecutive samples of its group
 * at once, one per lane, and every vertex array holds lane vectors.  The
 * subpaths grow together, vertex k of every lane in one step (a lane whose
 * subpath ended stays masked until the longest one ends), so the rays of a
 * step are traced as one packet (trace_packet.cl) and a strategy (s, t) is
 * evaluated for all lanes at once, masked where a lane's subpaths are too
 * short.  Each sample draws the same numbers as in a scalar build; the
 * splats of a packet go to the film in lane order, one strategy after the
 * other, so the image is bit-identical for a given LANES.  Measured on PoCL
 * (bench/bdpt_efficiency.py): LANES 16 is about 3x the paths per CPU-second
 * of the scalar build.  Where the time goes (Cornell box, 128 px, LANES 16,
 * by switching parts off): camera walk about 25 %, light walk 15 %, the
 * strategies 60 %, of which the shadow rays about a third and the MIS
 * weights a tenth.  About half the lanes of a walk step and a quarter of the
 * lanes of a strategy's shadow ray are active.  Tracing those shadow rays
 * from a queue compacted to full packets (in push order, so bit-identical)
 * cut the traces' time by about 40 % but the compaction's scalar copies cost
 * as much again on PoCL, so it is not kept.  The walks keep each vertex's
 * material and shading frame (vertex_bsdf: loaded to sample the next
 * direction anyway) in cam_b / light_b, and the connections read them there
 * instead of loading the material and building the frame again per
 * strategy: 12 % more paths per CPU-second on the Cornell box with two
 * spheres (3 interleaved renders each; loading only the light vertices'
 * materials once per packet had gained nothing measurable).
 *
 * Russian roulette on the shadow rays of connections (t >= 2, s >= 1;
 * connection_roulette): a connection whose weighted contribution w max(c)
 * falls below the sample's pixel estimate so far (BDPT_ROULETTE_FRACTION of
 * it) is traced with probability w max(c) / threshold and counted divided by
 * it, so the estimate stays unbiased; the weight comes before the shadow ray
 * for that (it does not depend on visibility).  On by default
 * (render_params.bdpt_roulette); a single strategy (bdpt_only_s >= 0) is
 * never rouletted, and roulette=False renders the exact sum of every
 * strategy, which tests/test_render_bdpt.py compares with the strategies'
 * images.  Measured (128 px, LANES 16, CPU time of 3 interleaved renders
 * of 192 spp each, on a shared machine: +-10 %): on the Cornell box with a
 * mirror and a glass sphere 6 to 11 % less CPU time per sample at 3 to 5 %
 * more variance with the fraction 1 (efficiency +1 to +8 %), on
 * scenes/caustic.json 7 % less at the same variance; the fraction 0.1 saved
 * nothing measurable (few connections fall below a tenth of the estimate so
 * far), 3 no more time than 1 at 12 % more variance.  A packet's shadow ray
 * is saved only when all its lanes lose; one roulette uniform shared by 16
 * consecutive samples (so that lanes lose together) saved no more time, and
 * evaluating every t's s <= 1 strategies before the connections (a better
 * estimate to compare against) cost more than it saved.
 *
 * Where the time goes now (the Cornell box with two spheres, 128 px, LANES
 * 16, 192 spp, CPU microseconds per path, by switching parts off; +-10 %
 * on a shared machine): 0.83 in all; the two walks 0.31 to 0.37 (the camera
 * walk alone 0.19, as much as a whole mis path: a packet steps until its
 * longest subpath ends, and with roulette from path length 5 and 16 lanes
 * that is usually the cap of 8 steps, where an average lane stops at about
 * 5.5 (an estimate from the survival rule, not measured)); the
 * (s >= 2, t >= 2) connections 0.23; the
 * (s, 1) camera connections 0.18 (their shadow rays 0.09, their splats
 * 0.045: perf puts about 5 % of the kernel's samples on the splats' adds
 * into random pixels of the 512 KB double group image, and prefetching
 * those pixels before the camera shadow ray gained nothing measurable); the s = 1
 * connections of t >= 2 0.07; s = 0 0.03; the pdf re-evaluations of the
 * walks nothing measurable.  LANES 8 gives 1.0 M paths per CPU-second,
 * LANES 4 0.7, against 1.2 to 1.3 at 16.  Russian roulette on the (s, 1)
 * shadow rays too (those strategies moved after the t >= 2 ones so that
 * the threshold is the sample's whole own-pixel estimate times W H) saved
 * no measurable time at 8 % more variance, so it is not kept: as with the
 * connections, a packet's ray is saved only when all 16 lanes lose.
 * The time follows the packet operations more than the lanes busy in them
 * (16 lanes cost about 1.25 x what 8 do): a speed-up of the order of 1.4 x
 * per path would need fuller packets (e.g. a lane that finishes its subpath
 * taking the next sample's, with vertex storage per sample) rather than
 * less work per lane.
 *
 * A profile of the kernel since the vertices keep their materials (perf's
 * samples mapped to these source lines through a -g build; same scene, 96
 * spp, 1.2 to 1.3 M paths per CPU-second): the walks 40 % (closest-hit
 * traversal 19, surface records 6, materials and frames 4, BSDF sampling 3,
 * their uniforms 3), the t >= 2 connections 33 % (shadow rays 8, the s = 1
 * emitter points 5, the roulette's uniforms 5, MIS weights 4, BSDF
 * evaluations 4), the (s, 1) camera connections 10 % (shadow rays 6) and
 * their splats 6 %.  Counted per packet of 16 samples: the camera walk
 * takes 6.8 steps with 9 lanes active on average, the light walk 6.3 with
 * 8.4; 7 (s, 1) shadow rays with 7.7 lanes; 33 t >= 2 connections entered
 * with 5 to 7 lanes, of which 9 trace a shadow ray, with 3.3 lanes.  Tried
 * and not kept: caching each vertex's pdf ratio for bdpt_mis_weight (the
 * same numbers without a division per vertex and strategy) measured 5 %
 * slower; calls instead of inlining for the traversals and the BSDF
 * dispatch halved the kernel's code and changed nothing measurable.
 * Measured again for the build's time (a cold PoCL cache, 1 spp): the BSDF
 * dispatch alone as a call halves the cold build (Cornell box 24.8 -> 11.7
 * CPU-s, caustic 22.5 -> 10.4, veach_mis 26.7 -> 12.9; the traversals as
 * calls too: 10.3 on Cornell, for 6-9 % fewer paths), but in 3 interleaved
 * renders it cost 4-12 % of the paths per CPU-second on the Cornell box (0-5 %
 * more on veach_mis and caustic); the eval dispatch alone cost 3-9 % and
 * built in 14.8 s.  Not kept: a render's time is the measure (README, bdpt).
 *
 * Launch parameters (render_params), not build options, so that one build
 * serves every choice: bdpt_power_mis (1: beta 2, 0: beta 1); bdpt_only_s/_t
 * (>= 0) render one strategy, its MIS weight kept unless bdpt_unweighted;
 * bdpt_roulette (1: the connection roulette above).
 */
#define LT_NO_TRACE_KERNEL
#include "render/lt.cl"
#include "samplers/owen_scramble.cl"

#ifndef BDPT_MAX_VERTICES
#define BDPT_MAX_VERTICES 24
#endif

/* The subpath a sampler draws for: its dimensions' place in the Sobol' interleave (see the header,
 * "Quasi-Monte Carlo"). */
#define BDPT_SIDE_CAMERA 0u
#define BDPT_SIDE_LIGHT 1u
#if SAMPLER_BACKEND == SAMPLER_BACKEND_SOBOL
#define BDPT_QMC 1
/* dimension d of a side's layout (rng/streams.cl) -> its Sobol' coordinate: block k of four -> block 2k + side */
#define BDPT_SOBOL_DIM(d, side) ((((uint)(d) >> 2) << 3) | ((uint)(side) << 2) | ((uint)(d) & 3u))
#else
#define BDPT_QMC 0
#endif

/* n uniforms (2, 4 or 8; 2 from an even, 4 and 8 from a multiple-of-4 dimension) of dimensions
 * d .. d + n - 1 of a side's layout (rng/streams.cl): the Philox back end draws them as they are, the
 * Sobol' one from the side's interleaved coordinates, one block of four at a time. */
MC_INLINE void bdpt_draw(mc_sampler_t *smp, uint side, uint d, int n, floatv *u) {
#if BDPT_QMC
    for (int j = 0; j < n; j += 4) {
        sampler_seek(smp, (uintv)(BDPT_SOBOL_DIM(d + (uint)j, side)));
        if (n == 2) sampler_next_2d(smp, u);
        else sampler_next_nd(smp, 4, u + j);
    }
#else
    (void)side;
    sampler_seek(smp, (uintv)(d));
    if (n == 2) sampler_next_2d(smp, u);
    else sampler_next_nd(smp, n, u);
#endif
}

/* One vertex of every lane's subpath (lane vectors). */
typedef struct {
    vec3v p;              /* position (z_0: the lens point) */
    vec3v n;              /* front normal (z_0: the camera's forward axis) */
    vec3v wi;             /* unit direction toward the previous vertex of its subpath */
    vec3v beta;           /* subpath throughput up to and including the vertex's arrival */
    floatv pdf_fwd;       /* area density of the vertex from its own subpath */
    floatv pdf_rev;       /* area density of the vertex from the other direction */
    floatv light_pdf_area; /* density of this point as y_0 (emitters only; the s = 0 strategy) */
    intv emitter;         /* emitter index, -1 if none */
    uintv mat;            /* material index (always a valid one, also in masked lanes) */
#ifdef TEXTURES
    floatv tu, tv;        /* the surface's texture coordinates (render/texture.cl) */
#endif
    intv delta;           /* the vertex scattered through a delta lobe (a lane mask) */
    intv delta_light;     /* y_0 of a point, spot or directional light (no camera subpath reaches it) */
    intv infinite;        /* a direction at infinity: y_0 of a light at infinity, or an escaped camera ray */
} bdpt_vertex;

/* The scene a sample sees: geometry, primitives, lights, camera and the image. */
typedef struct {
    const scene_geom *geom;
    const prim_tables *pt;
    const light_tables *lt;
    global const float4 *camera;
    camera_settings cam_set; /* the camera's clip planes and filter (render/camera.cl) */
    global const float4 *materials;
    global const float4 *textures; /* render/texture.cl (bound, and read, only with -DTEXTURES) */
    float4 bsphere;
    uint width, height;
    float pixels;
    int has_env;      /* an environment: escaped camera rays end in a vertex at infinity */
    int only_s, only_t, unweighted; /* the one strategy rendered (-1: all), without its weight */
    int power_mis;                  /* the power heuristic (beta 2), else the balance heuristic */
    int roulette;                   /* Russian roulette on the connections' shadow rays (see connection_roulette) */
} bdpt_scene;

/* The area density at q (normal nq) of a light ray from infinity along d: the disk's 1 / (pi R^2), projected. */
MC_INLINE floatv infinite_to_area(const bdpt_scene *sc, vec3v d, vec3v nq) {
    return lane_abs(v3_dot(d, nq)) / (RT_PI * sc->bsphere.w * sc->bsphere.w);
}

/* The area density at point q (normal nq) of a direction of solid-angle density pdf_dir sampled at p. */
MC_INLINE floatv to_area(floatv pdf_dir, vec3v p, vec3v q, vec3v nq) {
    vec3v v = v3_sub(q, p);
    floatv d2 = v3_len2(v);
    return lane_select((floatv)(0.0f), pdf_dir * lane_abs(v3_dot(nq, v)) / (d2 * lane_sqrt(d2)), d2 > 0.0f);
}

/* Lanes whose vertex v (material m) is specular for the MIS densities (see the header, "Specular
 * chains"): a surface of a material without a smooth lobe (no connection ever ends there), not an
 * emitter and not at infinity: a function of the vertex alone, whichever subpath holds it. */
MC_INLINE intv specular_vertex(const material_v *m, const bdpt_vertex *v) {
    return !bsdf_is_smooth(m) & (v->emitter < 0) & !v->infinite;
}

/* The MIS density at q (normal nq) of a direction of solid-angle density pdf_dir sampled at p (normal
 * np): to_area's area density, except where q is specular (q_specular), there the projected
 * solid-angle density pdf_dir / |cos_p| (see the header, "Specular chains"). */
MC_INLINE floatv density_toward(floatv pdf_dir, vec3v p, vec3v np, vec3v q, vec3v nq, intv q_specular) {
    const floatv area = to_area(pdf_dir, p, q, nq);
    if (!lane_any(q_specular)) return area;
    const vec3v v = v3_sub(q, p);
    const floatv d2 = v3_len2(v);
    const floatv cos_p = lane_abs(v3_dot(np, v)) * lane_rsqrt(lane_select((floatv)(1.0f), d2, d2 > 0.0f));
    const floatv projected = lane_select((floatv)(0.0f), pdf_dir / cos_p, (d2 > 0.0f) & (cos_p > 0.0f));
    return lane_select(area, projected, q_specular);
}

/* A vertex's material and shading frame, loaded once for the evaluations of one connection. */
typedef struct {
    material_v m;
    frame3v fr;
    vec3v wi_local;
} vertex_bsdf;

MC_INLINE vertex_bsdf vertex_bsdf_of(const bdpt_scene *sc, const bdpt_vertex *v) {
    vertex_bsdf b;
    b.m = material_load(sc->materials, v->mat);
#ifdef TEXTURES
    material_texture(&b.m, sc->textures, v->tu, v->tv, (intv)(-1));
#endif
    b.fr = frame_from_normal(v->n);
    b.wi_local = frame_to_local(b.fr, v->wi);
    return b;
}

/* f cos(theta_out) for light arriving along v->wi and leaving along world direction w_out;
 * *pdf: the density of sampling w_out from wi.  *pdf_rev (when not null): that of sampling wi from w_out.
 * mode: TRANSPORT_RADIANCE at camera vertices, TRANSPORT_IMPORTANCE at light vertices (only
 * rough refraction tells them apart; pdfs are the same in both). */
MC_INLINE vec3v vertex_eval(const vertex_bsdf *b, vec3v w_out, floatv *pdf, floatv *pdf_rev, int mode) {
    vec3v wo = frame_to_local(b->fr, w_out);
    if (pdf_rev) bsdf_eval_mode(&b->m, wo, b->wi_local, pdf_rev, mode);
    return bsdf_eval_mode(&b->m, b->wi_local, wo, pdf, mode);
}

/* Whether the segments from a (normal na) to b are unoccluded, for the lanes in `active`.  The ray aims
 * from the offset origin itself at b, as the path integrators' shadow rays do (integrator.cl, p_up): a
 * ray parallel to a -> b from the offset origin meets b's surface eps (1/cos - cos) before b (eps the
 * offset, cos the angle at the offset), which overtook the SHADOW_EPSILON margin for most segments in a
 * scene far from the world's origin, where offset_origin's eps grows with |p| (a light over a floor 200
 * units away lost 61 % of its (1, 2) light and 4.4 % of the image: tests/test_render_bdpt_far.py). */
MC_INLINE intv segment_clear(const bdpt_scene *sc, vec3v a, vec3v na, vec3v b, intv active) {
    vec3v so = offset_origin(a, na, v3_sub(b, a));
    vec3v d = v3_sub(b, so);
    floatv dist = lane_sqrt(v3_len2(d));
    vec3v w = v3_scale(d, 1.0f / lane_select((floatv)(1.0f), dist, dist > 0.0f));
    return active & !trace_any_v(sc->geom, so, w, dist * (1.0f - SHADOW_EPSILON), active);
}

/* Vertex v of a subpath, found by the ray (o, d) from vertex prev (the lanes in `hit` hit a surface, those
 * in `esc` escaped into the environment): its position, front normal, geometric wi (toward prev, so that
 * the MIS densities are functions of the vertices alone; see bdpt_walk), emitter, material and texture
 * coordinates, no delta flags; a vertex at infinity in direction d for `esc`.  Leaves beta and the
 * densities to the caller; returns the surface record. */
MC_INLINE surface_v vertex_at_hit(const bdpt_scene *sc, bdpt_vertex *v, const bdpt_vertex *prev, hitv h, vec3v o,
                                  vec3v d, intv hit, intv esc) {
    surface_v sf = surface_at(sc->pt, h.prim, h.t, o, d, hit);
    v->p = sf.p;
    v->n = sf.n;
    vec3v back = v3_sub(prev->p, sf.p);
    v->wi = v3_select(v3_neg(d), v3_normalize(back), hit & (v3_len2(back) > 0.0f));
    v->emitter = sf.emitter;
    v->light_pdf_area = lane_select((floatv)(0.0f), sf.pmf * (1.0f - sc->lt->env_pmf) / sf.area, sf.emitter >= 0);
    v->mat = sf.mat;
#ifdef TEXTURES
    texture_uv(sc->textures, sc->pt, h.prim, h.b1, h.b2, sf.p, hit, &v->tu, &v->tv);
#endif
    v->delta = (intv)(0);
    v->delta_light = (intv)(0);
    v->infinite = esc;
    if (lane_any(esc)) {
        v->p = v3_select(v->p, v3_add(prev->p, d), esc);
        v->n = v3_select(v->n, v3_neg(d), esc);
        v->light_pdf_area = lane_select(v->light_pdf_area, (floatv)(0.0f), esc);
        v->emitter = lane_select(v->emitter, (intv)(-1), esc);
        v->mat = lane_select(v->mat, (uintv)(0u), esc);
    }
    return sf;
}

/* pdf_fwd of a walk's new vertex v, sampled from prev with solid-angle density pdf_geo (zero where
 * prev is a point, spot or infinite light: those keep to_area's or infinite_to_area's density), once
 * v's material m is known: density_toward's where v is specular. */
MC_INLINE void specular_density(bdpt_vertex *v, const bdpt_vertex *prev, const material_v *m, floatv pdf_geo) {
    const intv spec = specular_vertex(m, v) & (pdf_geo > 0.0f);
    if (lane_any(spec)) v->pdf_fwd = lane_select(v->pdf_fwd, density_toward(pdf_geo, prev->p, prev->n, v->p, v->n, spec), spec);
}

/* Grow the lanes' subpaths from path[n - 1] along (o, d), sampled with solid-angle density
 * pdf_dir, for the lanes in `alive`, while they have fewer than maxv vertices; *count: each
 * lane's vertex count (raised for the lanes that gain vertices).  Every step writes vertex n of
 * every lane (masked lanes get finite values with a valid material), so a strategy may read
 * vertex k < max(count) of any lane and mask the result.
 * The MIS densities (pdf_fwd, pdf_rev) and wi are functions of the vertices'
 * positions alone, as the connections compute them: a walk's ray leaves from
 * an offset origin (offset_origin), so its sampled direction differs from the
 * direction between the two vertices by about RAY_EPSILON / distance, and
 * weights taken from it would not sum to 1 with the connections' (a bias of
 * -1e-3 in a spherical furnace, tests/test_render_bdpt.py).  So each new
 * vertex w re-evaluates the previous vertex v's densities along the
 * geometric directions: w's pdf_fwd and the pdf_rev of the vertex before v.
 * mode: TRANSPORT_RADIANCE (camera; dimensions RENDER_DIM_BSDF(k - 1) at z_k, Mitsuba's
 * roulette on max(beta) eta^2) or TRANSPORT_IMPORTANCE (light; LT_DIM_BSDF(k) at y_k,
 * roulette on max(beta) / rr_scale as lt.cl).  Roulette applies from path length rr_depth. */
MC_INLINE void bdpt_walk(const bdpt_scene *sc, mc_sampler_t *smp, bdpt_vertex *path, vertex_bsdf *bsdfs,
                         intv *count, intv alive, int maxv, vec3v o, vec3v d, vec3v beta, floatv pdf_dir, int mode, uint rr_depth,
                         floatv rr_scale, bsdf_sample_v *first) {
    floatv eta = (floatv)(1.0f);
    vertex_bsdf *pb = bsdfs; /* path[n - 1]'s material, frame and geometric wi, from the step that sampled it */
    int cached = 1, written = 0; /* bsdfs[k] holds path[k]'s for 1 <= k < cached; path[written] the last vertex written */
    floatv written_pdf = (floatv)(0.0f); /* the solid-angle density path[written] was sampled with (pdf_geo) */
    for (int n = 1; n < maxv && lane_any(alive); ) {
        hitv h = trace_closest_v(sc->geom, o, d, alive);
        /* a camera ray ends at the far clip plane, as the megakernel's (render/camera.cl): what lies
         * beyond is a miss */
        if (n == 1 && mode == TRANSPORT_RADIANCE && camera_has_far_clip(sc->cam_set))
            h.hit = h.hit & !camera_beyond_far_clip(sc->camera, sc->cam_set, d, h.t);
        intv hit = alive & h.hit;
        /* a camera ray that escapes into an environment: a vertex at infinity in direction d */
        const intv esc = mode == TRANSPORT_RADIANCE && sc->has_env ? alive & !h.hit : (intv)(0);
        bdpt_vertex *v = &path[n];
        bdpt_vertex *prev = &path[n - 1];
        const surface_v sf = vertex_at_hit(sc, v, prev, h, o, d, hit, esc);
        v->beta = beta;
        /* prev's density of the direction toward v: the camera's rays leave the lens point itself (pdf_dir),
         * an area emitter's by its cosine, a surface's by its BSDF given its own geometric wi; a point or
         * spot light's ray leaves the light's position itself (pdf_dir), an infinite light's a disk
         * (infinite_to_area) */
        floatv pdf_geo = pdf_dir;
        if (n >= 2) {
            floatv pdf_back;
            vertex_eval(pb, v3_neg(v->wi), &pdf_geo, &pdf_back, mode);
            pdf_geo = lane_select(pdf_geo, (floatv)(0.0f), prev->delta);
            bdpt_vertex *pprev = &path[n - 2];
            /* y_0 at infinity keeps a solid-angle density; a specular pprev (bsdfs[n - 2], cached for n >= 3)
             * a projected solid-angle one (density_toward) */
            const intv spec = n >= 3 ? specular_vertex(&bsdfs[n - 2].m, pprev) : (intv)(0);
            floatv rev = lane_select(density_toward(pdf_back, prev->p, prev->n, pprev->p, pprev->n, spec), pdf_back,
                                     pprev->infinite);
            pprev->pdf_rev = lane_select(pprev->pdf_rev, rev, (hit | esc) & !prev->delta);
        } else if (mode == TRANSPORT_IMPORTANCE) {
            pdf_geo = lane_select(emitter_pdf_solid_angle(prev->n, v3_neg(v->wi)), pdf_dir,
                                  prev->delta_light | prev->infinite);
        }
        v->pdf_fwd = to_area(pdf_geo, prev->p, sf.p, sf.n);
        if (n == 1 && mode == TRANSPORT_IMPORTANCE)
            v->pdf_fwd = lane_select(v->pdf_fwd, infinite_to_area(sc, d, sf.n), prev->infinite);
        v->pdf_rev = (floatv)(0.0f);
        /* pdf_dir: the solid-angle density of d from prev (its BSDF sample, or the camera's) */
        if (lane_any(esc)) v->pdf_fwd = lane_select(v->pdf_fwd, pdf_dir, esc);
        /* a specular v's pdf_fwd becomes density_toward's once its material is loaded (specular_density) */
        written_pdf = lane_select(pdf_geo, (floatv)(0.0f), prev->infinite | prev->delta_light);
        written = n++;
        *count = lane_select(*count, (intv)(n), hit | esc);
        alive = hit;
        if (n >= maxv || !lane_any(alive)) break;
        pb = &bsdfs[n - 1];
        *pb = vertex_bsdf_of(sc, v);
        specular_density(v, prev, &pb->m, written_pdf);
        cached = n;
        floatv ub[4]; /* lobe, direction 2D, roulette */
        if (mode == TRANSPORT_RADIANCE) bdpt_draw(smp, BDPT_SIDE_CAMERA, RENDER_DIM_BSDF((uint)(n - 2)), 4, ub);
        else bdpt_draw(smp, BDPT_SIDE_LIGHT, LT_DIM_BSDF((uint)(n - 1)), 4, ub);
        bsdf_sample_v bs = bsdf_sample(&pb->m, pb->wi_local, ub[0], ub[1], ub[2], mode);
        if (first && n == 2) *first = bs; /* z_1's branch, for split_first_vertex */
        intv ok = alive & (v3_maxc(bs.weight) > 0.0f) & (bs.pdf > 0.0f);
        v->delta = ok & bs.delta;
        beta = v3_mul(beta, bs.weight);
        eta *= bs.eta;
        /* the solid-angle density of d, for a vertex at infinity should the ray escape */
        pdf_dir = lane_select(bs.pdf, (floatv)(0.0f), bs.delta);
        vec3v wo = frame_to_world(pb->fr, bs.wo);
        o = offset_origin(sf.p, sf.n, wo);
        d = wo;
        /* roulette as integrator.cl (camera: from depth rr_depth of the vertex after z_k, i.e. k + 1)
         * and lt.cl (light: from light vertex rr_depth) */
        if ((uint)(mode == TRANSPORT_RADIANCE ? n - 1 : n) >= rr_depth) {
            floatv q = mode == TRANSPORT_RADIANCE ? lane_min(v3_maxc(beta) * eta * eta, (floatv)(0.95f))
                                                  : lane_min(v3_maxc(beta) / rr_scale, (floatv)(0.95f));
            ok = ok & (ub[3] < q);
            beta = v3_scale(beta, 1.0f / q);
        }
        alive = ok;
    }
    /* the last vertex's too, which the connections read (it samples no direction) */
    if (written >= cached) {
        bsdfs[written] = vertex_bsdf_of(sc, &path[written]);
        specular_density(&path[written], &path[written - 1], &bsdfs[written].m, written_pdf);
    }
}

/* (pdf_rev / pdf_fwd)^beta with zero densities (delta vertices) counted as 1; beta 2 where power. */
MC_INLINE floatv mis_ratio(int power, floatv rev, floatv fwd) {
    floatv r = lane_select((floatv)(1.0f), rev, rev != 0.0f) / lane_select((floatv)(1.0f), fwd, fwd != 0.0f);
    return power ? r * r : r;
}

/* The MIS weight of strategy (s, t), the connection's reverse densities
 * already in place; nl_cap, nc_cap: the most light and camera vertices a
 * strategy of this render may use. */
MC_INLINE floatv bdpt_mis_weight(const bdpt_scene *sc, const bdpt_vertex *light, const bdpt_vertex *cam, int s,
                                 int t, int nl_cap, int nc_cap) {
    floatv sum = (floatv)(0.0f), r = (floatv)(1.0f);
    /* (1, 1) is no strategy for a light at infinity */
    const intv no_11 = s + t == 2 ? (s > 0 ? light[0].infinite : cam[t - 1].infinite) : (intv)(0);
    /* strategies (s + t - i, i): the camera vertex z_i is taken by the light subpath instead */
    for (int i = t - 1; i > 0; --i) {
        if (s + t - i > nl_cap) break;
        r *= mis_ratio(sc->power_mis, cam[i].pdf_rev, cam[i].pdf_fwd);
        sum += lane_select(r, (floatv)(0.0f), cam[i].delta | cam[i - 1].delta | (i == 1 ? no_11 : (intv)(0)));
    }
    r = (floatv)(1.0f);
    /* strategies (i, s + t - i): the light vertex y_i is taken by the camera subpath instead */
    for (int i = s - 1; i >= 0; --i) {
        if (s + t - i > nc_cap) break;
        r *= mis_ratio(sc->power_mis, light[i].pdf_rev, light[i].pdf_fwd);
        intv delta_before = i > 0 ? light[i - 1].delta : light[0].delta_light;
        sum += lane_select(r, (floatv)(0.0f), light[i].delta | delta_before);
    }
    return 1.0f / (1.0f + sum);
}

/* bdpt_mis_weight for a path that strategy (s, t) joined at cam[t - 1] and light[s - 1]: the path scatters
 * there by the connection's smooth lobe, whatever lobe the walk went on with (a plastic's delta coat), so
 * the two endpoints count as non-delta (pbrt-v3's MISWeight does the same). */
MC_INLINE floatv bdpt_connection_weight(const bdpt_scene *sc, bdpt_vertex *light, bdpt_vertex *cam, int s, int t, int nl_cap,
                                        int nc_cap) {
    intv dz = cam[t - 1].delta, dy = s > 0 ? light[s - 1].delta : (intv)(0);
    cam[t - 1].delta = (intv)(0);
    if (s > 0) light[s - 1].delta = (intv)(0);
    floatv w = bdpt_mis_weight(sc, light, cam, s, t, nl_cap, nc_cap);
    cam[t - 1].delta = dz;
    if (s > 0) light[s - 1].delta = dy;
    return w;
}

/* Russian roulette on the shadow ray of a connection (s >= 1, t >= 2), for the lanes in `ok` whose
 * weighted contribution w max(c) falls below `threshold` (BDPT_ROULETTE_FRACTION of the sample's
 * pixel estimate so far): the ray is traced with probability q = w max(c) / threshold and the
 * contribution c becomes c / q, so its expectation is unchanged (the efficiency-optimized Russian
 * roulette of visibility tests that Veach's thesis, chapter 10, proposes for bidirectional path tracing).
 * threshold and w do not depend on the uniform: it comes from its own stream and dimension
 * (RNG_STREAM_BDPT_ROULETTE, BDPT_DIM_ROULETTE(s, t)), one per strategy.  Returns the lanes that
 * survive; off (sc->roulette 0) it returns `ok` and leaves c as it is. */
#define BDPT_ROULETTE_FRACTION 1.0f
#define BDPT_DIM_ROULETTE(s, t) ((uint)(s) * (uint)(2 * BDPT_MAX_VERTICES) + (uint)(t))
MC_INLINE intv connection_roulette(const bdpt_scene *sc, const rng_t *rr, int s, int t, floatv threshold, floatv w,
                                   vec3v *c, intv ok) {
    if (!sc->roulette) return ok;
    const floatv wc = w * v3_maxc(*c);
    const intv play = ok & (wc < threshold);
    if (!lane_any(play)) return ok;
    /* Philox in every sampler build (see the header, "Quasi-Monte Carlo"): dimension d is word d % 4 of
     * block d / 4, the numbers of the Philox back end's sampler_next_1d */
    const uint d = BDPT_DIM_ROULETTE(s, t);
    const floatv u = u01(philox_word(rng_block(*rr, (uintv)(d >> 2)), (uintv)(d & 3u)));
    const floatv q = wc / threshold; /* in [0, 1) where play; zero (a zero weight) never survives */
    *c = v3_select(*c, v3_scale(*c, 1.0f / q), play & (u < q));
    return ok & !(play & (u >= q));
}

/* The radiance a camera subpath sees at its vertex pt, for the lanes in `active` (strategy (0, t)
 * and split_first_vertex): an area emitter's toward pt->wi if pt is on its emitting side (*on_emitter),
 * or at infinity (an escaped camera ray) the environment's along -pt->wi (*at_inf); zero elsewhere. */
MC_INLINE vec3v emission_seen(const bdpt_scene *sc, const bdpt_vertex *pt, intv active, intv *on_emitter,
                              intv *at_inf) {
    const intv inf = active & pt->infinite;
    const intv ok = active & !pt->infinite & (pt->emitter >= 0) & (v3_dot(pt->n, pt->wi) > 0.0f);
    *on_emitter = ok;
    *at_inf = inf;
    if (!lane_any(ok | inf)) return v3s(0.0f);
    intv e = lane_select((intv)(-1), pt->emitter, ok);
    vec3v le = emitter_radiance_of(sc->lt, e);
#ifdef TEXTURES
    le = emitter_radiance_uv(sc->lt, e, pt->tu, pt->tv, le, ok); /* a textured emitter (render/lights.cl) */
#endif
    if (lane_any(inf)) le = v3_select(le, environment_radiance(sc->lt, v3_neg(pt->wi), inf), inf);
    return le;
}

/* Strategy (s, t) with t >= 2 for the lanes in `active`: its unweighted contribution to the
 * sample's own pixel, zero where a lane has none, times its weight into *w.  ue: the s = 1 light
 * point's four uniforms (emitter choice and position).  cam_b, light_b: the vertices' materials and
 * frames (vertex 0 of each has none). */
MC_INLINE vec3v bdpt_connect(const bdpt_scene *sc, bdpt_vertex *light, const vertex_bsdf *light_b, bdpt_vertex *cam,
                             int s, int t, const floatv *ue, const vertex_bsdf *cam_b, intv active, int nl_cap,
                             int nc_cap, const rng_t *rr, floatv threshold, floatv *w) {
    vec3v zero = v3s(0.0f);
    *w = (floatv)(0.0f);
    bdpt_vertex *pt = &cam[t - 1], *ptm = &cam[t - 2];
    const vertex_bsdf *zb = &cam_b[t - 1];
    /* z_{t-2} specular: its reverse density is density_toward's (see the header, "Specular chains") */
    const intv ptm_spec = t >= 3 ? specular_vertex(&cam_b[t - 2].m, ptm) : (intv)(0);
    floatv save_pt = pt->pdf_rev, save_ptm = ptm->pdf_rev;
    vec3v c;
    intv ok;
    if (s == 0) {
        intv inf;
        const vec3v le = emission_seen(sc, pt, active, &ok, &inf);
        if (!lane_any(ok | inf)) return zero;
        c = v3_mul(pt->beta, le);
        pt->pdf_rev = pt->light_pdf_area;
        ptm->pdf_rev = density_toward(emitter_pdf_solid_angle(pt->n, pt->wi), pt->p, pt->n, ptm->p, ptm->n, ptm_spec);
        if (lane_any(inf)) {
            vec3v dir = v3_neg(pt->wi);
            pt->pdf_rev = lane_select(pt->pdf_rev, sc->lt->env_pmf * environment_pdf(sc->lt, dir, inf), inf);
            ptm->pdf_rev = lane_select(ptm->pdf_rev, infinite_to_area(sc, dir, ptm->n), inf);
            ok = ok | inf;
        }
        *w = lane_select((floatv)(0.0f), bdpt_connection_weight(sc, light, cam, s, t, nl_cap, nc_cap), ok);
        pt->pdf_rev = save_pt;
        ptm->pdf_rev = save_ptm;
    } else if (s == 1) {
        ok = active & bsdf_is_smooth(&zb->m);
        if (!lane_any(ok)) return zero;
        floatv u6[6] = {ue[0], ue[1], ue[2], ue[3], (floatv)(0.5f), (floatv)(0.5f)};
        emitter_ray_v er = sample_emitter_ray(sc->lt, sc->bsphere, u6, ok);
        /* lanes that chose a light at infinity (env, directional) or a point or spot light see it as
         * light sampling does (lights.cl: the same choice and direction) */
        intv inf = ok & er.infinite, point = ok & er.valid & er.delta & !er.infinite;
        light_sample_v ls;
        if (lane_any(inf | point)) {
            ls = sample_light(sc->lt, sc->pt, pt->p, ue[0], ue[1], ue[2], ue[3], inf | point);
            inf = inf & ls.valid;
            point = point & ls.valid;
        }
        ok = ok & er.valid & !er.infinite;
        vec3v dv = v3_sub(er.pos, pt->p);
        floatv d2 = v3_len2(dv);
        vec3v wz = v3_scale(dv, lane_rsqrt(d2));
        floatv cos_y = -v3_dot(er.n, wz);
        ok = (ok & !er.delta & (cos_y > 0.0f) & (d2 > 0.0f)) | (point & (d2 > 0.0f));
        const int special = lane_any(inf | point);
        floatv pz, pr;
        vec3v fz = vertex_eval(zb, special ? v3_select(wz, ls.wo, inf) : wz, &pz, &pr, TRANSPORT_RADIANCE);
        c = v3_scale(v3_mul(v3_mul(pt->beta, fz), er.radiance), cos_y / (d2 * er.pdf_area));
        if (special) {
            /* a point or spot light: intensity times falloff / d^2, probability er.pdf_area; at infinity:
             * radiance over the solid-angle pdf (a directional light's: its choice probability) */
            vec3v fl = v3_mul(v3_mul(pt->beta, fz), ls.radiance);
            c = v3_select(c, v3_scale(fl, 1.0f / er.pdf_area), point);
            c = v3_select(c, v3_scale(fl, 1.0f / ls.pdf), inf);
            ok = ok | inf;
        }
        ok = ok & (v3_maxc(c) > 0.0f);
        if (!lane_any(ok)) return zero;
        /* the weight before the shadow ray, which the roulette needs (it does not depend on visibility) */
        /* y_0 as the weight sees it: bdpt_mis_weight reads only a light vertex's densities and delta
         * flags, so only those are swapped in (and restored after), not the whole vertex record */
        bdpt_vertex *y0 = &light[0];
        const floatv y0_fwd = y0->pdf_fwd, y0_rev = y0->pdf_rev;
        const intv y0_delta = y0->delta, y0_delta_light = y0->delta_light, y0_inf = y0->infinite;
        y0->delta = (intv)(0);
        y0->delta_light = er.delta;
        y0->infinite = (intv)(0);
        y0->pdf_fwd = er.pdf_area;
        y0->pdf_rev = to_area(pz, pt->p, er.pos, er.n);
        /* the density of the direction toward z_{t-1}: an area light's cosine, a point or spot light's
         * emission density (uniform on the sphere or the cone: er's, whatever direction it drew) */
        pt->pdf_rev = to_area(lane_select(cos_y * RT_INV_PI, er.pdf_solid_angle, er.delta), er.pos, pt->p, pt->n);
        if (special) {
            y0->delta_light = lane_select(y0->delta_light, ls.delta, inf);
            y0->infinite = inf;
            y0->pdf_fwd = lane_select(y0->pdf_fwd, ls.pdf, inf);
            y0->pdf_rev = lane_select(y0->pdf_rev, pz, inf);
            pt->pdf_rev = lane_select(pt->pdf_rev, infinite_to_area(sc, ls.wo, pt->n), inf);
        }
        ptm->pdf_rev = density_toward(pr, pt->p, pt->n, ptm->p, ptm->n, ptm_spec);
        *w = bdpt_connection_weight(sc, light, cam, s, t, nl_cap, nc_cap);
        y0->pdf_fwd = y0_fwd;
        y0->pdf_rev = y0_rev;
        y0->delta = y0_delta;
        y0->delta_light = y0_delta_light;
        y0->infinite = y0_inf;
        pt->pdf_rev = save_pt;
        ptm->pdf_rev = save_ptm;
        ok = connection_roulette(sc, rr, s, t, threshold, *w, &c, ok);
        if (special && lane_any(ok)) {
            const intv at_inf = ok & inf;
            ok = segment_clear(sc, pt->p, pt->n, er.pos, ok & !inf);
            if (lane_any(at_inf))
                ok = ok | (at_inf & !trace_any_v(sc->geom, offset_origin(pt->p, pt->n, ls.wo), ls.wo,
                                                 (floatv)(INFINITY), at_inf));
        } else if (lane_any(ok)) {
            ok = segment_clear(sc, pt->p, pt->n, er.pos, ok);
        }
    } else {
        bdpt_vertex *qs = &light[s - 1], *qsm = &light[s - 2];
        ok = active & bsdf_is_smooth(&zb->m);
        if (!lane_any(ok)) return zero;
        const vertex_bsdf *yb = &light_b[s - 1];
        ok = ok & bsdf_is_smooth(&yb->m);
        vec3v dv = v3_sub(pt->p, qs->p);
        floatv d2 = v3_len2(dv);
        ok = ok & (d2 > 0.0f);
        if (!lane_any(ok)) return zero;
        vec3v wy = v3_scale(dv, lane_rsqrt(d2)); /* from y_{s-1} toward z_{t-1} */
        floatv py, pz, pry, prz;
        vec3v fy = vertex_eval(yb, wy, &py, &pry, TRANSPORT_IMPORTANCE);
        vec3v fz = vertex_eval(zb, v3_neg(wy), &pz, &prz, TRANSPORT_RADIANCE);
        c = v3_scale(v3_mul(v3_mul(qs->beta, fy), v3_mul(fz, pt->beta)), 1.0f / d2);
        ok = ok & (v3_maxc(c) > 0.0f);
        if (!lane_any(ok)) return zero;
        floatv save_qs = qs->pdf_rev, save_qsm = qsm->pdf_rev;
        pt->pdf_rev = to_area(py, qs->p, pt->p, pt->n);
        qs->pdf_rev = to_area(pz, pt->p, qs->p, qs->n);
        ptm->pdf_rev = density_toward(prz, pt->p, pt->n, ptm->p, ptm->n, ptm_spec);
        const intv qsm_spec = s >= 3 ? specular_vertex(&light_b[s - 2].m, qsm) : (intv)(0);
        qsm->pdf_rev = lane_select(density_toward(pry, qs->p, qs->n, qsm->p, qsm->n, qsm_spec), pry, qsm->infinite);
        *w = bdpt_connection_weight(sc, light, cam, s, t, nl_cap, nc_cap);
        qs->pdf_rev = save_qs;
        qsm->pdf_rev = save_qsm;
        pt->pdf_rev = save_pt;
        ptm->pdf_rev = save_ptm;
        ok = connection_roulette(sc, rr, s, t, threshold, *w, &c, ok);
        if (lane_any(ok)) ok = segment_clear(sc, qs->p, qs->n, pt->p, ok);
    }
    *w = lane_select((floatv)(0.0f), *w, ok);
    return v3_select(zero, c, ok);
}

/* Whether a material is a delta BSDF of exactly two branches, reflection and transmission, chosen by
 * the lobe uniform u as "reflect if u < R" (render/bsdf_dielectric.cl, render/bsdf_thindielectric.cl):
 * the smooth dielectric and the thin sheet.  Not a conductor (one branch) nor plastic's delta coat. */
MC_INLINE intv two_branch_delta(const material_v *m) {
    return (m->kind == MAT_DIELECTRIC) | (m->kind == MAT_THINDIELECTRIC);
}

/* The splitting of z_1's two delta branches (see the header): for the lanes in `split` (a pinhole camera,
 * z_1 a surface of a two_branch_delta material, `taken` the branch the camera walk drew there), the
 * emission seen along the branch the walk did not take, beta_1 W_o Le_o: W_o = weight x probability of
 * that branch (radiance mode: refraction's 1/eta^2 included), Le_o what emission_seen finds at the end of
 * one closest-hit ray (an emitter's front, or the environment when the ray escapes); zero elsewhere.  The
 * other branch is drawn by bsdf_sample with lobe uniform 1 (transmission: u < R fails for every R <= 1)
 * or 0 (reflection where R > 0), so no random number is used. */
MC_INLINE vec3v split_first_vertex(const bdpt_scene *sc, const bdpt_vertex *cam, const vertex_bsdf *zb,
                                   const bsdf_sample_v *taken, intv split) {
    const vec3v zero = v3s(0.0f);
    const bdpt_vertex *z1 = &cam[1];
    /* reflection leaves on wi's side of the surface, transmission on the other */
    const intv took_reflection = taken->wo.z * zb->wi_local.z > 0.0f;
    const bsdf_sample_v o = bsdf_sample(&zb->m, zb->wi_local, lane_select((floatv)(0.0f), (floatv)(1.0f), took_reflection),
                                        (floatv)(0.5f), (floatv)(0.5f), TRANSPORT_RADIANCE);
    /* the other branch exists (R strictly between 0 and 1) and carries light */
    split = split & (o.wo.z * taken->wo.z < 0.0f) & (o.pdf > 0.0f) & (v3_maxc(o.weight) > 0.0f);
    if (!lane_any(split)) return zero;
    const vec3v d = frame_to_world(zb->fr, o.wo);
    const vec3v org = offset_origin(z1->p, z1->n, d);
    const hitv h = trace_closest_v(sc->geom, org, d, split);
    const intv hit = split & h.hit;
    const intv esc = sc->has_env ? split & !h.hit : (intv)(0);
    bdpt_vertex z2;
    vertex_at_hit(sc, &z2, z1, h, org, d, hit, esc);
    intv on_emitter, at_inf;
    const vec3v le = emission_seen(sc, &z2, hit | esc, &on_emitter, &at_inf);
    const vec3v c = v3_mul(v3_scale(v3_mul(z1->beta, o.weight), o.pdf), le);
    return v3_select(zero, c, on_emitter | at_inf);
}

/* Strategy (s, 1) for the lanes in `active`: light vertex y_{s-1} seen by the camera through
 * the lens point of (ul1, ul2).  Returns the splat (W H times the contribution, unweighted) and
 * where it lands on the film (*film, for splat_filtered); *w its weight, zero where a lane has none. */
MC_INLINE vec3v bdpt_connect_camera(const bdpt_scene *sc, bdpt_vertex *light, const vertex_bsdf *light_b,
                                    bdpt_vertex *cam, int s, floatv ul1,
                                    floatv ul2, intv active, int nl_cap, int nc_cap, camera_direction_v *film,
                                    floatv *w) {
    vec3v zero = v3s(0.0f);
    *w = (floatv)(0.0f);
    bdpt_vertex *qs = &light[s - 1];
    const vertex_bsdf *yb = &light_b[s - 1];
    intv ok = active;
    if (s == 1) {
        ok = ok & !(qs->delta_light | qs->infinite); /* invisible, or left to (0, 2) */
        if (!lane_any(ok)) return zero;
    } else {
        ok = ok & bsdf_is_smooth(&yb->m);
        if (!lane_any(ok)) return zero;
    }
    camera_connection_v k = camera_connect(sc->camera, sc->cam_set, qs->p, ul1, ul2, sc->width, sc->height);
    ok = ok & k.valid;
    if (!lane_any(ok)) return zero;
    vec3v f;
    floatv pr = (floatv)(0.0f);
    if (s == 1) {
        floatv cos_y = v3_dot(qs->n, k.wo);
        f = v3s(lane_max(cos_y, (floatv)(0.0f)));
    } else {
        floatv pfwd;
        f = vertex_eval(yb, k.wo, &pfwd, &pr, TRANSPORT_IMPORTANCE);
    }
    vec3v c = v3_scale(v3_mul(qs->beta, f), sc->pixels * k.film.importance / k.pdf_solid_angle);
    ok = ok & (v3_maxc(c) > 0.0f);
    if (!lane_any(ok)) return zero;
    ok = camera_visible(sc->geom, qs->p, qs->n, &k, ok);
    if (!lane_any(ok)) return zero;
    *film = k.film;
    floatv save_qs = qs->pdf_rev;
    qs->pdf_rev = to_area(k.film.pdf_solid_angle, k.lens, qs->p, qs->n);
    if (s > 1) {
        bdpt_vertex *qsm = &light[s - 2];
        floatv save_qsm = qsm->pdf_rev;
        const intv qsm_spec = s >= 3 ? specular_vertex(&light_b[s - 2].m, qsm) : (intv)(0);
        qsm->pdf_rev = lane_select(density_toward(pr, qs->p, qs->n, qsm->p, qsm->n, qsm_spec), pr, qsm->infinite);
        *w = bdpt_connection_weight(sc, light, cam, s, 1, nl_cap, nc_cap);
        qsm->pdf_rev = save_qsm;
    } else {
        *w = bdpt_connection_weight(sc, light, cam, s, 1, nl_cap, nc_cap);
    }
    qs->pdf_rev = save_qs;
    *w = lane_select((floatv)(0.0f), *w, ok);
    return v3_select(zero, c, ok);
}

/* Whether strategy (s, t) is rendered (all, or the one of render_params.bdpt_only_s / _t). */
MC_INLINE int strategy_on(const bdpt_scene *sc, int s, int t) {
    return sc->only_s < 0 || (s == sc->only_s && t == sc->only_t);
}

MC_INLINE floatv strategy_weight(const bdpt_scene *sc, floatv w) {
    return sc->unweighted ? (floatv)(1.0f) : w;
}

/* The scene of a splatting trace kernel's work-item (the names SPLAT_TRACE_PRELUDE makes). */
MC_INLINE bdpt_scene bdpt_scene_of(const render_params *params, const scene_geom *geom, const prim_tables *pt,
                                   const light_tables *lt, global const float4 *camera,
                                   global const float4 *materials, global const float4 *textures, float4 bsphere,
                                   uint npix) {
    bdpt_scene sc;
    sc.has_env = params->env_radiance.x > 0.0f || params->env_radiance.y > 0.0f || params->env_radiance.z > 0.0f;
    sc.geom = geom;
    sc.pt = pt;
    sc.lt = lt;
    sc.camera = camera;
    sc.cam_set = camera_settings_of(params);
    sc.materials = materials;
    sc.textures = textures;
    sc.bsphere = bsphere;
    sc.width = params->width;
    sc.height = params->height;
    sc.pixels = (float)npix;
    sc.only_s = params->bdpt_only_s;
    sc.only_t = params->bdpt_only_t;
    sc.unweighted = params->bdpt_unweighted;
    sc.power_mis = params->bdpt_power_mis;
    /* a single strategy is rendered exactly as drawn (teaching, tests), never rouletted */
    sc.roulette = params->bdpt_roulette && sc.only_s < 0;
    return sc;
}

/* The film uniforms of sample s of pixel p (per lane) in batch b: point s of the Owen-scrambled
 * (0, 2)-sequence (samplers/owen_scramble.cl) of scrambling b W H + p, whose seeds are words 0
 * and 1 of Philox (b W H + p, block 0, RNG_STREAM_BDPT_FILM) (see the header, "Film positions"). */
MC_INLINE void bdpt_film_uniforms(ulong seed, uintv b, uintv p, uint npix, uintv s, floatv *u) {
    const ulongv scrambling = to_ulongv(b) * (ulong)npix + to_ulongv(p);
    const philox_ctr c = rng_block(rng_init(scrambling, seed, RNG_STREAM_BDPT_FILM), (uintv)(0u));
    owen_sobol_2d(s, c.v0, c.v1, u);
}

/* z_0 of a camera subpath: the lens point, facing along the camera's forward axis. */
MC_INLINE bdpt_vertex lens_vertex(vec3v co, vec3v forward) {
    bdpt_vertex z;
    z.p = co;
    z.n = forward;
    z.wi = forward;
    z.beta = v3s(1.0f);
    z.pdf_fwd = (floatv)(1.0f);
    z.pdf_rev = (floatv)(0.0f);
    z.light_pdf_area = (floatv)(0.0f);
    z.emitter = (intv)(-1);
    z.mat = (uintv)(0u);
#ifdef TEXTURES
    z.tu = z.tv = (floatv)(0.0f);
#endif
    z.delta = (intv)(0);
    z.delta_light = (intv)(0);
    z.infinite = (intv)(0);
    return z;
}

/* Samples of blocks first_block .. first_block + nblocks - 1; params.ntiles groups per block,
 * one work-item each, LANES samples at a time, on the splat film of lt.cl (scratch: one group
 * image per work-item). */
kernel void bdpt_trace(
    SPLAT_TRACE_PARAMS)
{
    SPLAT_TRACE_PRELUDE;
    const bdpt_scene sc = bdpt_scene_of(&params, &geom, &pt, &lt, camera, materials, textures, bsphere, npix);
    const float inv_w = 1.0f / (float)width, inv_h = 1.0f / (float)height;
    const bool thin_lens = camera_aperture(camera) > 0.0f;
    /* the most vertices a strategy may take from each side (see the header) */
    const int nc_cap = max_depth >= 0 ? min(max_depth + 1, BDPT_MAX_VERTICES) : BDPT_MAX_VERTICES;
    const int nl_cap = max_depth >= 0 ? min(max_depth, BDPT_MAX_VERTICES) : BDPT_MAX_VERTICES;
    const vec3v forward = cam_row(camera[CAMERA_RECORD_FORWARD_QUAD]);
    const uint spb = max(params.spp_per_block, 1u);
    /* the splitting at z_1 (see the header): a pinhole, paths of 2 segments allowed, strategy (0, 3) rendered */
    const int split_on = !thin_lens && nc_cap >= 3 && (max_depth < 0 || max_depth >= 2) && strategy_on(&sc, 0, 3);

    bdpt_vertex cam[BDPT_MAX_VERTICES];
    bdpt_vertex light[BDPT_MAX_VERTICES];
    /* the vertices' materials and frames, from the walks (vertex 0 of each has none) */
    vertex_bsdf cam_b[BDPT_MAX_VERTICES];
    vertex_bsdf light_b[BDPT_MAX_VERTICES];

    for (ulong j = 0; j < total; j += LANES) {
        /* the lanes holding one of the group's samples (the last packet may be partial) */
        const intv active = LANE_IOTA < (uintv)((uint)min(total - j, (ulong)LANES));
        const ulongv index = (ulongv)(path0 + j) + to_ulongv(LANE_IOTA);
        /* sample number sn of pixel `pixel`: sample sn - b spp_per_block of its batch b (see the header) */
        const uintv sn = to_uintv(index / (ulongv)(npix));
        const uintv pixel = to_uintv(index) - sn * npix;
        const uintv batch = sn / spb;

        /* ---- the camera subpaths ---- */
#if BDPT_QMC
        /* point s_b of scrambling b W H + p (see the header, "Quasi-Monte Carlo") */
        const ulongv qindex = ((to_ulongv(batch) * (ulong)npix + to_ulongv(pixel)) << SOBOL_LOG2_POINTS) |
                              to_ulongv(sn - batch * spb);
        /* the light subpath: point s_b W H + p (the sample's place in its block) of the batch's scrambling b */
        const ulongv lindex = (to_ulongv(batch) << SOBOL_LOG2_POINTS) | (index - to_ulongv(batch) * ((ulong)spb * npix));
        mc_sampler_t cs = sampler_start(seed, qindex, RNG_STREAM_RENDER);
        floatv uc[2];
        bdpt_draw(&cs, BDPT_SIDE_CAMERA, RENDER_DIM_CAMERA, 2, uc);
#else
        const ulongv lindex = index;
        mc_sampler_t cs = sampler_start(seed, index, RNG_STREAM_RENDER);
        floatv uc[2];
        bdpt_film_uniforms(seed, batch, pixel, npix, sn - batch * spb, uc);
#endif
        uintv py = pixel / width;
        /* the film point: filter importance sampling around the pixel (render/pixel_filter.cl) */
        floatv sx = film_coordinate(&sc.cam_set.filter, to_floatv(pixel - py * width), uc[0]);
        floatv sy = film_coordinate(&sc.cam_set.filter, to_floatv(py), uc[1]);
        vec3v co, cd;
        if (thin_lens) {
            floatv ul[2];
            bdpt_draw(&cs, BDPT_SIDE_CAMERA, RENDER_DIM_CAMERA + 2u, 2, ul);
            cd = camera_ray_lens(camera, sx, sy, inv_w, inv_h, ul[0], ul[1], &co);
        } else {
            cd = camera_ray(camera, sx, sy, inv_w, inv_h, &co);
        }
        camera_direction_v cdir = camera_importance(camera, &sc.cam_set, co, cd, width, height);
        cam[0] = lens_vertex(co, forward);
        intv nc = lane_select((intv)(0), (intv)(1), active);
        /* z_0 stays the lens point; the ray leaves from the near clip plane (render/camera.cl) */
        bsdf_sample_v z1_branch; /* the walk's sample at z_1, where it takes one */
        z1_branch.wo = v3s(0.0f);
        z1_branch.weight = v3s(0.0f);
        z1_branch.pdf = (floatv)(0.0f);
        z1_branch.eta = (floatv)(1.0f);
        z1_branch.delta = (intv)(0);
        bdpt_walk(&sc, &cs, cam, cam_b, &nc, active, nc_cap, camera_clip_origin(camera, sc.cam_set, co, cd), cd, v3s(1.0f),
                  cdir.pdf_solid_angle, TRANSPORT_RADIANCE, rr_depth, (floatv)(1.0f), &z1_branch);

        /* ---- the light subpaths ---- */
        mc_sampler_t ls = sampler_start(seed, lindex, RNG_STREAM_LIGHT_TRACE);
        floatv ue[8];
        bdpt_draw(&ls, BDPT_SIDE_LIGHT, LT_DIM_EMIT, 8, ue);
        intv nl = (intv)(0);
        if (nl_cap > 0) {
            emitter_ray_v er = sample_emitter_ray(&lt, bsphere, ue, active);
            const intv started = er.valid;
            light[0].p = er.pos;
            light[0].n = er.n;
            light[0].wi = er.n;
            light[0].beta = v3_scale(er.radiance, 1.0f / er.pdf_area);
            light[0].pdf_fwd = er.pdf_area;
            light[0].pdf_rev = (floatv)(0.0f);
            light[0].light_pdf_area = er.pdf_area;
            light[0].emitter = (intv)(-1);
            light[0].mat = (uintv)(0u);
#ifdef TEXTURES
            light[0].tu = light[0].tv = (floatv)(0.0f);
#endif
            light[0].delta = (intv)(0);
            light[0].delta_light = er.delta;
            light[0].infinite = er.infinite;
            if (lane_any(er.infinite)) {
                /* a direction: its density as light sampling draws it (the disk's area density
                 * pi R^2 taken out of pdf_area; a directional light's pdf_solid_angle is 1) */
                light[0].p = v3_select(light[0].p, v3_sub(er.pos, er.d), er.infinite);
                light[0].pdf_fwd = lane_select(light[0].pdf_fwd,
                                               er.pdf_area * RT_PI * bsphere.w * bsphere.w * er.pdf_solid_angle,
                                               er.infinite);
            }
            vec3v b1 = v3_scale(er.radiance, er.cos_theta / (er.pdf_area * er.pdf_solid_angle));
            nl = lane_select(nl, (intv)(1), started);
            bdpt_walk(&sc, &ls, light, light_b, &nl, started & (v3_maxc(b1) > 0.0f), nl_cap, offset_origin(er.pos, er.n, er.d),
                      er.d, b1, er.pdf_solid_angle, TRANSPORT_IMPORTANCE, rr_depth, v3_maxc(b1), 0);
        }

        /* ---- every strategy, for all lanes at once ---- */
        const rng_t rs = rng_init(index, seed, RNG_STREAM_BDPT_ROULETTE);
        vec3v L = v3s(0.0f);
        /* the lanes whose emission right after z_1 is split over z_1's two delta branches (see the header):
         * the branch the walk did not take now, the one it took at (0, 3) */
        intv split = (intv)(0);
        if (split_on) {
            split = active & (nc >= 2) & !cam[1].infinite & two_branch_delta(&cam_b[1].m) & z1_branch.delta &
                    (z1_branch.pdf > 0.0f);
            if (lane_any(split)) L = split_first_vertex(&sc, cam, &cam_b[1], &z1_branch, split);
        }
        for (int t = 1; lane_any(nc >= t); ++t) {
            const intv has_t = nc >= t;
            /* s = 1 with t >= 2 samples its own light point, so it needs no light subpath */
            const intv ns = t >= 2 ? lane_select(nl, (intv)(1), nl < 1) : nl;
            for (int s = 0; lane_any(has_t & (ns >= s)); ++s) {
                if (s + t < 2 || (max_depth >= 0 && s + t - 1 > max_depth) || !strategy_on(&sc, s, t)) continue;
                /* only (0, t) ends at infinity */
                const intv run = has_t & (ns >= s) & (s > 0 ? !cam[t - 1].infinite : has_t);
                floatv w;
                if (t == 1) {
                    floatv ul[2] = {ue[6], ue[7]};
                    /* a pinhole's lens point takes no uniforms (camera_lens_point): no draw then */
                    if (s > 1 && thin_lens) {
                        bdpt_draw(&ls, BDPT_SIDE_LIGHT, LT_DIM_LENS((uint)(s - 1)), 2, ul);
                    }
                    camera_direction_v film;
                    vec3v c = bdpt_connect_camera(&sc, light, light_b, cam, s, ul[0], ul[1], run, nl_cap, nc_cap, &film, &w);
                    intv got = w > 0.0f;
                    if (lane_any(got))
                        splat_filtered(img, &sc.cam_set.filter, &film, v3_scale(c, strategy_weight(&sc, w)), got, width,
                                       height);
                } else {
                    floatv ul[4] = {(floatv)(0.0f), (floatv)(0.0f), (floatv)(0.0f), (floatv)(0.0f)};
                    if (s == 1) {
                        bdpt_draw(&cs, BDPT_SIDE_CAMERA, RENDER_DIM_LIGHT((uint)(t - 2)), 4, ul);
                    }
                    const floatv threshold = BDPT_ROULETTE_FRACTION * v3_maxc(L);
                    vec3v c = bdpt_connect(&sc, light, light_b, cam, s, t, ul, cam_b, run, nl_cap, nc_cap, &rs, threshold, &w);
                    /* the branch the walk took at z_1, with probability P_b: beta_1 W_b Le_b */
                    if (s == 0 && t == 3 && lane_any(split)) c = v3_select(c, v3_scale(c, z1_branch.pdf), split);
                    L = v3_add(L, v3_select(v3s(0.0f), v3_scale(c, strategy_weight(&sc, w)), w > 0.0f));
                }
            }
        }
        const intv lit = active & !((L.x == 0.0f) & (L.y == 0.0f) & (L.z == 0.0f));
        if (lane_any(lit)) splat(img, pixel, v3_scale(L, sc.pixels), lit);
    }
}
