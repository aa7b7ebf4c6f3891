/* walk.cl — random walks for f(x) = g(x) + integral_D K(x,y) f(y) dy, D = [0,1]^DIM.
 *
 * Each walk is one sample of f at a query point x0 (lecture, "Rekurzivní Monte
 * Carlo odhad"):  xi_0 = x0,  W_0 = 1,  W_i = W_{i-1} K(xi_{i-1}, xi_i) / (P_i p_i(xi_i)),
 *   truncated, roulette, subcritical:  v = sum_{i=0}^{k} W_i g(xi_i)
 *   nee:                               v = g(x0) + sum_{i=0}^{k} W_i K(xi_i, zeta_i) g(zeta_i) / p(zeta_i)
 * with the variant chosen at compile time (WALK_EST):
 *   WALK_EST_TRUNCATED   uniform moves, no roulette, exactly `depth` moves (biased);
 *   WALK_EST_ROULETTE    uniform moves, survival P = `survival` or, when that is
 *                        <= 0, P = min(1, |W_i|) from the walk's weight
 *                        ("Ruská ruleta pro integrální rovnice"); unbiased;
 *   WALK_EST_SUBCRITICAL moves ~ |K(xi, .)|, survival min(1, integral |K|)
 *                        ("Volba pravděpodobností", transition.cl);
 *   WALK_EST_NEE         subcritical moves plus next-event estimation
 *                        ("Odhad příští události", next_event.cl).
 * Roulette with P depending on the already sampled move is unbiased because
 * E[1{u < P} / P | everything before u] = 1.
 *
 * Work split.  Work-item gid computes walk block gid / nq for query point
 * gid % nq: walks w = block * wpb + j, j < wpb, w < walk_limit.  LANES walks
 * run at once in the lanes of vector types; when a lane's walk ends the lane
 * starts its next walk at once (a live-lane mask with refill, so a packet is
 * not held up by its longest walk).  Which lane runs a walk changes nothing:
 * its numbers depend on (seed, q, w, step) alone (walk_rng.cl).
 *
 * Lane l runs walks l, l + LANES, l + 2 LANES, ... of the block, in this
 * order (a static hand-over: walks are short, a lane finishes one in most
 * iterations, and a shared counter would need a prefix count across lanes
 * and data-dependent branches).  The lanes' shares differ only by the random
 * walk lengths, a few per cent of a block of 4096 walks.  An iteration makes
 * WALK_SPB steps of every lane when one Philox block holds the uniforms of
 * several steps (walk_rng.cl): Philox is about half of a step's cost.
 *
 * Determinism.  Walk j's value is added, in double, to virtual partial sum
 * j mod 16 (lane j mod LANES, accumulator (j / LANES) mod (16 / LANES)), and
 * each lane meets its walks in increasing j; at the end the 16 partial sums
 * are added in order.  So every partial sum adds the same walks in the same
 * order for any LANES (as in integrate/integrate.cl), and the block's sums
 * are the same bits for any lane width, work-group size and split of blocks
 * into launches.  Counts and walk lengths are integers, exact in any order.
 *
 * Guard.  A walk that survives `max_len` moves, or whose weight grows beyond
 * WALK_WEIGHT_GUARD (finite factors multiplying up: the terms of the series
 * grow, they would overflow to Inf a few hundred moves later), is stopped and
 * counted as a guard hit: the Neumann series appears not to converge.  The
 * work-item then starts no new walk and the host raises ConvergenceError.
 * An infinite weight in one move (K or 1/p infinite) is a non-finite value,
 * not a guard hit.
 *
 * Output per work-item, WALK_STATS doubles:
 *   [0] finite walks   [1] non-finite walks   [2] sum (v - shift)   [3] sum (v - shift)^2
 *   [4] sum of walk lengths (moves, all walks)  [5] guard hits
 */
#include "walks/walk_rng.cl"
#include "walks/next_event.cl"

#define WALK_STATS 6
#define WALK_WEIGHT_GUARD 1e30f
#define WALK_VLANES 16 /* virtual partial sums */
#define WALK_NACC (WALK_VLANES / LANES)

