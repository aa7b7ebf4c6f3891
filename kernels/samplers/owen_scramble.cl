/* owen_scramble.cl — nested uniform (Owen) scrambling by hashing, and the
 * Owen-scrambled (0, 2)-sequence built on it; shared by the Sobol' sampler
 * back end (samplers/sobol_sampler.cl) and by consumers that want a
 * stratified 2-D point set inside an otherwise independent (Philox) build
 * (bdpt's film positions, render/bdpt.cl).
 *
 * Bits are handled reversed, the order the hash works in: Burley 2020,
 * "Practical Hash-based Owen Scrambling", JCGT 9(4), sec. 3 (Laine and
 * Karras 2011): on the reversed bits, each step of laine_karras changes a bit
 * only by the bits below it, so bit k of the coordinate is flipped by a hash
 * of bits 0..k-1, the more significant bits once reversed back: Owen's
 * nested scrambling.  Burley's constants.
 */
#ifndef MCOCL_OWEN_SCRAMBLE_CL
#define MCOCL_OWEN_SCRAMBLE_CL

#include "rng/uniform.cl"

MC_INLINE uintv reverse_bits(uintv x) {
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
    return (x >> 16) | (x << 16);
}

/* The Laine-Karras permutation of the reversed bits x with seed s (see the header). */
MC_INLINE uintv laine_karras(uintv x, uintv s) {
    x += s;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

/* The scrambled coordinate's 32 bits (in order): u01 or u01d maps them to the grid. */
MC_INLINE uintv owen_bits(uintv x, uintv s) { return reverse_bits(laine_karras(x, s)); }

MC_INLINE floatv owen_uniform(uintv x, uintv s) { return u01(owen_bits(x, s)); }

/* Point p (per lane) of the Owen-scrambled (0, 2)-sequence: Sobol' dimensions
 * 0 and 1 (the first two rows of samplers/sobol_joe_kuo_1024.cl, computed
 * here, not read from the table: dimension 0 is van der Corput, whose
 * reversed coordinate is p itself; dimension 1's reversed direction numbers
 * are the rows of Pascal's triangle mod 2, RV_0 = 1, RV_k = RV_{k-1} ^
 * (RV_{k-1} << 1)), scrambled with seeds s0, s1.  Any prefix of 2^m points
 * is a (0, m, 2)-net, and a prefix of n points is stratified to within one
 * point per elementary interval of the net below n (Owen 1995; the
 * scrambling keeps the net property). */
MC_INLINE void owen_sobol_2d(uintv p, uintv s0, uintv s1, floatv *u) {
    uintv x1 = (uintv)(0u), rv = (uintv)(1u);
    for (uintv b = p; lane_any(b != 0u); b >>= 1u) {
        x1 ^= rv & ((uintv)(0u) - (b & 1u));
        rv ^= rv << 1u;
    }
    u[0] = owen_uniform(p, s0);
    u[1] = owen_uniform(x1, s1);
}

#endif
