/* tabulate.cl — the raw weights of the walk's tabulated densities.
 *
 * The subcritical transition density of a walk at x is |K(x, .)| / integral
 * |K(x, .)|; the next-event density is |g| / integral |g|.  These kernels
 * evaluate the user's K and g (scalar forms) on a grid; walks/tabulate.py
 * turns the weights into quantised CDFs (table.cl).
 *
 * Grid: nxa cells of x per axis, nya bins of y per axis, row-major with axis
 * 0 most significant (as wt_cell and wt_sample read them).  A weight is the
 * mean of |K| over (sx^DIM) * (sy^DIM) sub-points: sx per axis in the x cell
 * times sy per axis in the y bin, each at the centre of its sub-box, so a
 * kernel peak narrower than a bin still shows.  Any non-finite value makes
 * the weight NaN (the host counts those and reports them).
 */
#ifndef MCOCL_WALK_TABULATE_CL
#define MCOCL_WALK_TABULATE_CL

/* The centre of sub-box `sub` (of s per axis) of box `box` (of na per axis). */
MC_INLINE void walk_subpoint(uint box, uint na, uint sub, uint s, float *p) {
    for (int k = DIM - 1; k >= 0; --k) {
        const uint d = box % na, e = sub % s;
        box /= na;
        sub /= s;
        p[k] = ((float)d + ((float)e + 0.5f) / (float)s) / (float)na;
    }
}

MC_INLINE uint walk_ipow(uint b, int e) {
    uint r = 1u;
    for (int k = 0; k < e; ++k) r *= b;
    return r;
}

/* out[c * nb + b] = mean |K(x, y)|, x in cell c, y in bin b. */
kernel void walk_tabulate_kernel(uint ncells, uint nb, uint nxa, uint nya, uint sx, uint sy, global float *out) {
    const uint gid = get_global_id(0);
    if (gid >= ncells * nb) return;
    const uint c = gid / nb, b = gid % nb;
    const uint nsx = walk_ipow(sx, DIM), nsy = walk_ipow(sy, DIM);
    float x[DIM], y[DIM];
    float acc = 0.0f;
    int bad = 0;
    for (uint i = 0; i < nsx; ++i) {
        walk_subpoint(c, nxa, i, sx, x);
        for (uint k = 0; k < nsy; ++k) {
            walk_subpoint(b, nya, k, sy, y);
            const float v = walk_K_s(x, y);
            bad |= !isfinite(v);
            acc += fabs(v);
        }
    }
    out[gid] = bad ? NAN : acc / (float)(nsx * nsy);
}

/* out[b] = mean |g(y)|, y in bin b. */
kernel void walk_tabulate_source(uint nb, uint nya, uint sy, global float *out) {
    const uint b = get_global_id(0);
    if (b >= nb) return;
    const uint nsy = walk_ipow(sy, DIM);
    float y[DIM];
    float acc = 0.0f;
    int bad = 0;
    for (uint k = 0; k < nsy; ++k) {
        walk_subpoint(b, nya, k, sy, y);
        const float v = walk_g_s(y);
        bad |= !isfinite(v);
        acc += fabs(v);
    }
    out[b] = bad ? NAN : acc / (float)nsy;
}

#endif
