/* lane_div_test.cl — lane_div (lane_ops.cl) exposed to the tests (tests/test_lane_div.py):
 * out[i] = x[i] / d by the multiply-high, LANES items per work-item. */
#include "lanes.cl"
#include "render/lane_io.cl"

kernel void divide(uint d, uint n, global const uint *x, global uint *out) {
    const uint base = (uint)get_global_id(0) * LANES;
    if (base >= n) return;
    const lane_divisor v = lane_divisor_of(d);
#if LANES == 1
    out[base] = lane_div(x[base], v);
#else
    MC_CAT(vstore, LANE_SUFFIX)(lane_div(MC_CAT(vload, LANE_SUFFIX)(0, x + base), v), 0, out + base);
#endif
}
