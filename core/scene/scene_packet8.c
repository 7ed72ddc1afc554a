/* scene_packet8.c -- the scene's packet queries where the CPU stops at AVX2.
 *
 * scene_packet.c's packets for CPUs without AVX-512: a 16-ray packet walks
 * the top-level BVH as two packets of 8 (bvh_rays8.h), and at a leaf mesh
 * objects take the 8 rays into their own BVH (mesh_packet8.c); every other
 * object is asked ray by ray, through the same struct nearest steps
 * (scene_query.h) that the one-ray search takes, so every ray gets exactly
 * scene_intersect's hit.  The packet shares the node tests of both levels
 * and the triangle tests, where a coherent packet's time goes.  Shadows go
 * by packet when the scene is opaque, as there.
 *
 * The AVX-512 code's extras (spheres and planes tested 16 wide, the
 * light buffers' shortcut for shadow rays) are not here: the rays those
 * would take go one by one or through the walk, to the same answer.
 */
#include "accel/bvh_rays8.h"
#include "scene/scene.h"
#include "scene/scene_query.h"

#ifdef CPU_AVX512

/* A packet's search: each ray's bound and best rank, as struct nearest
 * keeps them for one ray. */
struct scene8 {
    const rayd_scene *s;
    const struct ray16 *rd;
    const ray *r; /* the rays one by one: given, or made into rbuf when needed */
    struct hit *h;
    double tmax[16];
    long best[16];
    const struct object *base; /* ranks: rank0 + (o - base) */
    long rank0;
    uint64_t visits; /* objects the top level's walk visited, each once a lane */
    int half;        /* the lanes 8 half .. 8 half + 7 of the 16 */
    ray rbuf[16];
};

static const ray *lane_rays8(struct scene8 *q) {
    if (q->r) return q->r;
    for (int i = 0; i < 16; i++) q->rbuf[i] = ray16_get(q->rd, i);
    return q->r = q->rbuf;
}

static struct nearest lane_nearest8(struct scene8 *q, int i) {
    return (struct nearest){q->s, NULL, &lane_rays8(q)[i], &q->h[i], q->base, q->rank0, q->best[i]};
}

/* Object o for ray i alone, nearest hit. */
static void visit_lane(struct scene8 *q, const struct object *o, int i) {
    struct nearest c = lane_nearest8(q, i);
    nearest_visit(&c, o, &q->tmax[i]);
    q->best[i] = c.best;
}

/* A mesh for the rays in lanes (of the 16, in q's half), nearest hit: the
 * steps of nearest_visit (nearest_bound, object_hit, nearest_take) lane by
 * lane around one packet query, each hit written straight into h. */
CPU_AVX2_FN void mesh_nearest8(struct scene8 *q, const struct object *o, uint32_t lanes) {
    const struct mesh *m = &q->s->meshes[o->u.mesh.id];
    long rank = q->rank0 + (long)(o - q->base);
    double bound[16], scale[16], lmax[16];
    struct ray16 lrd;
    const struct ray16 *rd = q->rd;
    for (uint32_t k = lanes; k; k &= k - 1) {
        int i = __builtin_ctz(k);
        bound[i] = q->best[i] >= 0 && rank < q->best[i] ? next_up(q->tmax[i]) : q->tmax[i];
        scale[i] = 1, lmax[i] = bound[i];
        if (o->xform >= 0) { /* moved: the rays in its space */
            ray lr = object_ray_xform(q->s, o, &lane_rays8(q)[i], &scale[i]);
            ray16_set(&lrd, i, lr);
            lmax[i] = object_space_bound(bound[i], scale[i]);
            rd = &lrd;
        }
    }
    if (rd == &lrd) ray16_fill_rest(&lrd, lanes);
    struct mesh_hit mh[16];
    uint32_t hit = mesh8_intersect(m, rd, q->half, lmax, lanes, mh);
    for (; hit; hit &= hit - 1) {
        int i = __builtin_ctz(hit);
        if (!object_mesh_nearer(&mh[i], scale[i], bound[i])) continue;
        if ((double)mh[i].t / scale[i] > q->tmax[i]) continue; /* nearest_take's test */
        q->tmax[i] = object_mesh_fill(o, NULL, &mh[i], scale[i], &q->h[i]);
        q->best[i] = rank;
    }
}

CPU_AVX2_FN void visit_nearest8(struct scene8 *q, const struct object *o, uint32_t lanes) {
    if (o->kind == SHAPE_MESH) {
        mesh_nearest8(q, o, lanes);
        return;
    }
    for (; lanes; lanes &= lanes - 1) visit_lane(q, o, __builtin_ctz(lanes));
}

/* Object o for the rays in lanes, any hit: the rays it blocks (the scene
 * is opaque). */
CPU_AVX2_FN uint32_t visit_any8(struct scene8 *q, const struct object *o, uint32_t lanes) {
    if (o->kind == SHAPE_MESH) {
        const struct mesh *m = &q->s->meshes[o->u.mesh.id];
        if (o->xform < 0) return mesh8_occluded(m, q->rd, q->half, q->tmax, lanes);
        struct ray16 lrd;
        double lmax[16];
        for (uint32_t k = lanes; k; k &= k - 1) {
            int i = __builtin_ctz(k);
            double scale;
            ray16_set(&lrd, i, object_ray_xform(q->s, o, &lane_rays8(q)[i], &scale));
            lmax[i] = q->tmax[i] * scale;
        }
        ray16_fill_rest(&lrd, lanes);
        return mesh8_occluded(m, &lrd, q->half, lmax, lanes);
    }
    uint32_t blocked = 0;
    for (; lanes; lanes &= lanes - 1) {
        int i = __builtin_ctz(lanes);
        vec3 trans = v3(1, 1, 1);
        if (!object_filter(q->s, o, &lane_rays8(q)[i], q->tmax[i], &trans)) blocked |= 1u << i;
    }
    return blocked;
}

