/* transition.cl — how a walk moves from its vertex x to the next one, y.
 *
 * Lecture, "Rekurzivní Monte Carlo odhad": the weight of a walk is the product
 * of K(xi_{j-1}, xi_j) / (P_j p_j(xi_j)).  This file provides the density p
 * and the survival probability P of each variant; walk.cl multiplies.
 *
 * WALK_TRANS_UNIFORM  y uniform on [0,1]^DIM, p = 1 (roulette, truncated).
 * WALK_TRANS_TABLE    subcritical (lecture, "Volba pravděpodobností"): y ~
 *                     |K(x,.)| tabulated per cell of x (walks/tabulate.py) as
 *                     a piecewise-constant density p~(y|x); survival q~(x) =
 *                     min(1, integral of the table).  The weight multiplier is
 *                     K(x,y) / (q~ p~): exact K over the sampled density, so
 *                     the estimate is unbiased whatever the tabulation, and
 *                     the sign of K rides in the weight.
 *                     Returns m = K/p~ and q = q~.
 * WALK_TRANS_GIVEN    the user's inverse CDF y = T(x, u) of |K(x,.)| / A(x)
 *                     and row integral A(x) = integral of |K(x,y)| dy: q =
 *                     min(1, A) and m = sign(K(x,y)) A(x); (K - K) is added so
 *                     that a NaN/Inf K marks the walk as non-finite instead of
 *                     vanishing in sign().
 */
#ifndef MCOCL_WALK_TRANSITION_CL
#define MCOCL_WALK_TRANSITION_CL

#include "layouts.cl"
#include "walks/table.cl"

typedef struct {
    global const uint *tab;
    uint nxa;       /* cells of x per axis */
    uint nya;       /* bins of y per axis */
    uint nb;        /* bins, nya^DIM */
    uint lognb;     /* log2(nb) */
    uint trans_off; /* first transition CDF (cell 0) */
    uint q_off;     /* survival probabilities, one float per cell */
    uint src_off;   /* the source CDF (next-event estimation) */
} walk_tables;

/* The tables of buffer `tab` laid out as `g` says (host: WalkTables.geometry, mcocl/walks/tabulate.py). */
MC_INLINE walk_tables walk_tables_at(global const uint *tab, const walk_table_geometry g) {
    walk_tables t;
    t.tab = tab; t.nxa = g.nxa; t.nya = g.nya; t.nb = g.nb; t.lognb = g.lognb;
    t.trans_off = g.trans_off; t.q_off = g.q_off; t.src_off = g.src_off;
    return t;
}

/* The multiplier K(x,y)/p(y|x) of the move x -> y, y sampled here from the
 * uniforms u (layout WALK_U_* of the generated code); *q is the survival
 * probability of the subcritical variants (1 for the uniform one). */
MC_INLINE floatv walk_transition(const floatv *x, const floatv *u, floatv *y, floatv *q, walk_tables t) {
#if WALK_TRANS == WALK_TRANS_UNIFORM
    for (int k = 0; k < DIM; ++k) y[k] = u[WALK_U_Y + k];
    *q = (floatv)(1.0f);
    return walk_K(x, y);
#elif WALK_TRANS == WALK_TRANS_TABLE
    uintv cell = wt_cell(x, t.nxa);
    *q = lane_as_float(gather_uint(t.tab, t.q_off + cell));
    floatv p = wt_sample(t.tab, (uintv)(t.trans_off) + cell * (2u * t.nb), t.nya, t.nb, t.lognb, u[WALK_U_TBIN],
                         u + WALK_U_Y, y);
    return walk_K(x, y) / p;
#else
    walk_T_all(x, u + WALK_U_Y, y);
    floatv a = walk_A(x);
    *q = lane_min(a, (floatv)(1.0f));
    floatv k = walk_K(x, y);
    return lane_sign(k) * a + (k - k);
#endif
}

#endif
