/* integral_probe.cl — the user's row integral A(x) against a quadrature of
 * |K(x, .)|, and a quadrature of |g| for the user's source integral G, for
 * mcocl/walks/integral_check.py.  Built on its own with LANES=1 and the
 * scalar forms of K, g and A (as evaluate.cl).
 *
 * row_integral_probe: for probe x_p (DIM floats each)
 *   out[3p]     = A(x_p)
 *   out[3p + 1] = mean of |K(x_p, y)| over the n^DIM midpoints y of a grid
 *   out[3p + 2] = the same over the (n/2)^DIM midpoints of the halved grid
 * (midpoint rule on [0, 1]^DIM; the two differ by about the coarse rule's
 * error, which the host uses as the quadrature's error bar).  A non-finite
 * K makes the sum non-finite, and the host then skips the probe.  Sums are
 * compensated (Kahan 1965) so that 4096 float terms lose nothing the host's
 * 1e-3 tolerance could see.
 */
/* The mean of |K(x, y)| (with_x) or of |g(y)| over the n^DIM midpoints y. */
MC_INLINE float grid_mean_abs(const float *x, int with_x, uint n) {
    uint total = 1u;
    for (int k = 0; k < DIM; ++k) total *= n;
    float y[DIM];
    float s = 0.0f, c = 0.0f;
    for (uint j = 0; j < total; ++j) {
        uint r = j;
        for (int k = DIM - 1; k >= 0; --k) {
            y[k] = ((float)(r % n) + 0.5f) / (float)n;
            r /= n;
        }
        const float v = fabs(with_x ? walk_K(x, y) : walk_g(y)) - c;
        const float t = s + v;
        c = (t - s) - v;
        s = t;
    }
    return s / (float)total;
}

#ifdef walk_A /* a build with the user's row integral */
kernel void row_integral_probe(uint nprobes, uint n, global const float *xs, global float *out) {
    const uint p = get_global_id(0);
    if (p >= nprobes) return;
    float x[DIM];
    for (int k = 0; k < DIM; ++k) x[k] = xs[p * DIM + k];
    out[3 * p] = walk_A(x);
    out[3 * p + 1] = grid_mean_abs(x, 1, n);
    out[3 * p + 2] = grid_mean_abs(x, 1, n / 2u);
}
#endif

/* source_integral_probe: out[0], out[1] = the mean of |g| over the n^DIM and
 * the (n/2)^DIM grid midpoints (one work-item). */
kernel void source_integral_probe(uint n, global float *out) {
    if (get_global_id(0) != 0) return;
    float x[DIM];
    for (int k = 0; k < DIM; ++k) x[k] = 0.5f;
    out[0] = grid_mean_abs(x, 0, n);
    out[1] = grid_mean_abs(x, 0, n / 2u);
}
