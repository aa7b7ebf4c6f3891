/* unit_interval.cl — keeping warped coordinates inside the open unit interval.
 * A coordinate computed as (cell + jitter) / m, or by an inverse CDF, can round
 * to exactly 1.0f in float; estimators and lookups assume x < 1. */
#ifndef MCOCL_UNIT_INTERVAL_CL
#define MCOCL_UNIT_INTERVAL_CL

#include "lanes.cl"

#define ONE_MINUS_EPS 0x1.fffffep-1f /* the largest float below 1 */
#define TINY_POSITIVE 0x1p-24f

MC_INLINE floatv clamp_open01(floatv x) { return fmin(fmax(x, (floatv)(TINY_POSITIVE)), (floatv)(ONE_MINUS_EPS)); }

/* (cell + u) / m in double, rounded once to float: cell may be large (up to
 * 2^22 strata per axis) and the jitter must not be lost in a float sum. */
MC_INLINE floatv cell_to_unit(doublev cell, floatv u, double inv_m) {
    return clamp_open01(to_floatv((cell + to_doublev(u)) * inv_m));
}

#endif
