/* mis.cl — weights of combined estimators (lecture: "Kombinované odhady";
 * Veach & Guibas 1995; Veach's thesis §9.2).  Technique i draws n_i samples
 * from p_i; with q_i = n_i p_i(x) the weights sum to 1 at every x:
 *   average  w_i = n_i / sum_j n_j                         (constant)
 *   max      w_i = 1 if q_i is the largest q (lowest i on ties), else 0
 *   balance  w_i = q_i / sum_j q_j                           (thesis eq. 9.10)
 *   power    w_i = q_i^beta / sum_j q_j^beta                 (thesis eq. 9.13)
 * The lecture's one-sample-per-technique form is n_i = 1. */
#ifndef MCOCL_MIS_CL
#define MCOCL_MIS_CL

#include "lanes.cl"

MC_INLINE floatv mis_weight_average(int i, const float *n, int k) {
    float total = 0.0f;
    for (int j = 0; j < k; ++j) total += n[j];
    return (floatv)(n[i] / total);
}

MC_INLINE floatv mis_weight_max(int i, const floatv *q, int k) {
    floatv w = (floatv)(1.0f);
    for (int j = 0; j < k; ++j) {
        if (j == i) continue;
        /* i loses to a strictly larger q_j, or to an equal q_j with lower index */
        intv lose = (j < i) ? (q[j] >= q[i]) : (q[j] > q[i]);
        w = lane_select(w, (floatv)(0.0f), lose);
    }
    return w;
}

MC_INLINE floatv mis_weight_balance(int i, const floatv *q, int k) {
    floatv s = (floatv)(0.0f);
    for (int j = 0; j < k; ++j) s += q[j];
    return lane_select(q[i] / s, (floatv)(0.0f), s <= 0.0f);
}

/* Powers are taken of q / max(q) so that large densities do not overflow. */
MC_INLINE floatv mis_weight_power(int i, const floatv *q, int k, float beta) {
    floatv m = q[0];
    for (int j = 1; j < k; ++j) m = lane_max(m, q[j]);
    floatv s = (floatv)(0.0f), qi = (floatv)(0.0f);
    for (int j = 0; j < k; ++j) {
        floatv r = q[j] / m;
        floatv t = (beta == 2.0f) ? r * r : pow(r, (floatv)(beta));
        s += t;
        if (j == i) qi = t;
    }
    return lane_select(qi / s, (floatv)(0.0f), m <= 0.0f);
}

/* The rendering special case: two techniques, beta = 2 (Veach eq. 9.13), for
 * the technique whose (count-weighted) pdf is a against the other's b. */
MC_INLINE floatv power_heuristic(floatv a, floatv b) {
    floatv a2 = a * a, b2 = b * b;
    return lane_select(a2 / (a2 + b2), (floatv)(0.0f), (a2 + b2) <= 0.0f);
}

#endif