/* The float bounds of q's half for the node tests, as objects_walk has
 * them. */
CPU_AVX2_FN __m256 node_bounds8(const struct scene8 *q) {
    float f[8];
    for (int i = 0; i < 8; i++) {
        double t = q->tmax[8 * q->half + i];
        f[i] = t > 3e38 ? 3e38f : (float)t;
    }
    return _mm256_loadu_ps(f);
}

CPU_AVX2_FN unsigned tlas_nearest8(void *ctx, uint32_t first, uint32_t count, unsigned lanes,
                                   __m256 *tm) {
    struct scene8 *q = ctx;
    q->visits += (uint64_t)count * (uint64_t)__builtin_popcount(lanes);
    uint32_t all = (uint32_t)lanes << 8 * q->half;
    for (uint32_t k = first; k < first + count; k++) visit_nearest8(q, &q->s->objs[k], all);
    *tm = node_bounds8(q);
    return 0;
}

CPU_AVX2_FN unsigned tlas_any8(void *ctx, uint32_t first, uint32_t count, unsigned lanes,
                               __m256 *tm) {
    struct scene8 *q = ctx;
    (void)tm;
    uint32_t open = (uint32_t)lanes << 8 * q->half, blocked = 0;
    for (uint32_t k = first; k < first + count && blocked != open; k++) {
        q->visits += (uint64_t)__builtin_popcount(open & ~blocked);
        blocked |= visit_any8(q, &q->s->objs[k], open & ~blocked);
    }
    return blocked >> 8 * q->half;
}

/* The top level's walk for each half of the rays in active: a nearest-hit
 * one, or an any-hit one returning the rays blocked. */
CPU_AVX2_FN uint32_t tlas_walk8(struct scene8 *q, uint32_t active, bool any) {
    uint32_t blocked = 0;
    q->visits = 0;
    for (int h = 0; h < 2; h++) {
        unsigned lanes = active >> 8 * h & 0xffu;
        if (!lanes) continue;
        struct rays8_ray br;
        rays8_init(&br, q->rd, h, active, 4);
        q->half = h;
        __m256 tm = node_bounds8(q);
        unsigned got = rays8_walk(q->s->tlas.nodes, 4, NULL, 0, &br, &tm, lanes,
                                  any ? tlas_any8 : tlas_nearest8, NULL, q, !any);
        blocked |= (uint32_t)got << 8 * h;
    }
    meter_visits(q->visits, (uint64_t)__builtin_popcount(active)); /* a stop: at the next look */
    return blocked;
}

/* Object o for the rays in active, both halves. */
CPU_AVX2_FN void visit_both8(struct scene8 *q, const struct object *o, uint32_t active) {
    for (int h = 0; h < 2; h++) {
        q->half = h;
        uint32_t lanes = active & 0xffu << 8 * h;
        if (lanes) visit_nearest8(q, o, lanes);
    }
}

CPU_AVX2_FN uint32_t any_both8(struct scene8 *q, const struct object *o, uint32_t active) {
    uint32_t blocked = 0;
    for (int h = 0; h < 2; h++) {
        q->half = h;
        uint32_t lanes = active & 0xffu << 8 * h;
        if (lanes) blocked |= visit_any8(q, o, lanes);
    }
    return blocked;
}

/* The rays' bounds, lanes outside active copying the first one in it. */
static void bounds_load8(double out[16], const double tmax[16], uint32_t active) {
    int first = __builtin_ctz(active);
    for (int i = 0; i < 16; i++) out[i] = tmax[active >> i & 1 ? i : first];
}

CPU_AVX2_EXTERN uint32_t scene8_intersect(const rayd_scene *s, const struct ray16 *rd, const ray *r,
                                          const double tmax[16], uint32_t active,
                                          struct hit h[16]) {
    struct scene8 q;
    q.s = s, q.rd = rd, q.r = r, q.h = h;
    bounds_load8(q.tmax, tmax, active);
    for (int i = 0; i < 16; i++) q.best[i] = -1;
    q.base = s->planes, q.rank0 = 0;
    for (int32_t k = 0; k < s->nplanes; k++) visit_both8(&q, &s->planes[k], active);
    q.base = s->objs, q.rank0 = s->nplanes;
    if (s->nobjs == 1)
        visit_both8(&q, &s->objs[0], active);
    else if (s->nobjs > 1)
        tlas_walk8(&q, active, false);
    uint32_t hit = 0;
    for (int i = 0; i < 16; i++) hit |= (uint32_t)(q.best[i] >= 0) << i;
    return hit & active;
}

CPU_AVX2_EXTERN uint32_t scene8_blocked(const rayd_scene *s, const struct ray16 *rd, const ray *r,
                                        const double tmax[16], uint32_t active) {
    struct scene8 q;
    q.s = s, q.rd = rd, q.r = r, q.h = NULL;
    bounds_load8(q.tmax, tmax, active);
    q.base = s->objs, q.rank0 = s->nplanes;
    uint32_t open = active;
    for (int32_t k = 0; k < s->nplanes && open; k++) open &= ~any_both8(&q, &s->planes[k], open);
    if (open && s->nobjs == 1)
        open &= ~any_both8(&q, &s->objs[0], open);
    else if (open && s->nobjs > 1)
        open &= ~tlas_walk8(&q, open, true);
    return active & ~open;
}

#endif
