/* walk_rng.cl — the random numbers of one random-walk step.
 *
 * A step uses WALK_NU uniforms.  When they fit in a Philox block several
 * times (WALK_SPB = 4 / WALK_NU steps per block: 4 for a 1-D truncated walk,
 * 2 for 1-D roulette), one block serves WALK_SPB consecutive steps; walk.cl
 * then makes those steps in one iteration.  Addressing (samplers/sampler.cl,
 * stream RNG_STREAM_WALK + q for query point q, rng/streams.cl): walk w is
 * sample w, and iteration i (steps WALK_SPB i .. WALK_SPB i + WALK_SPB - 1)
 * draws dimensions WALK_DIMS_PER_ITER i .. in order, step after step, i.e.
 * with the Philox back end
 *     Philox4x32-10( counter = (lo32(w), hi32(w), i * WALK_BPS + b, RNG_STREAM_WALK + q),
 *                    key     = (lo32(seed), hi32(seed)) )        b = 0 .. WALK_BPS-1,
 * so a walk's numbers depend on (seed, q, w, step) alone: not on the lane or
 * the work-item that runs it, nor on when the lane picked the walk up.  Lanes
 * of a packet are at different steps: the dimension counter is per lane.
 * Dimensions are 32-bit words, so they wrap after 2^30 / WALK_BPS
 * iterations (over 10^9 moves; max_walk_length allows up to 2^31 - 1).
 */
#ifndef MCOCL_WALK_RNG_CL
#define MCOCL_WALK_RNG_CL

#include "samplers/sampler.cl"

#define WALK_SPB (WALK_NU <= 4 ? 4 / WALK_NU : 1) /* steps per iteration */
#define WALK_NUI (WALK_SPB * WALK_NU)             /* uniforms per iteration */
#define WALK_DIMS_PER_ITER (4u * (uint)WALK_BPS)  /* whole blocks: iterations start on a block */

/* u[0 .. WALK_NUI - 1]: the uniforms of iteration `it` (steps WALK_SPB it ..)
 * of the walks of sampler s. */
MC_INLINE void walk_step_uniforms(mc_sampler_t *s, uintv it, floatv *u) {
    sampler_seek(s, it * WALK_DIMS_PER_ITER);
    sampler_next_nd(s, WALK_NUI, u);
}

#endif
