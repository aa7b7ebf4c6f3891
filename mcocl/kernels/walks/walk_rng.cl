/* walk_rng.cl — the random numbers of one random-walk step.
 *
 * Addressing (the engine's Philox convention, rng/uniform.cl, with a
 * per-lane block word): the uniforms of step n of walk w for query point q are
 *     Philox4x32-10( counter = (lo32(w), hi32(w), n * WALK_BPS + b, WALK_STREAM + q),
 *                    key     = (lo32(seed), hi32(seed)) )        b = 0 .. WALK_BPS-1
 * so a walk's numbers depend on (seed, q, w, n) alone: not on the lane or the
 * work-item that runs it, nor on when the lane picked the walk up.  Lanes of a
 * packet are at different steps (a lane that finishes a walk starts the next
 * one, walk.cl), hence the block word is a vector here, unlike rng_block().
 *
 * WALK_STREAM (8) keeps these numbers apart from the stream tags 0..7 that
 * other families use; query q uses stream 8 + q.
 */
#ifndef MCOCL_WALK_RNG_CL
#define MCOCL_WALK_RNG_CL

#include "rng/uniform.cl"

#define WALK_STREAM 8u

/* u[0 .. WALK_NU-1]: the uniforms of step `n` of walks `w_lo`/`w_hi`. */
inline __attribute__((always_inline)) void walk_step_uniforms(uintv w_lo, uintv w_hi, uintv n, uint k0, uint k1,
                                                               uint stream, floatv *u) {
    for (int b = 0; b < WALK_BPS; ++b) {
        philox_ctr c;
        c.v0 = w_lo;
        c.v1 = w_hi;
        c.v2 = n * (uint)WALK_BPS + (uint)b;
        c.v3 = (uintv)(stream);
        philox_ctr r = philox4x32_10(c, k0, k1);
        if (4 * b + 0 < WALK_NU) u[4 * b + 0] = u01(r.v0);
        if (4 * b + 1 < WALK_NU) u[4 * b + 1] = u01(r.v1);
        if (4 * b + 2 < WALK_NU) u[4 * b + 2] = u01(r.v2);
        if (4 * b + 3 < WALK_NU) u[4 * b + 3] = u01(r.v3);
    }
}

#endif
