/* scene.c -- the frozen scene and the queries the tracer makes of it.
 *
 * The loader (scene_json.c) fills a rayd_scene and freezes it once; after
 * that it is immutable and shared by every rendering thread through a const
 * pointer.  Freezing moves unbounded objects (planes) to their own short
 * list and builds the BVH over the rest.  Intersection asks both.
 */
#include "scene.h"

#include <stdlib.h>
#include <string.h>

#include "error.h"

enum rayd_status scene_alloc(rayd_scene **out, struct rayd_error *err) {
    rayd_scene *s = calloc(1, sizeof *s);
    if (!s) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory");
    *out = s;
    return RAYD_OK;
}

void rayd_scene_free(rayd_scene *s) {
    if (!s) return;
    free(s->mats);
    free(s->lights);
    free(s->objs);
    free(s->planes);
    bvh_free(&s->bvh);
    free(s);
}

enum rayd_status scene_freeze(rayd_scene *s, struct rayd_error *err) {
    int32_t nb = 0, np = 0;
    for (int32_t i = 0; i < s->nobjs; i++) np += !shape_bounded(&s->objs[i]);
    if (np > 0) {
        s->planes = malloc(sizeof *s->planes * (size_t)np);
        if (!s->planes) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory");
        np = 0;
        for (int32_t i = 0; i < s->nobjs; i++) {
            if (shape_bounded(&s->objs[i]))
                s->objs[nb++] = s->objs[i];
            else
                s->planes[np++] = s->objs[i];
        }
        s->nobjs = nb;
        s->nplanes = np;
    }
    return bvh_build(&s->bvh, s->objs, s->nobjs, err);
}

bool scene_intersect(const rayd_scene *s, const ray *r, double tmin, double tmax, struct hit *h) {
    bool found = false;
    for (int32_t i = 0; i < s->nplanes; i++) {
        double t;
        if (plane_hit(&s->planes[i], r, tmin, tmax, &t)) {
            tmax = t;
            h->t = t;
            h->obj = i;
            h->plane = true;
            found = true;
        }
    }
    int32_t k = bvh_nearest(&s->bvh, s->objs, r, tmin, &tmax);
    if (k >= 0) {
        h->t = tmax;
        h->obj = k;
        h->plane = false;
        found = true;
    }
    return found;
}

struct shadow_ctx {
    const rayd_scene *s;
    vec3 trans;
};

/* Returns false (stop) as soon as nothing gets through. */
static bool shadow_filter(struct shadow_ctx *c, const struct object *o) {
    const struct material *m = &c->s->mats[o->material];
    if (m->transparency <= 0) {
        c->trans = v3(0, 0, 0);
        return false;
    }
    c->trans = v3_mul(c->trans, v3_scale(m->color, m->transparency));
    return v3_maxabs(c->trans) > 0;
}

static bool shadow_visit(void *ctx, int32_t obj, double t) {
    (void)t;
    struct shadow_ctx *c = ctx;
    return shadow_filter(c, &c->s->objs[obj]);
}

vec3 scene_transmittance(const rayd_scene *s, const ray *r, double tmax) {
    struct shadow_ctx c = {s, v3(1, 1, 1)};
    for (int32_t i = 0; i < s->nplanes; i++) {
        double t;
        if (plane_hit(&s->planes[i], r, 0, tmax, &t) && !shadow_filter(&c, &s->planes[i]))
            return c.trans;
    }
    bvh_each_hit(&s->bvh, s->objs, r, 0, tmax, shadow_visit, &c);
    return c.trans;
}

void rayd_scene_info(const rayd_scene *s, struct rayd_scene_info *info) {
    info->width = s->rs.width;
    info->height = s->rs.height;
    info->samples = s->rs.samples;
    info->max_depth = s->rs.max_depth;
    info->objects = (long)s->nobjs + s->nplanes;
    info->lights = s->nlights;
    info->bytes = sizeof *s + sizeof *s->mats * (size_t)s->nmats +
                  sizeof *s->lights * (size_t)s->nlights +
                  sizeof *s->objs * (size_t)(s->nobjs + s->nplanes) +
                  sizeof *s->bvh.nodes * (size_t)s->bvh.nnodes;
}
