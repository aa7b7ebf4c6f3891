/* sample_check.cl — the walk's samplers on their own, for goodness-of-fit
 * tests (tests/test_walks_sampling.py): the very functions walk.cl calls, fed
 * with the uniforms of step 0 of walks 0 .. n-1 of query point 0.
 *
 * walk_sample_check: for n samples from the vertex x,
 *   y[i*DIM + k]  the move sampled by walk_transition,  m[i] its multiplier K/p,
 *   q[i]          the survival probability,
 *   z[i*DIM + k]  the next-event point (nee builds; else 0), e[i] its g/p.
 */
#include "walks/walk_rng.cl"
#include "walks/next_event.cl"

kernel void walk_sample_check(uint n, ulong seed, global const float *xs, global const uint *tab,
                              const walk_table_geometry g,
                              global float *ys, global float *ms, global float *qs, global float *zs,
                              global float *es) {
    const uint gid = get_global_id(0);
    if (gid * LANES >= n) return;
    const walk_tables t = walk_tables_at(tab, g);
    const uintv idx = (uintv)(gid * LANES) + LANE_IOTA;
    floatv u[WALK_NUI]; /* the first step's uniforms come first */
    mc_sampler_t smp = sampler_start_at(seed, 0ul, idx, RNG_STREAM_WALK);
    walk_step_uniforms(&smp, (uintv)(0u), u);
    floatv x[DIM], y[DIM], z[DIM], q;
    for (int k = 0; k < DIM; ++k) x[k] = (floatv)(xs[k]);
    floatv m = walk_transition(x, u, y, &q, t);
#if WALK_EST == WALK_EST_NEE
    floatv e = walk_source_sample(u, z, t);
#else
    floatv e = (floatv)(0.0f);
    for (int k = 0; k < DIM; ++k) z[k] = (floatv)(0.0f);
#endif
    float_lanes a;
    for (int k = 0; k < DIM; ++k) {
        a.v = y[k];
        for (int l = 0; l < LANES; ++l) if (gid * LANES + l < n) ys[(gid * LANES + l) * DIM + k] = a.a[l];
        a.v = z[k];
        for (int l = 0; l < LANES; ++l) if (gid * LANES + l < n) zs[(gid * LANES + l) * DIM + k] = a.a[l];
    }
    a.v = m;
    for (int l = 0; l < LANES; ++l) if (gid * LANES + l < n) ms[gid * LANES + l] = a.a[l];
    a.v = q;
    for (int l = 0; l < LANES; ++l) if (gid * LANES + l < n) qs[gid * LANES + l] = a.a[l];
    a.v = e;
    for (int l = 0; l < LANES; ++l) if (gid * LANES + l < n) es[gid * LANES + l] = a.a[l];
}
