/* integrate.cl — the integration estimator: sample indices -> statistics.
 *
 * One work-item computes one block: UNITS_PER_BLOCK consecutive units of one
 * design, LANES units at a time.  A *unit* is what the estimator averages:
 *   independent, nrooks,  one point tuple, value v = unit_value(tau);
 *   sobol                 (sobol: the uniforms come from the Sobol' back end)
 *   vegas                 one point tuple through the VEGAS grid,
 *                         v = unit_value(x) J (sampling/vegas_grid.cl);
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
 * REAL_DOUBLE=1 (precision="double", independent and sobol only): the
 * uniforms come from sampler_next_nd_d (the 2^-32 grid), unit_value and the
 * user's snippets take and return doublev, and the partial sums are double.
 * Sums run in double on 16 *virtual* lanes (unit offset mod 16), whatever the
 * build's LANES, and the virtual lanes are added in order at the end: the
 * numbers of a block depend on its index alone, not on the device's vector
 * width nor on the work-group size.
 */
#include "samplers/sampler.cl"
#include "samplers/refine_zero.cl"
#include "sampling/stratified.cl"
#include "sampling/nrooks.cl"

#define SAMPLER_VEGAS 4
#if SAMPLER == SAMPLER_VEGAS
#include "sampling/vegas_grid.cl"
#endif
#ifndef VEGAS_STRATIFIED
#define VEGAS_STRATIFIED 0 /* 1: vegas iterations in stratified designs (mcocl/integration/vegas.py) */
#endif

#define SAMPLER_INDEPENDENT 0
#define SAMPLER_STRATIFIED 1
#define SAMPLER_NROOKS 2
#define SAMPLER_SOBOL 3 /* as independent; the uniforms come from the Sobol' back end */

#ifndef REAL_DOUBLE
#define REAL_DOUBLE 0
#endif
#if REAL_DOUBLE
#if SAMPLER != SAMPLER_INDEPENDENT && SAMPLER != SAMPLER_SOBOL
#error "REAL_DOUBLE: only the independent and sobol samplers evaluate in double"
#endif
/* the value type of a unit; a doublev select takes a longv mask */
typedef doublev realv;
#define REAL_MASK(m) to_longv(m)
#define REAL_ABS(v) fabs(v)
#define SAMPLER_NEXT_ND sampler_next_nd_d
#define REFINE_FIRST_CELLS refine_first_cells_d
MC_INLINE intv real_finite(doublev x) {
    return to_intv((lane_as_long(x) & 0x7ff0000000000000L) != 0x7ff0000000000000L);
}
#else
typedef floatv realv;
#define REAL_MASK(m) (m)
#define REAL_ABS(v) lane_abs(v)
#define SAMPLER_NEXT_ND sampler_next_nd
#define REFINE_FIRST_CELLS refine_first_cells
#define real_finite lane_finite
#endif

#define NCOORD (POINTS * DIM)
#if SAMPLER == SAMPLER_SOBOL
/* what the packets of a block share (one replicate) */
#include "samplers/sobol_block.cl"
#if REAL_DOUBLE
#define SOBOL_BLOCK_UNIFORMS sobol_block_uniforms_d
#else
#define SOBOL_BLOCK_UNIFORMS sobol_block_uniforms
#endif
#endif
#define STATS 6
#define VLANES 16
#define NACC (VLANES / LANES)

/* Sum of the 16 virtual lanes held in NACC lane vectors, in virtual-lane order. */
MC_INLINE double vlane_sum(const doublev *acc) {
    double s = 0.0;
    for (int a = 0; a < NACC; ++a) s += lane_sum_d(acc[a]);
    return s;
}

/* Uniform coordinates (dimensions 0 .. NCOORD-1) of the packet of samples
* base + stride * lane, with full resolution near 0 (samplers/refine_zero.cl). */
MC_INLINE void sample_uniforms(ulong base, uint stride, ulong seed, realv *u) {
    mc_sampler_t s = sampler_start_at(seed, base, stride * LANE_IOTA, RNG_STREAM_SAMPLE);
    SAMPLER_NEXT_ND(&s, NCOORD, u);
    REFINE_FIRST_CELLS(u, NCOORD, rng_init_offset(base, stride * LANE_IOTA, seed, RNG_STREAM_REFINE));
}

