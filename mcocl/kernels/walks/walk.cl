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
 * Determinism.  Every walk stores its value in scratch memory at its own
 * index; at the end the work-item adds the values up in a fixed order
 * (walk i into partial sum i mod 16, the 16 partial sums in order), in
 * double.  The block's sums are therefore the same bits for any LANES, any
 * work-group size and any split of blocks into launches.  Counts and walk
 * lengths are integers, exact in any order, and are summed in the lanes.
 *
 * Cost.  Walks are short (often one or two moves), so a lane finishes a walk
 * in most iterations.  Lane l runs walks l, l + LANES, l + 2 LANES, ... of
 * the block (a static hand-over: no prefix count across lanes, no
 * data-dependent branch), and every lane stores its value when any lane
 * finishes, unfinished lanes into a dummy slot past the block's walks.  The
 * lanes' shares differ only by the random walk lengths, a few per cent of a
 * block of 1024 walks.
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
#include "walks/lane_ops.cl"

#define WALK_STATS 6
#define WALK_WEIGHT_GUARD 1e30f
#define WALK_MAX_LANES 16 /* dummy slots per work-item: the widest build */

inline ulong lane_sum_ul(ulongv v) {
#if LANES == 1
    return v;
#else
    ulong s = 0;
    ulong t[LANES];
    MC_CAT(vstore, LANE_SUFFIX)(v, 0, t);
    for (int k = 0; k < LANES; ++k) s += t[k];
    return s;
#endif
}

kernel void walk_blocks(ulong first_block, uint nwork, uint nq, uint wpb, ulong walk_limit, ulong seed,
                        global const float *queries, global const double *shifts,
                        float survival, uint depth, uint max_len,
                        global const uint *tab, uint nxa, uint nya, uint nb, uint lognb,
                        uint trans_off, uint q_off, uint src_off,
                        global float *vals, global double *out) {
    const uint gid = get_global_id(0);
    if (gid >= nwork) return;
    const uint qi = gid % nq;
    const ulong w0 = (first_block + (ulong)(gid / nq)) * (ulong)wpb;
    const uint nwalks = walk_limit > w0 ? (uint)min((ulong)wpb, walk_limit - w0) : 0u;
    walk_tables t;
    t.tab = tab; t.nxa = nxa; t.nya = nya; t.nb = nb; t.lognb = lognb;
    t.trans_off = trans_off; t.q_off = q_off; t.src_off = src_off;
    const uint k0 = (uint)(seed & 0xffffffffu), k1 = (uint)(seed >> 32);
    const uint stream = WALK_STREAM + qi;
    /* wpb values, then LANES dummy slots for the lanes that did not finish */
    global float *V = vals + (size_t)gid * (wpb + WALK_MAX_LANES);

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
    ulongv moves = (ulongv)(0ul);
    uintv guards = (uintv)(0u);

    while (wl_any(active)) {
        const ulongv w = (ulongv)(w0) + to_ulongv(j);
        floatv u[WALK_NU];
        walk_step_uniforms(to_uintv(w & (ulong)0xffffffffu), to_uintv(w >> 32), n, k0, k1, stream, u);
#if WALK_EST == WALK_EST_NEE
        S += W * walk_next_event(x, u, t);
#endif
        floatv y[DIM], q;
        const floatv m = walk_transition(x, u, y, &q, t);
#if WALK_EST == WALK_EST_TRUNCATED
        const floatv Wn = W * m;
        intv go = n < (uintv)(depth);
#elif WALK_EST == WALK_EST_ROULETTE
        floatv Wn = W * m;
        const floatv P = survival > 0.0f ? (floatv)(survival) : wl_min(wl_abs(Wn), (floatv)(1.0f));
        intv go = u[WALK_U_SURV] < P;
        Wn = Wn / P;
#else
        intv go = u[WALK_U_SURV] < q;
        const floatv Wn = W * m / q;
#endif
        go = go & active;
        const intv guard = go & ((n >= (uintv)(max_len)) | ((wl_abs(Wn) > WALK_WEIGHT_GUARD) & wl_finite(Wn)));
        go = go & !guard;
        for (int k = 0; k < DIM; ++k) x[k] = wl_self(x[k], y[k], go);
        W = wl_self(W, Wn, go);
        n += to_uintv(mask_bit(go));
#if WALK_EST != WALK_EST_NEE
        S = wl_self(S, S + Wn * walk_g(y), go);
#endif
        /* A walk ends when it does not move on, when its weight is 0 (nothing
         * more to add) or when its weight or value is no longer finite. */
        S = wl_self(S, (floatv)(NAN), go & !wl_finite(W));
        intv finished = active & (!go | (W == 0.0f) | !wl_finite(S));
#if WALK_EST == WALK_EST_TRUNCATED
        finished = finished | (active & (n >= (uintv)(depth)));
#endif
        if (wl_any(finished)) {
            moves += to_ulongv(wl_selu((uintv)(0u), n, finished));
            guards += to_uintv(mask_bit(guard));
            /* a guard-stopped walk is stored as NaN and counted as a guard hit */
            wl_float_lanes rec;
            rec.v = wl_self(S, (floatv)(NAN), guard);
            wl_uint_lanes dst;
            dst.v = wl_selu((uintv)(wpb) + LANE_IOTA, j, finished);
            for (int l = 0; l < LANES; ++l) V[dst.a[l]] = rec.a[l];
            stop |= wl_any(guard);
            /* lane l runs walks l, l + LANES, l + 2 LANES, ...; after a guard hit, none */
            j = wl_selu(j, stop ? (uintv)(nwalks) : j + (uint)LANES, finished);
            for (int k = 0; k < DIM; ++k) x[k] = wl_self(x[k], x0[k], finished);
            W = wl_self(W, (floatv)(1.0f), finished);
            S = wl_self(S, s0, finished);
            n = wl_selu(n, (uintv)(0u), finished);
            active = j < (uintv)(nwalks);
        }
    }

    /* the block's statistics (see "Determinism" above); after a guard hit some
     * walks never ran: only the guard count is reported, the run will raise */
    const uint started = stop ? 0u : nwalks;
    const double shift = shifts[qi];
    double16 a1 = (double16)(0.0), a2 = (double16)(0.0), an = (double16)(0.0), ab = (double16)(0.0);
    for (uint i = 0; i < started; i += 16) {
        const int16 in_range = convert_int16((uint16)(i) + (uint16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15)
                                             < (uint16)(started));
        const float16 v = vload16(0, V + i);
        const long16 ok = convert_long16(in_range & isfinite(v));
        const long16 bad = convert_long16(in_range & !isfinite(v));
        const double16 d = select((double16)(0.0), convert_double16(v) - shift, ok);
        a1 += d;
        a2 += d * d;
        an += select((double16)(0.0), (double16)(1.0), ok);
        ab += select((double16)(0.0), (double16)(1.0), bad);
    }
    double nv = 0.0, nbad = 0.0, s1 = 0.0, s2 = 0.0;
    double t1[16], t2[16], tn[16], tb[16];
    vstore16(a1, 0, t1);
    vstore16(a2, 0, t2);
    vstore16(an, 0, tn);
    vstore16(ab, 0, tb);
    for (int k = 0; k < 16; ++k) {
        s1 += t1[k];
        s2 += t2[k];
        nv += tn[k];
        nbad += tb[k];
    }
    const double nguard = (double)lane_sum_u(guards);
    global double *o = out + (size_t)gid * WALK_STATS;
    o[0] = nv;
    o[1] = nbad - nguard;
    o[2] = s1;
    o[3] = s2;
    o[4] = (double)lane_sum_ul(moves);
    o[5] = nguard;
}
