/* shadow_queue.cl — deferred shadow rays, traced in full packets (bdpt.cl).
 *
 * bdpt.cl evaluates a connection strategy (s, t) for the LANES samples of a
 * packet at once, but a strategy exists only in the lanes whose subpaths are
 * long enough: measured on the Cornell box (LANES 16, bench/bdpt_efficiency.py's
 * scenes), about a quarter of the lanes of a connection's shadow ray were
 * active, and a packet traversal (trace_packet.cl) costs about as much for a
 * few incoherent rays as for sixteen.  So a connection does not trace its
 * shadow ray at once: it pushes, for each lane that needs one, the ray and
 * the weighted contribution it would add into this queue, compacted in push
 * order (strategy by strategy, lanes in order within a strategy), and the
 * queue traces LANES entries at a time as one packet (the "stream
 * compaction" of wavefront path tracers, Laine, Karras and Aila, "Megakernels
 * Considered Harmful", HPG 2013, section 4).
 *
 * An entry's contribution goes, when its ray is clear, either to a pixel of
 * the splat film (splat_one, a t = 1 strategy) or to the running sum of a
 * lane of the packet (the sample's own pixel, t >= 2).  Entries are applied
 * in push order, so every pixel of the film and every lane's sum receive the
 * same additions in the same order as when each ray was traced at once: the
 * image is the same, bit for bit, and it does not depend on timing.  An entry
 * may need no ray (strategy s = 0); it still goes through the queue, so that
 * its lane's sum keeps its order.
 */
#ifndef MCOCL_RENDER_SHADOW_QUEUE_CL
#define MCOCL_RENDER_SHADOW_QUEUE_CL

#include "render/trace.cl"

/* Room for one packet waiting to be traced and one push of LANES entries: a ring of two packets'
 * slots, whose head is slot 0 or slot LANES (a packet is traced only when LANES entries wait, or
 * when the queue drains), so that every traced packet is LANES consecutive slots. */
#define SHADOW_QUEUE_SIZE (2 * LANES)
/* A target with this bit set is a lane's own sum (the lane in the low bits), otherwise a pixel. */
#define SHADOW_TO_LANE 0x80000000u

/* A shadow ray: origin, unit direction and the distance it must be clear for. */
typedef struct {
    vec3v o, d;
    floatv tmax;
} shadow_ray_v;

typedef struct {
    float ox[SHADOW_QUEUE_SIZE], oy[SHADOW_QUEUE_SIZE], oz[SHADOW_QUEUE_SIZE];
    float dx[SHADOW_QUEUE_SIZE], dy[SHADOW_QUEUE_SIZE], dz[SHADOW_QUEUE_SIZE];
    float tmax[SHADOW_QUEUE_SIZE];
    int traced[SHADOW_QUEUE_SIZE];          /* the entry has a ray (otherwise it is clear) */
    float cr[SHADOW_QUEUE_SIZE], cg[SHADOW_QUEUE_SIZE], cb[SHADOW_QUEUE_SIZE];
    uint target[SHADOW_QUEUE_SIZE];
    int head, n;                            /* the first waiting entry's slot; entries waiting */
    float sum_r[LANES], sum_g[LANES], sum_b[LANES]; /* each lane's sum of its applied entries */
} shadow_queue;

/* The segment from a (normal na) to b as a shadow ray, as bdpt.cl's connections and
 * lt.cl's camera_visible trace it: from an offset origin, clear up to b less SHADOW_EPSILON. */
MC_INLINE shadow_ray_v shadow_segment(vec3v a, vec3v na, vec3v b) {
    shadow_ray_v r;
    r.d = v3_normalize(v3_sub(b, a));
    r.o = offset_origin(a, na, r.d);
    r.tmax = lane_sqrt(v3_len2(v3_sub(b, r.o))) * (1.0f - SHADOW_EPSILON);
    return r;
}

/* An empty queue with zero lane sums (every slot written: the packet loads read whole slots). */
MC_INLINE void shadow_queue_init(shadow_queue *q) {
    for (int k = 0; k < SHADOW_QUEUE_SIZE; ++k) {
        q->ox[k] = q->oy[k] = q->oz[k] = 0.0f;
        q->dx[k] = q->dy[k] = 0.0f;
        q->dz[k] = 1.0f;
        q->tmax[k] = 0.0f;
        q->traced[k] = 0;
        q->cr[k] = q->cg[k] = q->cb[k] = 0.0f;
        q->target[k] = 0u;
    }
    q->head = q->n = 0;
    for (int k = 0; k < LANES; ++k) q->sum_r[k] = q->sum_g[k] = q->sum_b[k] = 0.0f;
}

