/* lane_io.cl — loading and storing whole lane vectors from and to
 * structure-of-arrays buffers (component c of item i at c * n + i). */
#ifndef MCOCL_RENDER_LANE_IO_CL
#define MCOCL_RENDER_LANE_IO_CL

#include "lanes.cl"

#if LANES == 1
#define store_floatv(v, p) (*(p) = (v))
#define load_floatv(p) (*(p))
#else
#define store_floatv(v, p) MC_CAT(vstore, LANE_SUFFIX)((v), 0, (p))
#define load_floatv(p) MC_CAT(vload, LANE_SUFFIX)(0, (p))
#endif

#endif
