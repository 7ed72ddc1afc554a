/* scene.h -- the frozen scene (internal view of rayd_scene). */
#ifndef SCENE_H
#define SCENE_H

#include <stdint.h>

#include "bvh.h"
#include "camera.h"
#include "light.h"
#include "material.h"
#include "mesh.h"
#include "shape.h"
#include "xform.h"

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
    struct object *objs;   /* bounded objects, in top-level BVH order */
    int32_t nobjs;
    struct object *planes; /* unbounded objects, tested one by one */
    int32_t nplanes;
    struct mesh *meshes;   /* geometry that objects refer to */
    uint32_t nmeshes;
    struct xform *xforms;  /* placements that objects refer to */
    int32_t nxforms;
    struct bvh4 tlas;      /* over objs */
    bool brute;            /* tests only: every query tests every primitive */
};

struct hit {
    double t;
    int32_t obj;        /* index into objs, or into planes when plane is set */
    bool plane;
    struct mesh_hit mh; /* set for meshes */
};

/* What the shader needs to know about a hit. */
struct surface {
    vec3 p;           /* world-space point */
    vec3 n;           /* unit shading normal, outward */
    vec3 ng;          /* unit geometric normal, outward */
    const struct material *m;
    bool thin;        /* no inside: what passes through goes straight on */
    bool float_geom;  /* float geometry: larger offsets for secondary rays */
};

/* A scene under construction: objects are appended, then scene_freeze
 * splits bounded from unbounded objects and builds the top-level BVH.  The
 * scene owns all its arrays. */
enum rayd_status scene_alloc(rayd_scene **out, struct rayd_error *err);
enum rayd_status scene_freeze(rayd_scene *s, struct rayd_error *err);

/* Nearest hit with t in (0, tmax); false when the ray escapes. */
bool scene_intersect(const rayd_scene *s, const ray *r, double tmax, struct hit *h);

/* Fraction of light that passes from the ray's origin to distance tmax:
 * 0 behind an opaque object, (transparency * color) per transparent one. */
vec3 scene_transmittance(const rayd_scene *s, const ray *r, double tmax);

/* Point, normals and material of a hit of ray r. */
void scene_surface(const rayd_scene *s, const ray *r, const struct hit *h, struct surface *sf);

#endif
