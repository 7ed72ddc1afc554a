/* scene.h -- the frozen scene (internal view of rayd_scene). */
#ifndef SCENE_H
#define SCENE_H

#include <stdint.h>

#include "bvh.h"
#include "camera.h"
#include "light.h"
#include "material.h"
#include "shape.h"

struct render_settings {
    int width, height;
    int samples;   /* rays per pixel */
    int max_depth; /* secondary bounces allowed */
    vec3 background;
    uint64_t seed;
};

struct rayd_scene {
    struct camera cam;
    struct render_settings rs;
    struct material *mats;
    int nmats;
    struct light *lights;
    int nlights;
    struct object *objs;   /* bounded objects, in BVH order */
    int32_t nobjs;
    struct object *planes; /* unbounded objects, tested one by one */
    int32_t nplanes;
    struct bvh bvh;
};

struct hit {
    double t;
    int32_t obj;      /* index into objs, or into planes when plane is set */
    bool plane;
};

/* A scene under construction: objects are appended, then scene_freeze
 * splits bounded from unbounded objects and builds the BVH.  The scene owns
 * all its arrays. */
enum rayd_status scene_alloc(rayd_scene **out, struct rayd_error *err);
enum rayd_status scene_freeze(rayd_scene *s, struct rayd_error *err);

/* Nearest hit in (tmin, tmax); false when the ray escapes. */
bool scene_intersect(const rayd_scene *s, const ray *r, double tmin, double tmax, struct hit *h);

/* Fraction of light that passes from the ray's origin to distance tmax:
 * 0 behind an opaque object, (transparency * color) per transparent one. */
vec3 scene_transmittance(const rayd_scene *s, const ray *r, double tmax);

static inline const struct object *scene_object(const rayd_scene *s, const struct hit *h) {
    return h->plane ? &s->planes[h->obj] : &s->objs[h->obj];
}

#endif
