/* density_probe.cl — a user's analytic proposal (pdf and inverse CDF) on
 * probe points, for mcocl/integration/density_check.py.  Built with LANES=1
 * and the scalar forms of the two snippets, named probe_pdf and probe_inv.
 *
 * For probe t[i]:
 *   pdf_at[i] = pdf(t[i])                 the density on a grid of [0, 1]
 *   inv_at[i] = inverse(t[i])             the inverse CDF on a grid of (0, 1)
 *   pdf_inv[i] = pdf(inv_at[i])           the density at the sampled point
 * (unclamped: the check is of the user's pair, not of the warp's clamping of
 * points below 2^-24 into the open interval, sampling/unit_interval.cl)
 */
kernel void density_probe(uint n, global const float *t, global float *pdf_at, global float *inv_at,
                          global float *pdf_inv) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    const float ti = t[i];
    pdf_at[i] = probe_pdf(ti);
    const float x = probe_inv(ti);
    inv_at[i] = x;
    pdf_inv[i] = probe_pdf(x);
}
