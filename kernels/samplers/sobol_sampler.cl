/* sobol_sampler.cl — the sampler back end of randomised quasi-Monte Carlo
 * (samplers/sampler.cl): Owen-scrambled Sobol' points.
 *
 * Addressing.  Sample index i (64-bit) is point p = i mod 2^SOBOL_LOG2_POINTS
 * of scrambling (replicate) r = i >> SOBOL_LOG2_POINTS, so a replicate's
 * points are one contiguous index range; its first 2^m points (m <=
 * SOBOL_LOG2_POINTS) are a (0, m, 2)-net in dimensions 0-1 whatever the
 * scrambling (Owen 1995: nested uniform scrambling keeps the net property).
 *
 * Coordinate j of the point, 32 bits, in three steps:
 *   1. Sobol' (Joe-Kuo direction numbers, samplers/sobol_joe_kuo_1024.cl),
 *      evaluated directly, not in Gray-code order: x = XOR of V_k over the
 *      set bits k of p.  Each sample costs the same and depends on p alone.
 *      The table holds V_k bit-reversed, and XOR commutes with bit reversal,
 *      so x comes out reversed, as step 2 wants it.
 *   2. Nested uniform (Owen) scrambling by hashing (Laine and Karras 2011;
 *      Burley 2020, "Practical Hash-based Owen Scrambling", JCGT 9(4), sec. 3):
 *      on the reversed bits, the Laine-Karras permutation with seed s_j
 *      flips each bit by a hash of the bits below it (the more significant
 *      bits of the coordinate), which is Owen's nested scrambling.  Burley's
 *      constants.  Then reverse back (samplers/owen_scramble.cl, shared
 *      with bdpt's film positions).
 *   3. The top 23 bits -> the cell centre of rng/uniform.cl's grid (never 0
 *      nor 1, unbiased on the grid).
 * s_j, the seed of dimension j of replicate r, is word j % 4 of
 * Philox4x32-10(counter = (lo32(r), hi32(r), j / 4, stream), key = seed)
 * (rng/uniform.cl, with the replicate in place of the sample index): every
 * replicate and every dimension is an independent scrambling.
 *
 * The numbers of (seed, i, j, stream) depend on nothing else: not the lane,
 * the device, nor the launch split.  Dimensions j < SOBOL_TABLE_DIMS (the
 * host sizes the table to the coordinates a program draws, at most 1024)
 * are Sobol' coordinates; later ones are padded (sobol_padded_reversed).
 */
#ifndef MCOCL_SOBOL_SAMPLER_CL
#define MCOCL_SOBOL_SAMPLER_CL

#include "rng/uniform.cl"
#include "samplers/sobol_joe_kuo_1024.cl"
#include "samplers/owen_scramble.cl"

/* log2 of the points of one scrambling (host: mcocl/integration/samplers.py, Sobol). */
#ifndef SOBOL_LOG2_POINTS
#define SOBOL_LOG2_POINTS 16
#endif
#if SOBOL_LOG2_POINTS < 0 || SOBOL_LOG2_POINTS > 31
#error "SOBOL_LOG2_POINTS must be in 0..31"
#endif

typedef struct {
    rng_t replicate;  /* which scrambling (index >> SOBOL_LOG2_POINTS), seed, stream */
    uintv point;      /* index within the scrambling, per lane */
    uintv dim;        /* the next dimension, per lane */
    uint high;        /* the point's bits from SOBOL_LANE_BITS up, when the same in every lane */
    int same_high;    /* whether they are (a packet of consecutive points, as integrate.cl draws) */
    int same_replicate; /* whether every lane is in one replicate (its seeds: one scalar Philox call) */
} mc_sampler_t;

#if LANES == 1
#define SOBOL_LANE0(x) (x)
#define SOBOL_LANE_BITS 0
#else
#define SOBOL_LANE0(x) ((x).s0)
#define SOBOL_LANE_BITS (LANES == 2 ? 1 : LANES == 4 ? 2 : LANES == 8 ? 3 : 4)
#endif
#define SOBOL_LOW_MASK ((1u << SOBOL_LANE_BITS) - 1u)

