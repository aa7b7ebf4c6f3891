/* unit_interval.cl — keeping warped coordinates inside the open unit interval.
 * A coordinate computed as (cell + jitter) / m, or by an inverse CDF, can round
 * to exactly 1.0f in float; estimators and lookups assume x < 1. */
#ifndef MCOCL_UNIT_INTERVAL_CL
#define MCOCL_UNIT_INTERVAL_CL

#include "lanes.cl"

#define ONE_MINUS_EPS 0x1.fffffep-1f /* the largest float below 1 */

MC_INLINE floatv clamp_open01(floatv x) { return lane_open01(x); }

/* (cell + u) / m in double, rounded once to float: cell may be large (up to
 * 2^22 strata per axis) and the jitter must not be lost in a float sum.  The
 * rounding can still carry the point onto a neighbouring slab's boundary (u
 * within 2^-24 of 0 or 1); one float step back keeps every point in its own
 * slab, which is what makes a design stratified or N-rooks. */
MC_INLINE floatv cell_to_unit(doublev cell, floatv u, double m, double inv_m) {
    floatv t = clamp_open01(to_floatv((cell + to_doublev(u)) * inv_m));
    const doublev y = to_doublev(t) * m; /* exact: 24-bit t times m <= 2^22 */
    /* floor(y) > cell: one float down; floor(y) < cell: one float up */
    return lane_step_positive(t, to_intv(y < cell), to_intv(y >= cell + 1.0));
}

#endif
