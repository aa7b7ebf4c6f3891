/* next_event.cl — next-event estimation (lecture, "Odhad příští události").
 *
 * f = g + h, h(x) = integral K(x,y) g(y) dy + integral K(x,y) h(y) dy.  At
 * every vertex x of the walk the first integral is estimated by one sample
 * zeta with a density p ~ |g|:  K(x, zeta) g(zeta) / p(zeta); the walk then
 * continues by the subcritical rule (transition.cl) for the second integral.
 *
 * WALK_SRC_TABLE  p = |g| tabulated on the walk's bin grid (walks/tabulate.py),
 *                 the term is K g / p~ with the exact K and g: unbiased
 *                 whatever the tabulation.
 * WALK_SRC_GIVEN  the user's inverse CDF zeta = Z(u) of |g| / G and G =
 *                 integral of |g|: the term is K(x, zeta) sign(g(zeta)) G,
 *                 plus (g - g) so that a NaN/Inf g marks the walk non-finite.
 */
#ifndef MCOCL_WALK_NEXT_EVENT_CL
#define MCOCL_WALK_NEXT_EVENT_CL

#include "walks/transition.cl"

/* Sample zeta (into z) from the uniforms u; returns g(zeta) / p(zeta). */
MC_INLINE floatv walk_source_sample(const floatv *u, floatv *z, walk_tables t) {
#if WALK_SRC == WALK_SRC_TABLE
    floatv p = wt_sample(t.tab, (uintv)(t.src_off), t.nya, t.nb, t.lognb, u[WALK_U_ZBIN], u + WALK_U_Z, z);
    return walk_g(z) / p;
#else
    walk_Z_all(u + WALK_U_Z, z);
    floatv gz = walk_g(z);
    return lane_sign(gz) * (float)WALK_SOURCE_INTEGRAL + (gz - gz);
#endif
}

/* One-sample estimate of integral K(x, y) g(y) dy, from uniforms u. */
MC_INLINE floatv walk_next_event(const floatv *x, const floatv *u, walk_tables t) {
    floatv z[DIM];
    floatv gp = walk_source_sample(u, z, t);
    return walk_K(x, z) * gp;
}

#endif
