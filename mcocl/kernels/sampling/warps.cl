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
 * Z = Phi(beta) - Phi(alpha).  Sampling inverts Phi in double precision:
 * Acklam's rational approximation (relative error 1.2e-9) and one Halley
 * step against erfc, accurate to double rounding.  To keep the CDF values
 * away from 1, where they lose their digits, the host mirrors the problem
 * (z -> -z) whenever alpha > 0 so that the sampled tail is always the lower one:
 * then p = p_lo + u (p_hi - p_lo) with p_lo = Phi(alpha), p_hi = Phi(beta). */
MC_INLINE doublev norm_cdf_d(doublev z) { return 0.5 * erfc(-z * M_SQRT1_2); }

MC_INLINE doublev norm_quantile_d(doublev p) {
    const double a0 = -3.969683028665376e+01, a1 = 2.209460984245205e+02, a2 = -2.759285104469687e+02,
                 a3 = 1.383577518672690e+02, a4 = -3.066479806614716e+01, a5 = 2.506628277459239e+00;
    const double b0 = -5.447609879822406e+01, b1 = 1.615858368580409e+02, b2 = -1.556989798598866e+02,
                 b3 = 6.680131188771972e+01, b4 = -1.328068155288572e+01;
    const double c0 = -7.784894002430293e-03, c1 = -3.223964580411365e-01, c2 = -2.400758277161838e+00,
                 c3 = -2.549732539343734e+00, c4 = 4.374664141464968e+00, c5 = 2.938163982698783e+00;
    const double d0 = 7.784695709041462e-03, d1 = 3.224671290700398e-01, d2 = 2.445134137142996e+00,
                 d3 = 3.754408661907416e+00;
    const double plow = 0.02425;
    /* central region */
    doublev q = p - 0.5;
    doublev r = q * q;
    doublev zc = (((((a0 * r + a1) * r + a2) * r + a3) * r + a4) * r + a5) * q /
                 (((((b0 * r + b1) * r + b2) * r + b3) * r + b4) * r + 1.0);
    /* tails, by symmetry on min(p, 1 - p) */
    doublev pt = lane_select_d(p, 1.0 - p, p > 0.5);
    doublev s = sqrt(-2.0 * log(pt));
    doublev zt = (((((c0 * s + c1) * s + c2) * s + c3) * s + c4) * s + c5) /
                 ((((d0 * s + d1) * s + d2) * s + d3) * s + 1.0);
#if LANES == 1
    doublev z = (p < plow) ? zt : ((p > 1.0 - plow) ? -zt : zc);
#else
    doublev z = lane_select_d(zc, lane_select_d(-zt, zt, p < plow), (p < plow) | (p > 1.0 - plow));
#endif
    /* Halley step: e = Phi(z) - p; z -= e / (phi(z) (1 + z e / (2 phi(z)))) */
    doublev e = norm_cdf_d(z) - p;
    doublev u = e * 2.5066282746310002 * exp(0.5 * z * z);
    return z - u / (1.0 + 0.5 * z * u);
}

MC_INLINE floatv pdf_truncnorm(floatv x, float mu, float inv_sigma, float norm) {
    floatv z = (x - mu) * inv_sigma;
    return norm * exp(-0.5f * z * z);
}

/* sign = +1, or -1 when the host mirrored the problem; norm = 1/(sigma Z sqrt(2 pi)). */
MC_INLINE floatv warp_truncnorm(floatv u, double mu, double sigma, double sign, double p_lo, double p_hi,
                             float norm, floatv *pdf) {
    doublev p = p_lo + to_doublev(u) * (p_hi - p_lo);
    doublev z = norm_quantile_d(p);
    floatv x = clamp_open01(to_floatv(mu + sign * sigma * z));
    *pdf = pdf_truncnorm(x, (float)mu, (float)(1.0 / sigma), norm);
    return x;
}

#endif