/* Split the index (lo, hi words) into replicate and point. */
MC_INLINE mc_sampler_t sobol_split(uintv lo, uintv hi, ulong seed, uint stream) {
    mc_sampler_t s;
#if SOBOL_LOG2_POINTS == 0
    s.point = (uintv)(0u);
    s.replicate.lo = lo;
    s.replicate.hi = hi;
#else
    s.point = lo & (uintv)((1u << SOBOL_LOG2_POINTS) - 1u);
    s.replicate.lo = (lo >> SOBOL_LOG2_POINTS) | (hi << (32 - SOBOL_LOG2_POINTS));
    s.replicate.hi = hi >> SOBOL_LOG2_POINTS;
#endif
    s.replicate.k0 = (uint)(seed & 0xffffffffu);
    s.replicate.k1 = (uint)(seed >> 32);
    s.replicate.stream = stream;
    s.dim = (uintv)(0u);
    s.high = SOBOL_LANE0(s.point) & ~SOBOL_LOW_MASK;
    s.same_high = !lane_any((s.point & ~SOBOL_LOW_MASK) != (uintv)(s.high));
    s.same_replicate = !lane_any((s.replicate.lo != (uintv)(SOBOL_LANE0(s.replicate.lo)))
                                 | (s.replicate.hi != (uintv)(SOBOL_LANE0(s.replicate.hi))));
    return s;
}

/* The scrambling seeds of dimensions 4 block .. 4 block + 3 (the same block
 * in every lane): rng_block's words, from one scalar Philox call when every
 * lane is in one replicate (40 % of the sobol integration kernel's time
 * went to the vector call). */
MC_INLINE philox_ctr sobol_seed_block(const mc_sampler_t *s, uint block) {
    if (!s->same_replicate) return rng_block(s->replicate, (uintv)(block));
    const uint4 w = philox4x32_10_1((uint4)(SOBOL_LANE0(s->replicate.lo), SOBOL_LANE0(s->replicate.hi), block,
                                            s->replicate.stream), s->replicate.k0, s->replicate.k1);
    philox_ctr c;
    c.v0 = (uintv)(w.x); c.v1 = (uintv)(w.y); c.v2 = (uintv)(w.z); c.v3 = (uintv)(w.w);
    return c;
}

MC_INLINE mc_sampler_t sampler_start(ulong seed, ulongv index, uint stream) {
    return sobol_split(to_uintv(index & (ulong)0xffffffffu), to_uintv(index >> 32), seed, stream);
}

MC_INLINE mc_sampler_t sampler_start_at(ulong seed, ulong base, uintv offset, uint stream) {
    const rng_t r = rng_init_offset(base, offset, seed, stream);
    return sobol_split(r.lo, r.hi, seed, stream);
}

MC_INLINE void sampler_seek(mc_sampler_t *s, uintv dim) { s->dim = dim; }

/* Step 1: the bit-reversed Sobol' coordinate of dimension d (the same in every
 * lane) at the points p: XOR of the reversed V_k over the set bits of p. */
MC_INLINE uintv sobol_reversed(uintv p, uint d) {
    constant uint *rv = SOBOL_RV + 32u * d;
    uintv x = (uintv)(0u);
    for (int k = 0; k < SOBOL_LOG2_POINTS; ++k) x ^= (uintv)(rv[k]) & ((uintv)(0u) - ((p >> k) & 1u));
    return x;
}

MC_INLINE uint sobol_reversed1(uint p, uint d) {
    constant uint *rv = SOBOL_RV + 32u * d;
    uint x = 0u;
    /* stop at p's top set bit: a render build's SOBOL_LOG2_POINTS may exceed its blocks' points */
    for (int k = 0; k < SOBOL_LOG2_POINTS && (p >> k) != 0u; ++k) x ^= rv[k] & (0u - ((p >> k) & 1u));
    return x;
}

/* Step 1 for a packet whose points share their bits from SOBOL_LANE_BITS up
 * (s->same_high): by linearity over GF(2), x(p) = x(high) ^ x(p mod LANES),
 * the first a scalar loop, the second a vector loop of SOBOL_LANE_BITS steps.
 * The same bits as sobol_reversed, at a fraction of the vector work. */
MC_INLINE uintv sobol_reversed_packet(const mc_sampler_t *s, uint d) {
    if (!s->same_high) return sobol_reversed(s->point, d);
    constant uint *rv = SOBOL_RV + 32u * d;
    uint xh = 0u;
    for (int k = SOBOL_LANE_BITS; k < SOBOL_LOG2_POINTS && (s->high >> k) != 0u; ++k)
        xh ^= rv[k] & (0u - ((s->high >> k) & 1u));
    uintv x = (uintv)(xh);
    for (int k = 0; k < SOBOL_LANE_BITS && k < SOBOL_LOG2_POINTS; ++k)
        x ^= (uintv)(rv[k]) & ((uintv)(0u) - ((s->point >> k) & 1u));
    return x;
}

