/* integrate.cl — the integration estimator: sample indices -> statistics.
 *
 * One work-item computes one block: UNITS_PER_BLOCK consecutive units of one
 * design, LANES units at a time.  A *unit* is what the estimator averages:
 *   independent, nrooks   one point tuple, value v = unit_value(tau);
 *   stratified            one stratum holding two point tuples (see
 *                         sampling/stratified.cl), values v1, v2.
 * A point tuple is POINTS points of DIM coordinates (POINTS > 1 for combined
 * estimators: one point per sample of each technique).
 *
 * The generated part of the program (mcocl/integrate/codegen.py) defines
 *   DIM, POINTS, SAMPLER, DESIGN_UNITS, UNITS_PER_BLOCK, BLOCKS_PER_DESIGN,
 *   STRATA_M (stratified), NROOKS_MASK/S1/S2 (nrooks) and
 *   floatv unit_value(floatv *tau, global const uint *tables)
 * which warps the uniforms tau[POINTS*DIM] and returns the primary estimate.
 *
 * Output, per block, STATS doubles:
 *   [0] valid finite samples   [1] non-finite samples (kept out of the sums)
 *   [2] sum (v - shift)        [3] sum (v - shift)^2   [4] 0     (independent, nrooks)
 *                              [3] sum (v1 - v2)^2     [4] pairs (stratified)
 *   [5] sum |v| (the scale of float rounding in v, see job.py)
 * Sums run in double on 16 *virtual* lanes (unit offset mod 16), whatever the
 * build's LANES, and the virtual lanes are added in order at the end: the
 * numbers of a block depend on its index alone, not on the device's vector
 * width nor on the work-group size.
 */
#include "rng/uniform.cl"
#include "sampling/stratified.cl"
#include "sampling/nrooks.cl"

#define SAMPLER_INDEPENDENT 0
#define SAMPLER_STRATIFIED 1
#define SAMPLER_NROOKS 2

#define NCOORD (POINTS * DIM)
#define STATS 6
#define VLANES 16
#define NACC (VLANES / LANES)

/* Sum of the 16 virtual lanes held in NACC lane vectors, in virtual-lane order. */
inline double vlane_sum(const doublev *acc) {
    double s = 0.0;
    for (int a = 0; a < NACC; ++a) s += lane_sum_d(acc[a]);
    return s;
}

/* Uniform coordinates of sample `index`: dimensions 0 .. NCOORD-1. */
inline void sample_uniforms(ulongv index, ulong seed, floatv *u) {
    rng_t r = rng_init(index, seed, RNG_STREAM_SAMPLE);
    rng_uniforms(r, 0u, NCOORD, u);
}

kernel void integrate_blocks(ulong first_block, ulong nblocks, ulong unit_limit, ulong seed, double shift,
                             global const uint *tables, global double *out) {
    if (get_global_id(0) >= nblocks) return;
    const ulong b = first_block + get_global_id(0);
    const ulong design = b / (ulong)BLOCKS_PER_DESIGN;
    const ulong unit0 = (b - design * (ulong)BLOCKS_PER_DESIGN) * (ulong)UNITS_PER_BLOCK;
    const ulong limit = min(unit_limit, (ulong)DESIGN_UNITS);
    const uint nunits = (uint)min((ulong)UNITS_PER_BLOCK, limit > unit0 ? limit - unit0 : 0ul);
    const ulong design_base = design * (ulong)DESIGN_UNITS;

    doublev s1[NACC], s2[NACC], npairs[NACC], sabs[NACC];
    for (int a = 0; a < NACC; ++a) {
        s1[a] = (doublev)(0.0); s2[a] = (doublev)(0.0); npairs[a] = (doublev)(0.0); sabs[a] = (doublev)(0.0);
    }
    uintv nvalid = (uintv)(0u), nbad = (uintv)(0u);

#if SAMPLER == SAMPLER_NROOKS
    perm_key keys[NCOORD];
    for (uint a = 0; a < NCOORD; ++a) keys[a] = nrooks_key(seed, design, a);
#endif

    for (uint k = 0; k < nunits; k += LANES) {
        const int acc = (int)((k / LANES) % NACC);
        uintv in_design = to_uintv((ulongv)(unit0 + k) + to_ulongv(LANE_IOTA));
        intv valid = (uintv)(k) + LANE_IOTA < (uintv)(nunits);
        ulongv unit = (ulongv)(design_base + unit0 + k) + to_ulongv(LANE_IOTA);
        floatv tau[NCOORD];
#if SAMPLER == SAMPLER_STRATIFIED
        /* two samples (indices 2 unit, 2 unit + 1) in stratum `in_design` */
        doublev cell[DIM];
        stratum_cells(in_design, DIM, (double)STRATA_M, 1.0 / (double)STRATA_M, cell);
        floatv v2[2];
        for (int t = 0; t < 2; ++t) {
            sample_uniforms(2ul * unit + (ulong)t, seed, tau);
            for (uint a = 0; a < NCOORD; ++a)
                tau[a] = cell_to_unit(cell[a % DIM], tau[a], 1.0 / (double)STRATA_M);
            v2[t] = unit_value(tau, tables);
        }
        intv fin0 = isfinite(v2[0]), fin1 = isfinite(v2[1]);
        intv ok = valid & fin0 & fin1;
        nbad += to_uintv(mask_bit(valid & !fin0)) + to_uintv(mask_bit(valid & !fin1));
        doublev okd = to_doublev(mask_bit(ok));
        doublev d0 = to_doublev(select((floatv)(0.0f), v2[0], ok)) - shift;
        doublev d1 = to_doublev(select((floatv)(0.0f), v2[1], ok)) - shift;
        s1[acc] += (d0 + d1) * okd;
        sabs[acc] += to_doublev(fabs(select((floatv)(0.0f), v2[0], ok)) + fabs(select((floatv)(0.0f), v2[1], ok)));
        s2[acc] += (d0 - d1) * (d0 - d1) * okd;
        npairs[acc] += okd;
        nvalid += 2u * to_uintv(mask_bit(ok));
#else
        sample_uniforms(unit, seed, tau);
#if SAMPLER == SAMPLER_NROOKS
        for (uint a = 0; a < NCOORD; ++a) {
            uintv cell = nrooks_permute(in_design, DESIGN_UNITS, NROOKS_MASK, NROOKS_S1, NROOKS_S2, keys[a]);
            tau[a] = cell_to_unit(to_doublev(cell), tau[a], 1.0 / (double)DESIGN_UNITS);
        }
#endif
        floatv v = unit_value(tau, tables);
        intv ok = valid & isfinite(v);
        nbad += to_uintv(mask_bit(valid & !isfinite(v)));
        doublev okd = to_doublev(mask_bit(ok));
        doublev d = (to_doublev(select((floatv)(0.0f), v, ok)) - shift) * okd;
        s1[acc] += d;
        s2[acc] += d * d;
        sabs[acc] += to_doublev(fabs(select((floatv)(0.0f), v, ok)));
        nvalid += to_uintv(mask_bit(ok));
#endif
    }
    global double *o = out + get_global_id(0) * STATS;
    o[0] = (double)lane_sum_u(nvalid);
    o[1] = (double)lane_sum_u(nbad);
    o[2] = vlane_sum(s1);
    o[3] = vlane_sum(s2);
    o[4] = vlane_sum(npairs);
    o[5] = vlane_sum(sabs);
}
