/* sampler.cl — the one interface through which estimators draw their
 * uniforms (integration, random walks, rendering; as pbrt-v4's Sampler and
 * Mitsuba 3's sampler plugins).
 *
 * A sample is addressed by (seed, sample index, stream): the index says which
 * sample of the estimator this is, the stream which consumer draws
 * (rng/streams.cl).  Its coordinates are dimensions 0, 1, 2, ... handed out by
 * a per-lane dimension counter, held in an mc_sampler_t (OpenCL reserves the
 * name sampler_t for image samplers):
 *
 *   mc_sampler_t sampler_start(ulong seed, ulongv index, uint stream)
 *   mc_sampler_t sampler_start_at(ulong seed, ulong base, uintv offset, uint stream)
 *                                     sample base + offset (per lane)
 *   void   sampler_seek(mc_sampler_t *s, uintv dim)   set the counter (per lane):
 *                                     consumers with a fixed layout per depth
 *                                     or step start each group at its dimension
 *   floatv sampler_next_1d(mc_sampler_t *s)
 *   void   sampler_next_2d(mc_sampler_t *s, floatv *u)      u[0], u[1]
 *   void   sampler_next_nd(mc_sampler_t *s, int n, floatv *u)  u[0 .. n-1]
 *   void   sampler_next_nd_d(mc_sampler_t *s, int n, doublev *u)  the same
 *                                     dimensions in double, on the 2^-32 grid
 *                                     (rng/uniform.cl, u01d): precision="double"
 *   mc_sampler_t sampler_select(mc_sampler_t a, mc_sampler_t b, intv m)  m ? b : a per lane
 *
 * Every uniform lies on the grid of rng/uniform.cl (cell centres in (0, 1)).
 * Draw a group of coordinates with one call where you can: a back end may
 * make a group cheaper than its dimensions one by one (Philox: one call per
 * four dimensions).
 *
 * Back ends, chosen at build time by -DSAMPLER_BACKEND=...:
 *   SAMPLER_BACKEND_PHILOX  independent uniforms from Philox4x32-10
 *                           (samplers/philox_sampler.cl); the default.
 *   SAMPLER_BACKEND_SOBOL   Owen-scrambled Sobol' points, one scrambling per
 *                           2^SOBOL_LOG2_POINTS consecutive indices
 *                           (samplers/sobol_sampler.cl).
 * A new back end (e.g. Owen-scrambled Sobol) is one file defining mc_sampler_t
 * and the functions above, plus a line below; the estimators do not change.
 * Random numbers that are not sample coordinates (N-rooks permutation keys)
 * stay with rng/uniform.cl whatever the back end.
 */
#ifndef MCOCL_SAMPLER_CL
#define MCOCL_SAMPLER_CL

#define SAMPLER_BACKEND_PHILOX 0
#define SAMPLER_BACKEND_SOBOL 1

#ifndef SAMPLER_BACKEND
#define SAMPLER_BACKEND SAMPLER_BACKEND_PHILOX
#endif

/* Before the choice: includes are resolved once per program, as text, so a
 * file two back ends share must not sit inside one back end's #if. */
#include "rng/uniform.cl"
/* shared by the sobol back end and bdpt's film points (render/bdpt.cl) */
#include "samplers/owen_scramble.cl"

#if SAMPLER_BACKEND == SAMPLER_BACKEND_PHILOX
#include "samplers/philox_sampler.cl"
#elif SAMPLER_BACKEND == SAMPLER_BACKEND_SOBOL
#include "samplers/sobol_sampler.cl"
#else
#error "unknown SAMPLER_BACKEND"
#endif

#endif