/* Step 1 where the lanes may be at different dimensions (after a per-lane
 * sampler_seek): one lane at a time. */
MC_INLINE uintv sobol_reversed_lanes(uintv p, uintv d) {
    if (!lane_any(d != (uintv)(SOBOL_LANE0(d)))) return sobol_reversed(p, SOBOL_LANE0(d));
#if LANES == 1
    return sobol_reversed1(p, d);
#else
    uint pl[LANES], dl[LANES], xl[LANES];
    MC_CAT(vstore, LANES)(p, 0, pl);
    MC_CAT(vstore, LANES)(d, 0, dl);
    for (int l = 0; l < LANES; ++l) xl[l] = sobol_reversed1(pl[l], dl[l]);
    return MC_CAT(vload, LANES)(0, xl);
#endif
}

/* sobol_reversed_lanes of dimensions d .. d + rows - 1 (per lane, all in the
 * table; rows <= SOBOL_MAX_ROWS): one pass over the point bits for all rows
 * (which are consecutive in SOBOL_RV), instead of one per row.  The render's
 * vertices draw 4 or 8 dimensions at a time (render/integrator.cl), the lanes
 * at different depths, so at different dimensions, but mostly at one point
 * (sample s of their pixels).  Then the lanes go in groups of one dimension,
 * each group a scalar XOR over the point's set bits broadcast to its lanes; a
 * packet of several points takes one scalar loop per lane.  Every path XORs
 * the same rows: the same bits. */
#define SOBOL_MAX_ROWS 8
MC_INLINE void sobol_reversed_rows_lanes(uintv p, uintv d, int rows, uintv *x) {
#if LANES == 1
    constant uint *rv = SOBOL_RV + 32u * d;
    for (int i = 0; i < rows; ++i) x[i] = 0u;
    for (int k = 0; k < SOBOL_LOG2_POINTS && (p >> k) != 0u; ++k) {
        const uint m = 0u - ((p >> k) & 1u);
        for (int i = 0; i < rows; ++i) x[i] ^= rv[32 * i + k] & m;
    }
#else
    const uint p0 = SOBOL_LANE0(p);
    if (!lane_any(p != (uintv)(p0))) {
        uint_lanes dl;
        dl.v = d;
        for (int i = 0; i < rows; ++i) x[i] = (uintv)(0u);
        uint todo = (1u << LANES) - 1u; /* the lanes whose group is still to come, as bits */
        while (todo != 0u) {
            const uint dg = dl.a[31u - clz(todo & (0u - todo))]; /* the lowest lane to come (clz: OpenCL 1.2) */
            constant uint *rv = SOBOL_RV + 32u * dg;
            uint y[SOBOL_MAX_ROWS];
            for (int i = 0; i < rows; ++i) y[i] = 0u;
            for (uint b = p0; b != 0u; b &= b - 1u) {
                const uint k = 31u - clz(b & (0u - b));
                for (int i = 0; i < rows; ++i) y[i] ^= rv[32 * i + k];
            }
            const intv in_group = d == (uintv)(dg);
            for (int i = 0; i < rows; ++i) x[i] = lane_select(x[i], (uintv)(y[i]), in_group);
            todo &= ~lane_bits(in_group);
        }
        return;
    }
    uint pl[LANES], dl[LANES], xl[SOBOL_MAX_ROWS][LANES];
    MC_CAT(vstore, LANES)(p, 0, pl);
    MC_CAT(vstore, LANES)(d, 0, dl);
    for (int l = 0; l < LANES; ++l) {
        constant uint *rv = SOBOL_RV + 32u * dl[l];
        uint y[SOBOL_MAX_ROWS];
        for (int i = 0; i < rows; ++i) y[i] = 0u;
        for (int k = 0; k < SOBOL_LOG2_POINTS && (pl[l] >> k) != 0u; ++k) {
            const uint m = 0u - ((pl[l] >> k) & 1u);
            for (int i = 0; i < rows; ++i) y[i] ^= rv[32 * i + k] & m;
        }
        for (int i = 0; i < rows; ++i) xl[i][l] = y[i];
    }
    for (int i = 0; i < rows; ++i) x[i] = MC_CAT(vload, LANES)(0, xl[i]);
#endif
}

