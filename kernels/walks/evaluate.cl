/* evaluate.cl — the user's K and g at given points, for the Nyström
 * reference solver (mcocl/walks/nystrom.py).  Built on its own with LANES=1
 * and only the scalar forms of the snippets: it shares the parsing of the
 * user's expressions with the walks, nothing of their estimator.
 *
 * eval_kernel_grid: out[i * ny + j] = K(X_i, Y_j)   (X: nx points, Y: ny points, DIM floats each)
 * eval_source:      out[i] = g(X_i)
 */
kernel void eval_kernel_grid(uint nx, uint ny, global const float *X, global const float *Y, global float *out) {
    const uint gid = get_global_id(0);
    if (gid >= nx * ny) return;
    const uint i = gid / ny, j = gid % ny;
    float x[DIM], y[DIM];
    for (int k = 0; k < DIM; ++k) {
        x[k] = X[i * DIM + k];
        y[k] = Y[j * DIM + k];
    }
    out[gid] = walk_K(x, y);
}

kernel void eval_source(uint nx, global const float *X, global float *out) {
    const uint i = get_global_id(0);
    if (i >= nx) return;
    float x[DIM];
    for (int k = 0; k < DIM; ++k) x[k] = X[i * DIM + k];
    out[i] = walk_g(x);
}
