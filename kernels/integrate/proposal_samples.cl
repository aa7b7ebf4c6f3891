/* proposal_samples.cl — draw points from a proposal exactly as the estimator
 * does (same uniforms, same warp), and report the pdf the warp returned and
 * the pdf re-evaluated at the point.  Used by mcocl.integration.sample_proposal
 * (goodness-of-fit tests, users inspecting a proposal).  Needs DIM and the
 * generated warp_t0 / pdf_t0. */
#include "samplers/sampler.cl"

kernel void proposal_samples(ulong n, ulong seed, global const uint *tables,
                             global float *xs, global float *pdf_warp, global float *pdf_eval) {
    const ulong i0 = get_global_id(0) * (ulong)LANES;
    if (i0 >= n) return;
    ulongv idx = (ulongv)(i0) + to_ulongv(LANE_IOTA);
    mc_sampler_t s = sampler_start(seed, idx, RNG_STREAM_SAMPLE);
    floatv u[DIM], x[DIM];
    sampler_next_nd(&s, DIM, u);
    floatv p = warp_t0(u, x, tables);
    floatv q = pdf_t0(x, tables);
    /* float_lanes (lane_ops.cl) reads the lanes in every build, the scalar one included */
    float_lanes ps = {.v = p}, qs = {.v = q};
    for (int l = 0; l < LANES && i0 + l < n; ++l) {
        pdf_warp[i0 + l] = ps.a[l];
        pdf_eval[i0 + l] = qs.a[l];
    }
    for (int j = 0; j < DIM; ++j) {
        float_lanes xj = {.v = x[j]};
        for (int l = 0; l < LANES && i0 + l < n; ++l) xs[(i0 + l) * DIM + j] = xj.a[l];
    }
}
