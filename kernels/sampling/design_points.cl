/* design_points.cl — the points of one stratified or N-rooks design, exactly
 * as integrate.cl places them (same Philox addressing, same permutations).
 * For inspection and tests; built with LANES=1.  Needs DIM. */
#include "samplers/sampler.cl"
#include "samplers/refine_zero.cl"
#include "sampling/stratified.cl"
#include "sampling/nrooks.cl"

/* Point i of N-rooks design `design` of n points: out[i * DIM + j]. */
kernel void nrooks_points(uint n, ulong design, ulong seed, global float *out) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    uint mask = 0u;
    while (mask < n - 1u) mask = (mask << 1) | 1u;
    uint w = popcount(mask);
    uint s1 = max(1u, w / 2u), s2 = max(1u, (w + 2u) / 3u);
    float u[DIM];
    mc_sampler_t s = sampler_start(seed, design * (ulong)n + i, RNG_STREAM_SAMPLE);
    sampler_next_nd(&s, DIM, u);
    refine_first_cells(u, DIM, rng_init(design * (ulong)n + i, seed, RNG_STREAM_REFINE));
    for (uint a = 0; a < DIM; ++a) {
        uint cell = nrooks_permute(i, n, mask, s1, s2, nrooks_key(seed, design, a));
        out[i * DIM + a] = cell_to_unit((double)cell, u[a], (double)n, 1.0 / (double)n);
    }
}

/* The two samples of stratum h of a stratified design of m^DIM strata:
 * out[(2h + t) * DIM + j]. */
kernel void stratified_points(uint m, uint strata, ulong design, ulong seed, global float *out) {
    const uint h = get_global_id(0);
    if (h >= strata) return;
    double cell[DIM];
    stratum_cells(h, DIM, (double)m, 1.0 / (double)m, cell);
    for (uint t = 0; t < 2; ++t) {
        float u[DIM];
        const ulong index = 2ul * (design * (ulong)strata + h) + t;
        mc_sampler_t s = sampler_start(seed, index, RNG_STREAM_SAMPLE);
        sampler_next_nd(&s, DIM, u);
        refine_first_cells(u, DIM, rng_init(index, seed, RNG_STREAM_REFINE));
        for (uint a = 0; a < DIM; ++a) out[(2 * h + t) * DIM + a] = cell_to_unit(cell[a], u[a], (double)m, 1.0 / (double)m);
    }
}
