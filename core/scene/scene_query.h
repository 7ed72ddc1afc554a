/* scene_query.h -- what the one-ray queries of scene_query.c share with the
 * 16-ray packets of scene_packet.c.
 *
 * A packet must give every ray exactly the answer the ray would get alone,
 * though it visits objects in another order.  So the nearest-hit search is
 * order-free: among hits at exactly equal t the object of lower rank wins
 * (rank: its place in the scene's arrays, planes first), and its steps are
 * here for the packet code to apply lane by lane.
 */
#ifndef SCENE_QUERY_H
#define SCENE_QUERY_H

#include <string.h>

#include "scene/scene.h"

struct nearest {
    const rayd_scene *s;
    const struct xform *outer;
    const ray *r;
    struct hit *h;
    const struct object *base; /* rank of o: rank0 + (o - base) */
    long rank0, best;          /* best: rank of the hit so far, -1 none */
};

static inline long nearest_rank(const struct nearest *c, const struct object *o) {
    return c->rank0 + (long)(o - c->base);
}

/* The next double above a non-negative t (t itself if infinite). */
static inline double next_up(double t) {
    if (!(t >= 0) || t == INFINITY) return t;
    uint64_t u;
    memcpy(&u, &t, sizeof u);
    u++;
    memcpy(&t, &u, sizeof t);
    return t;
}

/* The bound to search object o up to: tmax, or just past it when o would
 * win a tie with the best hit so far. */
static inline double nearest_bound(const struct nearest *c, const struct object *o, double tmax) {
    return c->best >= 0 && nearest_rank(c, o) < c->best ? next_up(tmax) : tmax;
}
/* Keeps object o's hit h at t unless the best so far is nearer. */
void nearest_take(struct nearest *c, const struct object *o, double t, const struct hit *h,
                  double *tmax);
/* Both around object o's own query: an objects_walk visitor. */
bool nearest_visit(void *ctx, const struct object *o, double *tmax);

/* The ray in object o's space; *scale converts distances: t_obj = t * scale. */
ray object_ray_xform(const rayd_scene *s, const struct object *o, const ray *r, double *scale);

static inline ray object_ray(const rayd_scene *s, const struct object *o, const ray *r,
                             double *scale) {
    if (o->xform >= 0) return object_ray_xform(s, o, r, scale);
    *scale = 1;
    return *r;
}

/* object_ray for a walk that takes the ray by pointer (a mesh's): r
 * itself when o is untransformed, else buf filled.  A copy of r would
 * read it with 16-byte loads just after the caller wrote it 8 bytes at a
 * time; such loads cannot be forwarded from those stores and wait for
 * them to reach the cache, a good part of what a ray that misses a
 * mesh's box costs. */
static inline const ray *object_ray_at(const rayd_scene *s, const struct object *o, const ray *r,
                                       ray *buf, double *scale) {
    if (o->xform < 0) {
        *scale = 1;
        return r;
    }
    *buf = object_ray_xform(s, o, r, scale);
    return buf;
}

/* The bound to search a transformed object's own space up to, for the
 * world bound tmax: a few ulps past tmax * scale, so that a hit at or
 * just below tmax is found whatever rounding the two conversions do; the
 * hit is then kept or not by comparing in world units (t_obj / scale <
 * tmax).  So which of two nearly equal hits wins does not depend on which
 * object set tmax first. */
static inline double object_space_bound(double tmax, double scale) {
    return scale == 1 ? tmax : tmax * scale * (1 + 0x1p-50);
}

/* Whether mesh object o's hit mh, back in world units, is nearer than
 * tmax (a NaN is not). */
static inline bool object_mesh_nearer(const struct mesh_hit *mh, double scale, double tmax) {
    return (double)mh->t / scale < tmax;
}

/* Fills h from mesh object o's hit mh; returns its distance in world
 * units.  Inline, and apart from the test above: a packet decides each
 * lane's hit first and then writes it where it goes, with no struct hit
 * copied in between. */
static inline double object_mesh_fill(const struct object *o, const struct xform *outer,
                                      const struct mesh_hit *mh, double scale, struct hit *h) {
    double t = mh->t / scale;
    *h = (struct hit){.t = t, .leaf = o, .outer = outer, .part = 0, .orient = 0, .mh = *mh};
    return t;
}

/* Fills h (and *tmax, in world units) from mesh object o's hit mh, when
 * that is nearer than *tmax; false when not. */
static inline bool object_mesh_hit(const struct object *o, const struct xform *outer,
                                   const struct mesh_hit *mh, double scale, double *tmax,
                                   struct hit *h) {
    if (!object_mesh_nearer(mh, scale, *tmax)) return false;
    *tmax = object_mesh_fill(o, outer, mh, scale, h);
    return true;
}

/* Any hit of object o closer than tmax, through its material's filter:
 * false when no light passes any more. */
bool object_filter(const rayd_scene *s, const struct object *o, const ray *r, double tmax,
                   vec3 *trans);

/* The packets of 16 rays where the CPU stops at AVX2 (scene_packet8.c),
 * for scene_packet.c's entry points once cpu_avx2 holds: the nearest hits
 * into h, and (an opaque scene) the rays blocked.  r, when not NULL, holds
 * the rays of rd one by one. */
uint32_t scene8_intersect(const rayd_scene *s, const struct ray16 *rd, const ray *r,
                          const double tmax[16], uint32_t active, struct hit h[16]);
uint32_t scene8_blocked(const rayd_scene *s, const struct ray16 *rd, const ray *r,
                        const double tmax[16], uint32_t active);

#endif