/* Dimensions j >= SOBOL_TABLE_DIMS, drawn only by consumers of unbounded
 * depth (render paths deeper than the table; the integration host never
 * asks for them): Burley 2020, sec. 4, padding by shuffling.  The point
 * index is shuffled by a nested uniform scrambling of its own (seed: a hash
 * of the dimension's seed), and the coordinate is dimension 0 of Sobol' (van
 * der Corput, whose reversed bits are the index itself) at the shuffled
 * index.  Each such dimension is a stratified 1-D set, randomly permuted
 * against every other dimension: unbiased, without the table. */
MC_INLINE uintv sobol_padded_reversed(uintv p, uintv s) {
    uintv h = s ^ (s >> 16);  /* a 32-bit integer hash (lowbias32's constants) */
    h *= 0x7feb352du;
    h ^= h >> 15;
    h *= 0x846ca68bu;
    h ^= h >> 16;
    return reverse_bits(laine_karras(reverse_bits(p), h));
}

/* The scrambled bits of dimensions d (per lane) with scrambling seeds `seed`:
 * from the table, or padded past it. */
MC_INLINE uintv sobol_bits_lanes(const mc_sampler_t *s, uintv d, uintv seed) {
    const intv past = d >= (uintv)(SOBOL_TABLE_DIMS);
    uintv x;
    if (lane_any(past)) {
        x = lane_select(sobol_reversed_lanes(s->point, lane_select(d, (uintv)(0u), past)),
                        sobol_padded_reversed(s->point, seed), past);
    } else {
        x = sobol_reversed_lanes(s->point, d);
    }
    return owen_bits(x, seed);
}

/* The uniform of dimensions d (per lane) with scrambling seeds `seed`. */
MC_INLINE floatv sobol_uniform_lanes(const mc_sampler_t *s, uintv d, uintv seed) {
    return u01(sobol_bits_lanes(s, d, seed));
}

MC_INLINE floatv sampler_next_1d(mc_sampler_t *s) {
    const uintv seed = philox_word(rng_block(s->replicate, s->dim >> 2), s->dim & 3u);
    const floatv u = sobol_uniform_lanes(s, s->dim, seed);
    s->dim += 1u;
    return u;
}

/* n consecutive dimensions: one Philox call (four scrambling seeds) per four
 * dimensions when the counter is a multiple of 4 in every lane (as in every
 * present consumer), the packet shortcut of sobol_reversed_packet when it is
 * moreover the same in every lane and inside the table; else one dimension
 * at a time.  The three paths give the same numbers. */
MC_INLINE void sampler_next_nd(mc_sampler_t *s, int n, floatv *u) {
    const uint d0 = SOBOL_LANE0(s->dim);
    if (lane_any((s->dim & 3u) != 0u)) {
        for (int j = 0; j < n; ++j) u[j] = sampler_next_1d(s);
        return;
    }
    if (lane_any(s->dim != (uintv)(d0)) || d0 + (uint)n > (uint)SOBOL_TABLE_DIMS) {
        if (n == 8 && !lane_any(s->dim + 7u >= (uintv)(SOBOL_TABLE_DIMS))) {
            /* a render vertex's BSDF and light blocks at once: one pass over the groups for eight rows */
            uintv x[8];
            sobol_reversed_rows_lanes(s->point, s->dim, 8, x);
            const philox_ctr c = rng_block(s->replicate, s->dim >> 2);
            const philox_ctr e = rng_block(s->replicate, (s->dim >> 2) + 1u);
            u[0] = owen_uniform(x[0], c.v0);
            u[1] = owen_uniform(x[1], c.v1);
            u[2] = owen_uniform(x[2], c.v2);
            u[3] = owen_uniform(x[3], c.v3);
            u[4] = owen_uniform(x[4], e.v0);
            u[5] = owen_uniform(x[5], e.v1);
            u[6] = owen_uniform(x[6], e.v2);
            u[7] = owen_uniform(x[7], e.v3);
            s->dim += 8u;
            return;
        }
        for (int j = 0; j < n; j += 4) {  /* walks and paths: lanes at different depths */
            const uintv dj = s->dim + (uint)j;
            const philox_ctr c = rng_block(s->replicate, dj >> 2);
            if (j + 4 <= n && !lane_any(dj + 3u >= (uintv)(SOBOL_TABLE_DIMS))) {
                uintv x[4];
                sobol_reversed_rows_lanes(s->point, dj, 4, x);
                u[j] = owen_uniform(x[0], c.v0);
                u[j + 1] = owen_uniform(x[1], c.v1);
                u[j + 2] = owen_uniform(x[2], c.v2);
                u[j + 3] = owen_uniform(x[3], c.v3);
                continue;
            }
            u[j] = sobol_uniform_lanes(s, dj, c.v0);
            if (j + 1 < n) u[j + 1] = sobol_uniform_lanes(s, dj + 1u, c.v1);
            if (j + 2 < n) u[j + 2] = sobol_uniform_lanes(s, dj + 2u, c.v2);
            if (j + 3 < n) u[j + 3] = sobol_uniform_lanes(s, dj + 3u, c.v3);
        }
        s->dim += (uint)n;
        return;
    }
    for (int j = 0; j < n; j += 4) {
        const philox_ctr c = sobol_seed_block(s, (d0 + (uint)j) >> 2);
        u[j] = owen_uniform(sobol_reversed_packet(s, d0 + (uint)j), c.v0);
        if (j + 1 < n) u[j + 1] = owen_uniform(sobol_reversed_packet(s, d0 + (uint)j + 1u), c.v1);
        if (j + 2 < n) u[j + 2] = owen_uniform(sobol_reversed_packet(s, d0 + (uint)j + 2u), c.v2);
        if (j + 3 < n) u[j + 3] = owen_uniform(sobol_reversed_packet(s, d0 + (uint)j + 3u), c.v3);
    }
    s->dim += (uint)n;
}