/* Float partial sums are flushed into the double accumulators every FLUSH
 * groups of 16 units: a float sum of at most 64 terms per lane loses nothing
 * that matters, and float lanes are twice as wide as double ones
 * (docs/pocl-notes.md: "accumulating in float was fine up to 4096").
 *
 * Finite samples can still overflow a float partial (a square above 3.4e38,
 * a sum of samples near FLT_MAX; issue 10: `x[0] < 0.5f ? 3e38f : -3e38f`
 * gave NaN).  Non-finite samples never enter the sums, and a double sum of
 * float terms cannot overflow, so a block whose double sums end non-finite
 * had a float partial overflow: its units are then evaluated again (the same
 * uniforms, so the same samples) with every term added in double.  The check
 * costs nothing per sample (a test inside the loop cost 6% of the
 * throughput); ordinary integrands never take that path, and their sums stay
 * bit-identical to the float-only ones. */
#define FLUSH 4

/* The values of the LANES units k .. k+LANES-1 of the block (unit k of the
 * block is unit unit0 + k of its design): v[0] (and v[1], the second sample
 * of a stratum, for stratified designs), zero where a lane is past nunits or
 * not finite, and the lanes that are valid and finite (*ok) and those that
 * are valid but not finite (*bad, one count per non-finite sample).  The
 * VEGAS bins of the samples go to vbin for training. */
#if SAMPLER == SAMPLER_STRATIFIED || VEGAS_STRATIFIED
#define UNIT_SAMPLES 2
#else
#define UNIT_SAMPLES 1
#endif
MC_INLINE void unit_values(uint k, uint nunits, ulong unit0, ulong design_base, ulong seed,
                           global const uint *tables,
#if SAMPLER == SAMPLER_NROOKS
                           const perm_key *keys,
#endif
#if SAMPLER == SAMPLER_SOBOL
                           const sobol_block_t *sobol_block,
#endif
#if SAMPLER == SAMPLER_VEGAS
                           global const float *vegas_grid, uintv vbin[UNIT_SAMPLES][DIM],
#endif
                           realv *v, intv *ok, uintv *bad) {
#if SAMPLER != SAMPLER_INDEPENDENT
    const uintv in_design = (uintv)((uint)(unit0 + k)) + LANE_IOTA;
#endif
    const intv valid = (uintv)(k) + LANE_IOTA < (uintv)(nunits);
    const ulong ubase = design_base + unit0 + k;
    realv tau[NCOORD];
#if SAMPLER == SAMPLER_STRATIFIED || VEGAS_STRATIFIED
    /* two samples (indices 2 unit, 2 unit + 1) in stratum `in_design` */
    doublev cell[DIM];
    stratum_cells(in_design, DIM, (double)STRATA_M, 1.0 / (double)STRATA_M, cell);
    floatv v2[2];
    for (int t = 0; t < 2; ++t) {
        sample_uniforms(2ul * ubase + (ulong)t, 2u, seed, tau);
        for (uint a = 0; a < NCOORD; ++a)
            tau[a] = cell_to_unit(cell[a % DIM], tau[a], (double)STRATA_M, 1.0 / (double)STRATA_M);
#if VEGAS_STRATIFIED
        const floatv vjac = vegas_warp(tau, vegas_grid, vbin[t]);
        v2[t] = unit_value(tau, tables) * vjac;
#else
        v2[t] = unit_value(tau, tables);
#endif
    }
    const intv fin0 = lane_finite(v2[0]), fin1 = lane_finite(v2[1]);
    *ok = valid & fin0 & fin1;
    *bad = to_uintv(mask_bit(valid & !fin0)) + to_uintv(mask_bit(valid & !fin1));
    v[0] = lane_select((floatv)(0.0f), v2[0], *ok);
    v[1] = lane_select((floatv)(0.0f), v2[1], *ok);
#else
#if SAMPLER == SAMPLER_SOBOL
    /* sample_uniforms' numbers, from the block's shared part (samplers/sobol_block.cl) */
    SOBOL_BLOCK_UNIFORMS(sobol_block, k, tau);
    REFINE_FIRST_CELLS(tau, NCOORD, rng_init_offset(ubase, LANE_IOTA, seed, RNG_STREAM_REFINE));
#else
    sample_uniforms(ubase, 1u, seed, tau);
#endif
#if SAMPLER == SAMPLER_NROOKS
    for (uint a = 0; a < NCOORD; ++a) {
        uintv cell = nrooks_permute(in_design, DESIGN_UNITS, NROOKS_MASK, NROOKS_S1, NROOKS_S2, keys[a]);
        tau[a] = cell_to_unit(to_doublev(cell), tau[a], (double)DESIGN_UNITS, 1.0 / (double)DESIGN_UNITS);
    }
#endif
#if SAMPLER == SAMPLER_VEGAS
    const floatv vjac = vegas_warp(tau, vegas_grid, vbin[0]);
    const floatv u = unit_value(tau, tables) * vjac;
#else
    const realv u = unit_value(tau, tables);
#endif
    const intv fin = real_finite(u);
    *ok = valid & fin;
    *bad = to_uintv(mask_bit(valid & !fin));
    v[0] = lane_select((realv)(0.0f), u, REAL_MASK(*ok));
#endif
}