/* p, g: walk_params and walk_table_geometry (layouts.cl, from mcocl/layouts.py; host: mcocl/walks/job.py). */
kernel void walk_blocks(const walk_params p, const walk_table_geometry g, global const float *queries,
                        global const double *shifts, global const uint *tab, global double *out) {
    const ulong first_block = p.first_block, walk_limit = p.walk_limit, seed = p.seed;
    const uint nwork = p.nwork, nq = p.nq, wpb = p.wpb;
    const float survival = p.survival;
    const uint depth = p.depth, max_len = p.max_len;
    const uint gid = get_global_id(0);
    if (gid >= nwork) return;
    const uint qi = gid % nq;
    const ulong w0 = (first_block + (ulong)(gid / nq)) * (ulong)wpb;
    const uint nwalks = walk_limit > w0 ? (uint)min((ulong)wpb, walk_limit - w0) : 0u;
    const walk_tables t = walk_tables_at(tab, g);
    const uint stream = RNG_STREAM_WALK + qi;
    const double shift = shifts[qi];

    floatv x0[DIM];
    for (int k = 0; k < DIM; ++k) x0[k] = (floatv)(queries[qi * DIM + k]);
    const floatv s0 = walk_g(x0);

    /* lane state: walk j of the block at vertex x after n moves, weight W, value so far S */
    uintv j = LANE_IOTA;
    intv active = j < (uintv)(nwalks);
    int stop = 0;
    floatv x[DIM];
    for (int k = 0; k < DIM; ++k) x[k] = x0[k];
    floatv W = (floatv)(1.0f), S = s0;
    uintv n = (uintv)(0u);
    /* statistics: integer counts in the lanes, double sums in WALK_VLANES partial sums */
    ulongv moves = (ulongv)(0ul);
    uintv guards = (uintv)(0u), nbad = (uintv)(0u), nok = (uintv)(0u);
    doublev s1[WALK_NACC], s2[WALK_NACC];
    for (int a = 0; a < WALK_NACC; ++a) {
        s1[a] = (doublev)(0.0);
        s2[a] = (doublev)(0.0);
    }

    while (lane_any(active)) {
        /* the lanes' walks w0 + j */
        mc_sampler_t smp = sampler_start_at(seed, w0, j, stream);
        floatv uu[WALK_NUI];
        walk_step_uniforms(&smp, n / (uint)WALK_SPB, uu);
        /* up to WALK_SPB steps (every lane starts the iteration at a step that is
         * a multiple of WALK_SPB: walks restart at 0 and advance WALK_SPB at a time) */
        intv going = active, finished = (intv)(0), guard = (intv)(0);
#pragma unroll
        for (int sub = 0; sub < WALK_SPB; ++sub) {
            const floatv *u = uu + sub * WALK_NU;
#if WALK_EST == WALK_EST_NEE
            S = lane_select(S, S + W * walk_next_event(x, u, t), going);
#endif
            floatv y[DIM], q;
            const floatv m = walk_transition(x, u, y, &q, t);
#if WALK_EST == WALK_EST_TRUNCATED
            const floatv Wn = W * m;
            intv go = n < (uintv)(depth);
#elif WALK_EST == WALK_EST_ROULETTE
            floatv Wn = W * m;
            intv go;
            if (survival > 0.0f) {
                go = u[WALK_U_SURV] < survival;
                Wn = Wn / survival;
            } else {
                /* P = min(1, |Wn|) and Wn / P = sign(Wn) max(1, |Wn|), exactly (x / |x| = +-1) */
                const floatv a = lane_abs(Wn);
                go = u[WALK_U_SURV] < a;
                Wn = lane_copysign(lane_select(a, (floatv)(1.0f), a < 1.0f), Wn);
            }
#else
            intv go = u[WALK_U_SURV] < q;
            const floatv Wn = W * m / q;
#endif
            go = go & going;
            const intv g = go & ((n >= (uintv)(max_len)) | ((lane_abs(Wn) > WALK_WEIGHT_GUARD) & lane_finite(Wn)));
            guard = guard | g;
            go = go & !g;
            for (int k = 0; k < DIM; ++k) x[k] = lane_select(x[k], y[k], go);
            W = lane_select(W, Wn, go);
            n += to_uintv(mask_bit(go));
#if WALK_EST != WALK_EST_NEE
            S = lane_select(S, S + Wn * walk_g(y), go);
#endif
            /* A walk ends when it does not move on, when its weight is 0 (nothing
             * more to add) or when its weight or value is no longer finite. */
            S = lane_select(S, (floatv)(NAN), go & !lane_finite(W));
            intv ends = going & (!go | (W == 0.0f) | !lane_finite(S));
#if WALK_EST == WALK_EST_TRUNCATED
            ends = ends | (going & (n >= (uintv)(depth)));
#endif
            finished = finished | ends;
            going = going & !ends;
        }
        if (lane_any(finished)) {
            moves += to_ulongv(lane_select((uintv)(0u), n, finished));
            guards += to_uintv(mask_bit(guard));
            const intv ok = finished & !guard & lane_finite(S);
            nbad += to_uintv(mask_bit(finished & !guard & !lane_finite(S)));
            nok += to_uintv(mask_bit(ok));
            /* add v - shift to partial sum j mod 16: lane j mod LANES of accumulator
             * (j / LANES) mod WALK_NACC.  Lanes that add nothing add 0 (or -0),
             * selected by multiplying with exact 0/1 factors (cheaper than masks). */
            const doublev okf = to_doublev(to_intv(mask_bit(ok)));
            const doublev d = (to_doublev(lane_select((floatv)(0.0f), S, ok)) - shift) * okf;
            const doublev dd = d * d;
#if WALK_NACC == 1
            s1[0] += d;
            s2[0] += dd;
#else
            const uintv acc = (j / (uint)LANES) % (uint)WALK_NACC;
#pragma unroll
            for (int a = 0; a < WALK_NACC; ++a) {
                const doublev in_a = to_doublev(to_intv(mask_bit(acc == (uint)a)));
                s1[a] += d * in_a;
                s2[a] += dd * in_a;
            }
#endif
            stop |= lane_any(guard);
            /* the lane's next walk; after a guard hit, none (the run will raise) */
            j = lane_select(j, stop ? (uintv)(nwalks) : j + (uint)LANES, finished);
            for (int k = 0; k < DIM; ++k) x[k] = lane_select(x[k], x0[k], finished);
            W = lane_select(W, (floatv)(1.0f), finished);
            S = lane_select(S, s0, finished);
            n = lane_select(n, (uintv)(0u), finished);
            active = j < (uintv)(nwalks);
        }
    }

    /* the 16 partial sums in order: virtual lane r = lane r mod LANES of accumulator r / LANES */
    double t1 = 0.0, t2 = 0.0;
    for (int a = 0; a < WALK_NACC; ++a) {
        double_lanes v1, v2;
        v1.v = s1[a];
        v2.v = s2[a];
        for (int l = 0; l < LANES; ++l) {
            t1 += v1.a[l];
            t2 += v2.a[l];
        }
    }
    global double *o = out + (size_t)gid * WALK_STATS;
    o[0] = (double)lane_sum_u(nok);
    o[1] = (double)lane_sum_u(nbad);
    o[2] = t1;
    o[3] = t2;
    o[4] = (double)lane_sum_ul(moves);
    o[5] = (double)lane_sum_u(guards);
}