/* sampler_next_nd in double (u01d: all 32 scrambled bits), for
 * precision="double" integration: the same points and scramblings, the same
 * two paths (the packet shortcut where sampler_next_nd takes it). */
MC_INLINE void sampler_next_nd_d(mc_sampler_t *s, int n, doublev *u) {
    const uint d0 = SOBOL_LANE0(s->dim);
    if (lane_any(s->dim != (uintv)(d0)) || (d0 & 3u) != 0u || d0 + (uint)n > (uint)SOBOL_TABLE_DIMS) {
        for (int j = 0; j < n; ++j) {
            const uintv d = s->dim + (uint)j;
            u[j] = u01d(sobol_bits_lanes(s, d, philox_word(rng_block(s->replicate, d >> 2), d & 3u)));
        }
        s->dim += (uint)n;
        return;
    }
    for (int j = 0; j < n; j += 4) {
        const philox_ctr c = sobol_seed_block(s, (d0 + (uint)j) >> 2);
        u[j] = u01d(owen_bits(sobol_reversed_packet(s, d0 + (uint)j), c.v0));
        if (j + 1 < n) u[j + 1] = u01d(owen_bits(sobol_reversed_packet(s, d0 + (uint)j + 1u), c.v1));
        if (j + 2 < n) u[j + 2] = u01d(owen_bits(sobol_reversed_packet(s, d0 + (uint)j + 2u), c.v2));
        if (j + 3 < n) u[j + 3] = u01d(owen_bits(sobol_reversed_packet(s, d0 + (uint)j + 3u), c.v3));
    }
    s->dim += (uint)n;
}

MC_INLINE void sampler_next_2d(mc_sampler_t *s, floatv *u) {
    if (lane_any((s->dim & 1u) != 0u)) {
        u[0] = sampler_next_1d(s);
        u[1] = sampler_next_1d(s);
        return;
    }
    /* an even counter in every lane: the pair is words 0-1 or 2-3 of one Philox block of
     * scrambling seeds, drawn once (the camera's film point and lens point) */
    const philox_ctr c = rng_block(s->replicate, s->dim >> 2);
    const intv upper = (s->dim & 2u) != 0u;
    u[0] = sobol_uniform_lanes(s, s->dim, lane_select(c.v0, c.v2, upper));
    u[1] = sobol_uniform_lanes(s, s->dim + 1u, lane_select(c.v1, c.v3, upper));
    s->dim += 2u;
}

MC_INLINE mc_sampler_t sampler_select(mc_sampler_t a, mc_sampler_t b, intv m) {
    a.replicate.lo = lane_select(a.replicate.lo, b.replicate.lo, m);
    a.replicate.hi = lane_select(a.replicate.hi, b.replicate.hi, m);
    a.point = lane_select(a.point, b.point, m);
    a.dim = lane_select(a.dim, b.dim, m);
    a.high = SOBOL_LANE0(a.point) & ~SOBOL_LOW_MASK;
    a.same_high = !lane_any((a.point & ~SOBOL_LOW_MASK) != (uintv)(a.high));
    a.same_replicate = !lane_any((a.replicate.lo != (uintv)(SOBOL_LANE0(a.replicate.lo)))
                                 | (a.replicate.hi != (uintv)(SOBOL_LANE0(a.replicate.hi))));
    return a;
}

#endif
