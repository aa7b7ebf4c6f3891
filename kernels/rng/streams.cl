/* streams.cl — the registry of random-number streams: which consumer draws
 * from which Philox stream tag (counter word 3, rng/uniform.cl), and how the
 * dimensions of a stream are laid out where several consumers share one.
 *
 * Two consumers in the same program must never share a (stream, dimension)
 * pair, or their numbers would be correlated.  Programs are built separately,
 * so the walks' stream and the renderer's may use the same tag.  The host
 * mirrors the tags it exposes in mcocl/rng.py (STREAM_*).
 */
#ifndef MCOCL_RNG_STREAMS_CL
#define MCOCL_RNG_STREAMS_CL

/* ---- integration (integrate/integrate.cl, sampling/design_points.cl) ---- */
/* A sample's coordinates: dimension POINTS*DIM..., i.e. every technique's
 * point, then the generated estimator's proposal-choice and roulette dims
 * (mcocl/integration/codegen.py), all from one sample index. */
#define RNG_STREAM_SAMPLE 0u
#define RNG_STREAM_JITTER 1u      /* reserved for stratum jitter (mcocl.rng.STREAM_JITTER) */
#define RNG_STREAM_AUX 2u         /* reserved for auxiliary choices (mcocl.rng.STREAM_AUX) */
/* N-rooks permutation keys: "sample" = design index, dimension 4 * axis
 * (one Philox block of four round keys per axis; sampling/nrooks.cl). */
#define RNG_STREAM_PERMUTATION 3u
/* Refinement of uniforms in the first grid cell (samplers/refine_zero.cl):
 * "sample" = the sample's index in RNG_STREAM_SAMPLE, dimension 4 * coordinate. */
#define RNG_STREAM_REFINE 4u
/* The random linear scrambling of sampler="sobol" integration
 * (samplers/sobol_block.cl): "sample" = replicate index, dimension
 * 4 * (8 * coordinate + t), t < 8 (32 words per coordinate). */
#define RNG_STREAM_SOBOL_SCRAMBLE 5u

/* ---- random walks (walks/walk.cl) ---- */
/* Walk moves and roulette of query point q: stream RNG_STREAM_WALK + q,
 * "sample" = walk index, dimensions 4 * WALK_BPS per iteration of WALK_SPB
 * steps (walks/walk_rng.cl). */
#define RNG_STREAM_WALK 8u

/* ---- path tracing (render/integrator.cl) ---- */
/* Sample (pixel, s) has index s * W * H + pixel.  Dimensions: */
#define RNG_STREAM_RENDER 8u
#define RENDER_DIM_CAMERA 0u                    /* pixel jitter x, y; lens point 2D (block 0) */
#define RENDER_DIM_BSDF(depth) (4u + 8u * (depth))  /* lobe, direction 2D, roulette */
#define RENDER_DIM_LIGHT(depth) (8u + 8u * (depth)) /* environment or area, which light, position 2D */

/* ---- light tracing (render/lt.cl) ---- */
/* Light path i (i = s * W * H + k for the k-th path of "sample" s, as the
 * camera samples of path tracing are counted) has index i.  Dimensions: */
#define RNG_STREAM_LIGHT_TRACE 11u
#define LT_DIM_EMIT 0u /* environment or area, which light, position 2D, direction 2D, lens point 2D */
#define LT_DIM_BSDF(depth) (8u + 8u * (depth))  /* lobe, direction 2D, roulette at light vertex `depth` */
#define LT_DIM_LENS(depth) (12u + 8u * (depth)) /* the lens point of light vertex `depth`'s connection */
/* bdpt's Russian roulette on connection shadow rays (render/bdpt.cl): "sample" = the sample's index,
 * one dimension per strategy (s, t) */
#define RNG_STREAM_BDPT_ROULETTE 12u
/* The Owen scramblings of bdpt's film positions (render/bdpt.cl): "sample" = the scrambling's index
 * b W H + pixel (batch b), dimension 0 and 1 the seeds of the film's x and y */
#define RNG_STREAM_BDPT_FILM 13u

/* ---- sampling tests (render/bsdf_sample_test.cl, render/light_sample_test.cl) ---- */
#define RNG_STREAM_BSDF_TEST 9u
#define RNG_STREAM_LIGHT_TEST 10u

#endif