#if SAMPLER == SAMPLER_NROOKS
#define UNIT_KEYS keys,
#elif SAMPLER == SAMPLER_SOBOL
#define UNIT_KEYS &sobol_block,
#else
#define UNIT_KEYS
#endif
#if SAMPLER == SAMPLER_VEGAS
#define UNIT_VEGAS vegas_grid, vbin,
#else
#define UNIT_VEGAS
#endif

kernel void integrate_blocks(ulong first_block, ulong nblocks, ulong unit_limit, ulong seed, double shift,
                             global const uint *tables, global double *out
#if SAMPLER == SAMPLER_VEGAS
                             /* the grid and one training row per block (sampling/vegas_grid.cl) */
                             , global const float *vegas_grid, global double *vegas_train
#endif
                             ) {
    if (get_global_id(0) >= nblocks) return;
    const ulong b = first_block + get_global_id(0);
    const ulong design = b / (ulong)BLOCKS_PER_DESIGN;
    const ulong unit0 = (b - design * (ulong)BLOCKS_PER_DESIGN) * (ulong)UNITS_PER_BLOCK;
    const ulong limit = min(unit_limit, (ulong)DESIGN_UNITS);
    const uint nunits = (uint)min((ulong)UNITS_PER_BLOCK, limit > unit0 ? limit - unit0 : 0ul);
    const ulong design_base = design * (ulong)DESIGN_UNITS;

    /* partial sums f* in the value type (float, or double under REAL_DOUBLE) */
    doublev s1[NACC], s2[NACC], npairs[NACC], sabs[NACC];
    realv f1[NACC], f2[NACC], fabsv[NACC];
    floatv fpairs[NACC];
    for (int a = 0; a < NACC; ++a) {
        s1[a] = (doublev)(0.0); s2[a] = (doublev)(0.0); npairs[a] = (doublev)(0.0); sabs[a] = (doublev)(0.0);
        f1[a] = (realv)(0.0f); f2[a] = (realv)(0.0f); fpairs[a] = (floatv)(0.0f); fabsv[a] = (realv)(0.0f);
    }
    uintv nvalid = (uintv)(0u), nbad = (uintv)(0u);
    const float fshift = (float)shift; /* the host rounds the shift to float */
    const double dshift = (double)fshift;

#if SAMPLER == SAMPLER_VEGAS
    global double *train_row = vegas_train + get_global_id(0) * (ulong)VEGAS_ROW;
    vegas_train_clear(train_row);
#endif
#if SAMPLER == SAMPLER_NROOKS
    perm_key keys[NCOORD];
    for (uint a = 0; a < NCOORD; ++a) keys[a] = nrooks_key(seed, design, a);
#endif
#if SAMPLER == SAMPLER_SOBOL
    sobol_block_t sobol_block;
    sobol_block_init(&sobol_block, seed, design, unit0);
#endif

    /* k runs over units in steps of LANES; the inner loop over the NACC lane
     * vectors of one group of 16 virtual lanes is unrolled so that every
     * accumulator index is a compile-time constant (a run-time index would
     * force the accumulators out of registers into memory). */
    for (uint k0 = 0; k0 < nunits; k0 += VLANES) {
#pragma unroll
        for (int acc = 0; acc < NACC; ++acc) {
            const uint k = k0 + (uint)acc * LANES;
            if (k >= nunits) break;
            realv v[UNIT_SAMPLES];
            intv ok;
            uintv bad;
#if SAMPLER == SAMPLER_VEGAS
            uintv vbin[UNIT_SAMPLES][DIM];
#endif
            unit_values(k, nunits, unit0, design_base, seed, tables, UNIT_KEYS UNIT_VEGAS v, &ok, &bad);
            nbad += bad;
#if UNIT_SAMPLES == 2
            const floatv okf = lane_select((floatv)(0.0f), (floatv)(1.0f), ok);
            f1[acc] += (v[0] - fshift + v[1] - fshift) * okf;
            f2[acc] += (v[0] - v[1]) * (v[0] - v[1]);
            fabsv[acc] += lane_abs(v[0]) + lane_abs(v[1]);
            fpairs[acc] += okf;
            nvalid += 2u * to_uintv(mask_bit(ok));
#if VEGAS_STRATIFIED
            vegas_train_add_pair(train_row, vbin[0], v[0], vbin[1], v[1]);
#endif
#else
            const realv d = lane_select((realv)(0.0f), v[0] - fshift, REAL_MASK(ok));
            f1[acc] += d;
            f2[acc] += d * d;
            fabsv[acc] += REAL_ABS(v[0]);
            nvalid += to_uintv(mask_bit(ok));
#if SAMPLER == SAMPLER_VEGAS
            vegas_train_add(train_row, vbin[0], v[0]);
#endif
#endif
        }
        if ((k0 / VLANES) % FLUSH == FLUSH - 1 || k0 + VLANES >= nunits) {
            for (int a = 0; a < NACC; ++a) {
                s1[a] += to_doublev(f1[a]); s2[a] += to_doublev(f2[a]);
                npairs[a] += to_doublev(fpairs[a]); sabs[a] += to_doublev(fabsv[a]);
                f1[a] = (realv)(0.0f); f2[a] = (realv)(0.0f); fpairs[a] = (floatv)(0.0f); fabsv[a] = (realv)(0.0f);
            }
        }
    }
    double t1 = vlane_sum(s1), t2 = vlane_sum(s2), tabs = vlane_sum(sabs);
    if (!isfinite(t1) || !isfinite(t2) || !isfinite(tabs)) {
        /* a float partial overflowed (an overflow stays non-finite in the double
         * sums): the block again, every term added in double (see FLUSH) */
        for (int a = 0; a < NACC; ++a) {
            s1[a] = (doublev)(0.0); s2[a] = (doublev)(0.0); npairs[a] = (doublev)(0.0); sabs[a] = (doublev)(0.0);
        }
        for (uint k0 = 0; k0 < nunits; k0 += VLANES) {
#pragma unroll
            for (int acc = 0; acc < NACC; ++acc) {
                const uint k = k0 + (uint)acc * LANES;
                if (k >= nunits) break;
                realv v[UNIT_SAMPLES];
                intv ok;
                uintv bad;
#if SAMPLER == SAMPLER_VEGAS
                uintv vbin[UNIT_SAMPLES][DIM];
#endif
                unit_values(k, nunits, unit0, design_base, seed, tables, UNIT_KEYS UNIT_VEGAS v, &ok, &bad);
                const doublev okd = to_doublev(lane_select((floatv)(0.0f), (floatv)(1.0f), ok));
                const doublev d0 = to_doublev(v[0]);
                /* products in statements of their own: a product and a sum in one
                 * statement may be fused (FP_CONTRACT) for some vector widths
                 * and not others, and the sums must not depend on the width */
#if UNIT_SAMPLES == 2
                const doublev d1 = to_doublev(v[1]);
                const doublev d = (d0 - dshift + d1 - dshift) * okd, e = d0 - d1;
                const doublev ee = e * e;
                s1[acc] += d;
                s2[acc] += ee;
                sabs[acc] += fabs(d0) + fabs(d1);
                npairs[acc] += okd;
#else
                const doublev d = (d0 - dshift) * okd;
                const doublev dd = d * d;
                s1[acc] += d;
                s2[acc] += dd;
                sabs[acc] += fabs(d0);
#endif
            }
        }
        t1 = vlane_sum(s1); t2 = vlane_sum(s2); tabs = vlane_sum(sabs);
    }
    global double *o = out + get_global_id(0) * STATS;
    o[0] = (double)lane_sum_u(nvalid);
    o[1] = (double)lane_sum_u(nbad);
    o[2] = t1;
    o[3] = t2;
    o[4] = vlane_sum(npairs);
    o[5] = tabs;
}