/* Trace the first m <= LANES entries as one packet and apply the clear ones in order; the queue's
 * head moves on by m (m < LANES only when the queue drains: it is then empty, head back at 0). */
MC_INLINE void shadow_queue_trace(shadow_queue *q, const scene_geom *g, global film_t *img, int m) {
    const int h = q->head;
    vec3v o = v3(load_floatv(q->ox + h), load_floatv(q->oy + h), load_floatv(q->oz + h));
    vec3v d = v3(load_floatv(q->dx + h), load_floatv(q->dy + h), load_floatv(q->dz + h));
#if LANES == 1
    const intv traced = m > 0 && q->traced[h];
#else
    const intv traced = (LANE_IOTA < (uintv)((uint)m)) & (MC_CAT(vload, LANE_SUFFIX)(0, q->traced + h) != 0);
#endif
    int_lanes occ;
    occ.v = lane_any(traced) ? trace_any_v(g, o, d, load_floatv(q->tmax + h), traced) : (intv)(0);
    for (int k = 0; k < m; ++k) {
        if (occ.a[k]) continue;
        const int e = h + k;
        const uint to = q->target[e];
        if (to & SHADOW_TO_LANE) {
            const uint lane = to & ~SHADOW_TO_LANE;
            q->sum_r[lane] += q->cr[e];
            q->sum_g[lane] += q->cg[e];
            q->sum_b[lane] += q->cb[e];
        } else {
            splat_one(img, to, q->cr[e], q->cg[e], q->cb[e]);
        }
    }
    q->n -= m;
    q->head = q->n > 0 ? (h + m) & (SHADOW_QUEUE_SIZE - 1) : 0;
}

/* Queue, for the lanes in `push`, contribution c to `target` (a pixel, or SHADOW_TO_LANE | lane) once ray r
 * is clear (lanes in `traced`; the others need no ray); a full packet is traced at once. */
MC_INLINE void shadow_queue_push(shadow_queue *q, const scene_geom *g, global film_t *img, shadow_ray_v r, vec3v c,
                                 uintv target, intv push, intv traced) {
    float_lanes ox, oy, oz, dx, dy, dz, tm, cr, cg, cb;
    uint_lanes to;
    int_lanes on, tr;
    ox.v = r.o.x; oy.v = r.o.y; oz.v = r.o.z;
    dx.v = r.d.x; dy.v = r.d.y; dz.v = r.d.z;
    tm.v = r.tmax;
    cr.v = c.x; cg.v = c.y; cb.v = c.z;
    to.v = target;
    on.v = push;
    tr.v = traced;
    for (int k = 0; k < LANES; ++k) {
        if (!on.a[k]) continue;
        const int j = (q->head + q->n++) & (SHADOW_QUEUE_SIZE - 1);
        q->ox[j] = ox.a[k]; q->oy[j] = oy.a[k]; q->oz[j] = oz.a[k];
        q->dx[j] = dx.a[k]; q->dy[j] = dy.a[k]; q->dz[j] = dz.a[k];
        q->tmax[j] = tm.a[k];
        q->traced[j] = tr.a[k] != 0;
        q->cr[j] = cr.a[k]; q->cg[j] = cg.a[k]; q->cb[j] = cb.a[k];
        q->target[j] = to.a[k];
    }
    if (q->n >= LANES) shadow_queue_trace(q, g, img, LANES);
}

/* Trace and apply every waiting entry (the end of a packet: its lanes' sums are then complete). */
MC_INLINE void shadow_queue_drain(shadow_queue *q, const scene_geom *g, global film_t *img) {
    while (q->n > 0) shadow_queue_trace(q, g, img, min(q->n, LANES));
}

/* The lanes' sums as a lane vector, and zero sums for the next packet. */
MC_INLINE vec3v shadow_queue_take_sums(shadow_queue *q) {
    vec3v s = v3(load_floatv(q->sum_r), load_floatv(q->sum_g), load_floatv(q->sum_b));
    for (int k = 0; k < LANES; ++k) q->sum_r[k] = q->sum_g[k] = q->sum_b[k] = 0.0f;
    return s;
}

#endif
