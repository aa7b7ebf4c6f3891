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
 * takes the block's next walk (a live-lane mask with refill, so a packet is
 * not held up by its longest walk).  Which lane runs a walk changes nothing:
 * its numbers depend on (seed, q, w, step) alone (walk_rng.cl).
 *
 * Determinism.  Every walk stores its value and length in scratch memory at
 * its own index; at the end the work-item adds them up in walk order, in
 * double.  The block's sums are therefore the same bits for any LANES, any
 * work-group size and any split of blocks into launches.
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
#include "walks/lane_store.cl"

#define WALK_STATS 6
#define WALK_GUARD_BIT 0x80000000u
#define WALK_WEIGHT_GUARD 1e30f

kernel void walk_blocks(ulong first_block, uint nwork, uint nq, uint wpb, ulong walk_limit, ulong seed,
                        global const float *queries, global const double *shifts,
                        float survival, uint depth, uint max_len,
                        global const uint *tab, uint nxa, uint nya, uint nb, uint top,
                        uint trans_off, uint q_off, uint src_off,
                        global float *vals, global uint *lens, global double *out) {
    const uint gid = get_global_id(0);
    if (gid >= nwork) return;
    const uint qi = gid % nq;
    const ulong w0 = (first_block + (ulong)(gid / nq)) * (ulong)wpb;
    const uint nwalks = walk_limit > w0 ? (uint)min((ulong)wpb, walk_limit - w0) : 0u;
    walk_tables t;
    t.tab = tab; t.nxa = nxa; t.nya = nya; t.nb = nb; t.top = top;
    t.trans_off = trans_off; t.q_off = q_off; t.src_off = src_off;
    const uint k0 = (uint)(seed & 0xffffffffu), k1 = (uint)(seed >> 32);
    const uint stream = WALK_STREAM + qi;
    global float *V = vals + (size_t)gid * wpb;
    global uint *N = lens + (size_t)gid * wpb;

    floatv x0[DIM];
    for (int k = 0; k < DIM; ++k) x0[k] = (floatv)(queries[qi * DIM + k]);
    const floatv s0 = walk_g(x0);

    /* lane state: walk j of the block at vertex x after n moves, weight W, value so far S */
    uintv j = LANE_IOTA;
    intv active = j < (uintv)(nwalks);
    uint next = LANES;
    int stop = 0;
    floatv x[DIM];
    for (int k = 0; k < DIM; ++k) x[k] = x0[k];
    floatv W = (floatv)(1.0f), S = s0;
    uintv n = (uintv)(0u);

    while (mask_any(active)) {
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
        const floatv P = survival > 0.0f ? (floatv)(survival) : fmin(fabs(Wn), (floatv)(1.0f));
        intv go = u[WALK_U_SURV] < P;
        Wn = Wn / P;
#else
        intv go = u[WALK_U_SURV] < q;
        const floatv Wn = W * m / q;
#endif
        go = go & active;
        const intv guard = go & ((n >= (uintv)(max_len)) | ((fabs(Wn) > WALK_WEIGHT_GUARD) & isfinite(Wn)));
        go = go & !guard;
        for (int k = 0; k < DIM; ++k) x[k] = select(x[k], y[k], go);
        W = select(W, Wn, go);
        n += to_uintv(mask_bit(go));
#if WALK_EST != WALK_EST_NEE
        S = select(S, S + Wn * walk_g(y), go);
#endif
        /* A walk ends when it does not move on, when its weight is 0 (nothing
         * more to add) or when its weight or value is no longer finite. */
        S = select(S, (floatv)(NAN), go & !isfinite(W));
        intv finished = active & (!go | (W == 0.0f) | !isfinite(S));
#if WALK_EST == WALK_EST_TRUNCATED
        finished = finished | (active & (n >= (uintv)(depth)));
#endif
        if (mask_any(finished)) {
            float sa[LANES];
            uint na[LANES], ja[LANES];
            int fa[LANES], ga[LANES];
            WALK_STORE(S, sa);
            WALK_STORE(n, na);
            WALK_STORE(j, ja);
            WALK_STORE(finished, fa);
            WALK_STORE(guard, ga);
            for (int l = 0; l < LANES; ++l) {
                if (fa[l]) {
                    V[ja[l]] = sa[l];
                    N[ja[l]] = na[l] | (ga[l] ? WALK_GUARD_BIT : 0u);
                    stop |= ga[l] != 0;
                    ja[l] = stop ? nwalks : next++;
                }
            }
            j = WALK_LOAD(ja);
            for (int k = 0; k < DIM; ++k) x[k] = select(x[k], x0[k], finished);
            W = select(W, (floatv)(1.0f), finished);
            S = select(S, s0, finished);
            n = select(n, (uintv)(0u), finished);
            active = j < (uintv)(nwalks);
        }
    }

    /* the block's statistics, in walk order (see "Determinism" above) */
    const uint started = min(next, nwalks);
    const double shift = shifts[qi];
    double nv = 0.0, nbad = 0.0, s1 = 0.0, s2 = 0.0, len = 0.0, guards = 0.0;
    for (uint i = 0; i < started; ++i) {
        const float v = V[i];
        const uint nn = N[i];
        len += (double)(nn & ~WALK_GUARD_BIT);
        if (nn & WALK_GUARD_BIT) {
            guards += 1.0;
        } else if (!isfinite(v)) {
            nbad += 1.0;
        } else {
            const double d = (double)v - shift;
            s1 += d;
            s2 += d * d;
            nv += 1.0;
        }
    }
    global double *o = out + (size_t)gid * WALK_STATS;
    o[0] = nv;
    o[1] = nbad;
    o[2] = s1;
    o[3] = s2;
    o[4] = len;
    o[5] = guards;
}
