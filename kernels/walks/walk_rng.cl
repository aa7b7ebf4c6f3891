/* walk_rng.cl — the random numbers of one random-walk step.
 *
 * A step uses WALK_NU uniforms.  When they fit in a Philox block several
 * times (WALK_SPB = 4 / WALK_NU steps per block: 4 for a 1-D truncated walk,
 * 2 for 1-D roulette), one block serves WALK_SPB consecutive steps; walk.cl
 * then makes those steps in one iteration.  Addressing (the engine's Philox
 * convention, rng/uniform.cl, with a per-lane block word): the uniforms of
 * steps WALK_SPB i .. WALK_SPB i + WALK_SPB - 1 of walk w for query point q are
 *     Philox4x32-10( counter = (lo32(w), hi32(w), i * WALK_BPS + b, WALK_STREAM + q),
 *                    key     = (lo32(seed), hi32(seed)) )        b = 0 .. WALK_BPS-1
 * (words in order, step after step), so a walk's numbers depend on
 * (seed, q, w, step) alone: not on the lane or the work-item that runs it,
 * nor on when the lane picked the walk up.  Lanes of a packet are at
 * different steps, hence the block word is a vector here, unlike rng_block().
 *
 * WALK_STREAM (8) keeps these numbers apart from the stream tags 0..7 that
 * other families use; query q uses stream 8 + q.
 */
#ifndef MCOCL_WALK_RNG_CL
#define MCOCL_WALK_RNG_CL

#include "rng/uniform.cl"

#define WALK_STREAM 8u
#define WALK_SPB (WALK_NU <= 4 ? 4 / WALK_NU : 1) /* steps per iteration */
#define WALK_NUI (WALK_SPB * WALK_NU)             /* uniforms per iteration */

/* u[0 .. WALK_SPB * WALK_NU - 1]: the uniforms of iteration `it` (steps
 * WALK_SPB it ..) of walks `w_lo`/`w_hi`. */
inline __attribute__((always_inline)) void walk_step_uniforms(uintv w_lo, uintv w_hi, uintv it, uint k0, uint k1,
                                                               uint stream, floatv *u) {
    for (int b = 0; b < WALK_BPS; ++b) {
        philox_ctr c;
        c.v0 = w_lo;
        c.v1 = w_hi;
        c.v2 = it * (uint)WALK_BPS + (uint)b;
        c.v3 = (uintv)(stream);
        philox_ctr r = philox4x32_10(c, k0, k1);
        if (4 * b + 0 < WALK_NUI) u[4 * b + 0] = u01(r.v0);
        if (4 * b + 1 < WALK_NUI) u[4 * b + 1] = u01(r.v1);
        if (4 * b + 2 < WALK_NUI) u[4 * b + 2] = u01(r.v2);
        if (4 * b + 3 < WALK_NUI) u[4 * b + 3] = u01(r.v3);
    }
}

#endif
