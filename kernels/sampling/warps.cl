/* warps.cl — inverse-CDF warps x = P^-1(u) of the built-in 1-D proposal
 * densities on [0, 1], with their pdfs (lecture: "Vzorkování podle
 * důležitosti", xi = P^-1(tau), estimator f(xi) / p(xi)).
 *
 * Every warp returns x strictly inside (0, 1) and writes p(x) *as the pdf
 * function of the same family computes it*, so that an estimator that
 * re-evaluates p at x (multiple importance sampling) gets the same number.
 * Constants that do not depend on x (normalisations, CDF values at the ends)
 * are computed by the host in double precision and passed in.
 */
#ifndef MCOCL_WARPS_CL
#define MCOCL_WARPS_CL

#include "sampling/unit_interval.cl"

/* ---- exponential, truncated to [0, 1] ------------------------------------
 * p(x) = norm * exp(-rate x),  norm = rate / (1 - exp(-rate)),  rate > 0;
 * P(x) = (1 - exp(-rate x)) / (1 - exp(-rate)),
 * P^-1(u) = -log(1 + u * expm1(-rate)) / rate,  em1 = expm1(-rate) in (-1, 0).
 * (A negative rate is the mirror image x -> 1 - x; the host emits that.) */
MC_INLINE floatv pdf_exponential(floatv x, float rate, float norm) {
    return norm * exp(-rate * x);
}

MC_INLINE floatv warp_exponential(floatv u, float rate, float em1, float norm, floatv *pdf) {
    floatv x = clamp_open01(-log1p(u * em1) / rate);
    *pdf = pdf_exponential(x, rate, norm);
    return x;
}

/* ---- power law --------------------------------------------------------------
 * p(x) = (a + 1) x^a, a > -1;  P(x) = x^(a+1);  P^-1(u) = u^(1/(a+1)). */
MC_INLINE floatv pdf_power(floatv x, float a) {
    return (a + 1.0f) * exp(a * log(x));
}

MC_INLINE floatv warp_power(floatv u, float a, floatv *pdf) {
    floatv x = clamp_open01(exp(log(u) / (a + 1.0f)));
    *pdf = pdf_power(x, a);
    return x;
}

/* ---- normal distribution truncated to [0, 1] ----------------------------
 * z = (x - mu) / sigma restricted to [alpha, beta];  p(x) = phi(z) / (sigma Z),
 * Z = Phi(beta) - Phi(alpha).  Sampling inverts Phi with Acklam's rational
 * approximation, whose relative error (1.2e-9) is far below float rounding,
 * so x = mu + sigma z is exact to float precision and its density is p(x) up
 * to rounding.  Both CDF values are carried, P = Phi(z) and Q = 1 - Phi(z),
 * each formed where it is small (P = p_lo + u dP, Q = q_hi + (1 - u) dP,
 * 1 - u being exact for the engine's uniforms), so both tails keep their
 * digits; the host mirrors the problem (z -> -z) when alpha > 0.
 * Float arithmetic throughout: double vectors and the double erfc of a
 * refinement step cost 25x the plain estimator on PoCL. */
MC_INLINE floatv norm_quantile(floatv p, floatv q) {
    const float a0 = -3.969683028665376e+01f, a1 = 2.209460984245205e+02f, a2 = -2.759285104469687e+02f,
                a3 = 1.383577518672690e+02f, a4 = -3.066479806614716e+01f, a5 = 2.506628277459239e+00f;
    const float b0 = -5.447609879822406e+01f, b1 = 1.615858368580409e+02f, b2 = -1.556989798598866e+02f,
                b3 = 6.680131188771972e+01f, b4 = -1.328068155288572e+01f;
    const float c0 = -7.784894002430293e-03f, c1 = -3.223964580411365e-01f, c2 = -2.400758277161838e+00f,
                c3 = -2.549732539343734e+00f, c4 = 4.374664141464968e+00f, c5 = 2.938163982698783e+00f;
    const float d0 = 7.784695709041462e-03f, d1 = 3.224671290700398e-01f, d2 = 2.445134137142996e+00f,
                d3 = 3.754408661907416e+00f;
    const float plow = 0.02425f;
    /* central region */
    const floatv c = p - 0.5f;
    const floatv r = c * c;
    const floatv zc = (((((a0 * r + a1) * r + a2) * r + a3) * r + a4) * r + a5) * c /
                      (((((b0 * r + b1) * r + b2) * r + b3) * r + b4) * r + 1.0f);
    /* tails: the smaller of P and Q, each accurate */
    const floatv pt = lane_select(p, q, p > 0.5f);
    const floatv s = sqrt(-2.0f * log(pt));
    const floatv zt = (((((c0 * s + c1) * s + c2) * s + c3) * s + c4) * s + c5) /
                      ((((d0 * s + d1) * s + d2) * s + d3) * s + 1.0f);
    return lane_select(zc, lane_select(-zt, zt, p < plow), (p < plow) | (q < plow));
}

MC_INLINE floatv pdf_truncnorm(floatv x, float mu, float inv_sigma, float norm) {
    floatv z = (x - mu) * inv_sigma;
    return norm * exp(-0.5f * z * z);
}

/* sign = +1, or -1 when the host mirrored the problem; norm = 1/(sigma Z sqrt(2 pi));
 * p_lo = Phi(lo), q_hi = 1 - Phi(hi), dp = Phi(hi) - Phi(lo). */
MC_INLINE floatv warp_truncnorm(floatv u, float mu, float sigma, float sign, float p_lo, float q_hi, float dp,
                                float norm, floatv *pdf) {
    const floatv z = norm_quantile(p_lo + u * dp, q_hi + (1.0f - u) * dp);
    const floatv x = clamp_open01(mu + (sign * sigma) * z);
    *pdf = pdf_truncnorm(x, mu, 1.0f / sigma, norm);
    return x;
}

#endif
