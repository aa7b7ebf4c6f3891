/* lane_store.cl — moving a lane vector to and from a private array, the same
 * spelling for the scalar build (LANES=1 has no vstore1). */
#ifndef MCOCL_WALK_LANE_STORE_CL
#define MCOCL_WALK_LANE_STORE_CL

#include "lanes.cl"

#if LANES == 1
#define WALK_STORE(v, p) (*(p) = (v))
#define WALK_LOAD(p) (*(p))
#else
#define WALK_STORE(v, p) MC_CAT(vstore, LANE_SUFFIX)((v), 0, (p))
#define WALK_LOAD(p) MC_CAT(vload, LANE_SUFFIX)(0, (p))
#endif

#endif
